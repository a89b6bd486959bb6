"""Flights (loss of contact, ``q < -3/2``, eq. 9) of a recorded time history, compiled.

The record is the one :func:`hertzsweep.kernels.integrate.measure` writes: per sample
``q, q', N/F_s, in contact`` (columns :data:`DISPLACEMENT`, :data:`VELOCITY`,
:data:`NORMAL_FORCE`, :data:`IN_CONTACT`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import CACHE

DISPLACEMENT, VELOCITY, NORMAL_FORCE, IN_CONTACT = 0, 1, 2, 3
RECORD_COLUMNS = 4
LOSS_OF_CONTACT = -1.5  # q at which d = 1 + 2q/3 vanishes (eq. 9)
CROSSING_BISECTIONS = 48  # halvings of one sample interval: 2^-48, below rounding of tau


@njit(cache=CACHE)
def crossing(record, i, dt):
    """Fraction s of the interval from sample i to i + 1 (``dt`` in tau) where the cubic
    Hermite interpolant of ``(q, q')`` crosses q = -3/2 (bisection; the ends lie on either
    side of it)."""
    q0, q1 = record[i, DISPLACEMENT], record[i + 1, DISPLACEMENT]
    v0, v1 = record[i, VELOCITY] * dt, record[i + 1, VELOCITY] * dt
    lo = 0.0
    hi = 1.0
    positive = q0 > LOSS_OF_CONTACT
    for _ in range(CROSSING_BISECTIONS):
        s = 0.5 * (lo + hi)
        s2 = s * s
        s3 = s2 * s
        q = (
            (2.0 * s3 - 3.0 * s2 + 1.0) * q0
            + (s3 - 2.0 * s2 + s) * v0
            + (-2.0 * s3 + 3.0 * s2) * q1
            + (s3 - s2) * v1
        )
        if (q > LOSS_OF_CONTACT) == positive:
            lo = s
        else:
            hi = s
    return 0.5 * (lo + hi)


@njit(cache=CACHE)
def flight_intervals(record, dt, first=0):
    """Every flight (run of samples out of contact) of a record, in tau from its start.

    Parameters
    ----------
    record : float[M, 4]
        ``q, q', N/F_s, in contact`` every ``dt``.
    dt : float
        Sample spacing in tau.
    first : int
        Index of ``record[0]`` in a longer record the times are counted in (a chunk of
        one: ``(first + i) dt``, the whole record's arithmetic).

    Returns
    -------
    start, end : float[F]
        The flight's bounds: where the Hermite interpolant of ``(q, q')`` between the
        samples on either side crosses q = -3/2; a flight running into the record's start
        (end) is cut at ``first dt`` (``(first + M) dt``, the end of the last recorded
        period).
    complete : int8[F]
        1 where both bounds lie inside the record, 0 where the record cuts the flight.
    """
    m = record.shape[0]
    count = 0
    for i in range(m):
        if record[i, IN_CONTACT] == 0.0 and (i == 0 or record[i - 1, IN_CONTACT] != 0.0):
            count += 1
    start = np.empty(count)
    end = np.empty(count)
    complete = np.ones(count, dtype=np.int8)
    f = -1
    for i in range(m):
        out = record[i, IN_CONTACT] == 0.0
        if out and (i == 0 or record[i - 1, IN_CONTACT] != 0.0):
            f += 1
            if i == 0:
                start[f] = first * dt
                complete[f] = 0
            else:
                start[f] = (first + i - 1 + crossing(record, i - 1, dt)) * dt
        if out and (i == m - 1 or record[i + 1, IN_CONTACT] != 0.0):
            if i == m - 1:
                end[f] = (first + m) * dt
                complete[f] = 0
            else:
                end[f] = (first + i + crossing(record, i, dt)) * dt
    return start, end, complete


__all__ = [
    "DISPLACEMENT",
    "IN_CONTACT",
    "LOSS_OF_CONTACT",
    "NORMAL_FORCE",
    "RECORD_COLUMNS",
    "VELOCITY",
    "crossing",
    "flight_intervals",
]
