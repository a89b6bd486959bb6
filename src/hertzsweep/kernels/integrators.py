"""The paper's explicit central-difference scheme, compiled.

Scheme (section 4.3 of the paper), with step h in tau and ``c_n = c(q_n)``::

    (q[n+1] - 2 q[n] + q[n-1]) / h^2 + c_n (q[n+1] - q[n-1]) / (2 h) + R(q[n]) = 1 + f_n

The damping term is centred, so the update stays explicit (linear in ``q[n+1]``) and
second-order accurate where the force is smooth. The state is the pair of consecutive
displacements ``(q[n-1], q[n])`` at a fixed h. Steps per period N is an integer, so the
excitation ``sigma sin(2 pi j / N)`` and the lock-in references come from per-period
tables, and a dwell of whole periods keeps the excitation phase continuous.

Contract of the kernels: plain floats and arrays in, plain tuples out, no I/O. Each
returns a ``status``: :data:`OK`, :data:`NON_FINITE` (the state is no longer finite),
or :data:`UNSTABLE` (``h^2 omega^2 >= 4`` was reached: the step is beyond the
stability limit at the compression the run actually reached). The transmitted force is
``N/F_s = R(q) + c(q) q'`` with ``q'[n] = (q[n+1] - q[n-1]) / (2 h)``; the kernels
accumulate ``N/F_s - 1`` so that tiny inputs lose no digits to the static part.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..core.model import VISCOUS, contact_terms

OK = 0
NON_FINITE = 1
UNSTABLE = 2


def period_tables(steps_per_period: int) -> tuple[np.ndarray, np.ndarray]:
    """``sin(2 pi j / N)`` and ``cos(2 pi j / N)`` for j = 0 .. N-1."""
    phase = 2.0 * np.pi * np.arange(steps_per_period) / steps_per_period
    return np.sin(phase), np.cos(phase)


def step_size(frequency_ratio: float, steps_per_period: int) -> float:
    """h in tau for N steps per excitation period ``2 pi / w``."""
    return 2.0 * np.pi / (frequency_ratio * steps_per_period)


@njit(cache=True, inline="always")
def _next(q_prev, q, excess_force, rm1, c, h2, half_h, law, inv_viscous):
    """One central-difference update (the scheme multiplied by h^2);
    ``excess_force = f_n``, the input above F_s. For the viscous law the denominator
    ``1 + c h / 2`` is constant and its inverse ``inv_viscous`` is computed once."""
    numerator = h2 * (excess_force - rm1) + 2.0 * q - q_prev * (1.0 - c * half_h)
    if law == VISCOUS:
        return numerator * inv_viscous
    return numerator / (1.0 + c * half_h)


@njit(cache=True, inline="always")
def _next_viscous(q_prev, q, excess_force, d, sd, h2, damp_prev, inv_viscous):
    """The viscous update rearranged so that one FMA follows the square root (the loop is
    latency-bound): ``q[n+1] = P - Q sqrt(d)`` with ``P``, ``Q`` computed alongside it.
    ``damp_prev = 1 - c h / 2``; ``sd = sqrt(max(d, 0))``, so ``d sd = R(q)`` also out
    of contact."""
    p = (h2 * (excess_force + 1.0) + 2.0 * q - q_prev * damp_prev) * inv_viscous
    return p - (h2 * inv_viscous * d) * sd


@njit(cache=True, inline="always")
def _step(q_prev, q, excess_force, zeta, law, exponent, h2, half_h, damp_prev, inv_viscous):
    """One step of either form: ``(d, sqrt(d), R(q) - 1, c(q), q[n+1])``."""
    if law == VISCOUS:
        d = 1.0 + q * (2.0 / 3.0)
        sd = math.sqrt(d) if d > 0.0 else 0.0
        q_next = _next_viscous(q_prev, q, excess_force, d, sd, h2, damp_prev, inv_viscous)
        return d, sd, d * sd - 1.0, 2.0 * zeta, q_next
    d, sd, rm1, c = contact_terms(q, zeta, law, exponent)
    q_next = _next(q_prev, q, excess_force, rm1, c, h2, half_h, law, inv_viscous)
    return d, sd, rm1, c, q_next


@njit(cache=True)
def advance(q_prev, q, h, sigma, sin_table, periods, zeta, law, exponent):
    """Integrate whole periods without measuring. Returns ``(q_prev, q, status)``."""
    n = sin_table.shape[0]
    h2 = h * h
    half_h = 0.5 * h
    inv_viscous = 1.0 / (1.0 + 2.0 * zeta * half_h)
    limit = 4.0 / h2  # h^2 omega^2 < 4, omega^2 = sqrt(d)
    damp_prev = 1.0 - 2.0 * zeta * half_h
    for _ in range(periods):
        for j in range(n):
            d, sd, rm1, c, q_next = _step(
                q_prev, q, sigma * sin_table[j], zeta, law, exponent, h2, half_h, damp_prev,
                inv_viscous,
            )  # fmt: skip
            if sd >= limit:
                return q_prev, q, UNSTABLE
            q_prev = q
            q = q_next
        if not (math.isfinite(q) and math.isfinite(q_prev)):
            return q_prev, q, NON_FINITE
    return q_prev, q, OK


@njit(cache=True)
def measure(
    q_prev,
    q,
    h,
    sigma,
    sin_table,
    cos_table,
    periods,
    zeta,
    law,
    exponent,
    harmonics,
    coefficients,
    record,
    stride,
):
    """Integrate whole periods and read them like the rig's instruments.

    Parameters
    ----------
    harmonics : int64[K]
        Orders k to demodulate (each below N/2).
    coefficients : float64[K, 2]
        Output: ``sum (N/F_s - 1) cos(k theta_j)``, ``sum (N/F_s - 1) sin(k theta_j)``.
    record : float64[M, 4]
        Output when ``stride > 0``: every ``stride``-th step, ``q, q', N/F_s, in contact``.
    stride : int
        0 records nothing.

    Returns
    -------
    tuple
        ``(q_prev, q, status, sum_excess_force, force_max, force_min, loss_steps,
        longest_inner, lead_run, trail_run, q_prev_last, q_last)``: the flight run
        lengths are in steps (``lead_run`` starts the record, ``trail_run`` ends it, so
        that a flight across the period boundary can be joined), and ``(q_prev_last,
        q_last)`` is the state at the start of the last period.
    """
    n = sin_table.shape[0]
    n_harm = harmonics.shape[0]
    h2 = h * h
    half_h = 0.5 * h
    inv_viscous = 1.0 / (1.0 + 2.0 * zeta * half_h)
    damp_prev = 1.0 - 2.0 * zeta * half_h
    inv_2h = 1.0 / (2.0 * h)
    limit = 4.0 / h2
    index = np.zeros(n_harm, dtype=np.int64)
    coefficients[:, :] = 0.0
    total = 0.0
    force_max = -np.inf
    force_min = np.inf
    loss_steps = 0
    run = 0
    longest = 0
    lead = -1
    q_prev_last = q_prev
    q_last = q
    sample = 0
    status = OK
    for p in range(periods):
        if p == periods - 1:
            q_prev_last = q_prev
            q_last = q
        for i in range(n_harm):
            index[i] = 0
        for j in range(n):
            d, sd, rm1, c, q_next = _step(
                q_prev, q, sigma * sin_table[j], zeta, law, exponent, h2, half_h, damp_prev,
                inv_viscous,
            )  # fmt: skip
            if sd >= limit:
                status = UNSTABLE
                break
            velocity = (q_next - q_prev) * inv_2h
            excess = rm1 + c * velocity  # N/F_s - 1
            total += excess
            for i in range(n_harm):
                k = index[i]
                coefficients[i, 0] += excess * cos_table[k]
                coefficients[i, 1] += excess * sin_table[k]
                k += harmonics[i]
                if k >= n:
                    k -= n
                index[i] = k
            if excess > force_max:
                force_max = excess
            if excess < force_min:
                force_min = excess
            if d > 0.0:
                if run > 0:
                    if lead < 0:
                        lead = run
                    elif run > longest:
                        longest = run
                    run = 0
                elif lead < 0:
                    lead = 0
            else:
                loss_steps += 1
                run += 1
            if stride > 0 and (p * n + j) % stride == 0:
                record[sample, 0] = q
                record[sample, 1] = velocity
                record[sample, 2] = excess + 1.0
                record[sample, 3] = 1.0 if d > 0.0 else 0.0
                sample += 1
            q_prev = q
            q = q_next
        if status == OK and not (math.isfinite(q) and math.isfinite(q_prev)):
            status = NON_FINITE
        if status != OK:
            break
    if lead < 0:  # never in contact: one flight over the whole record
        lead = run
    return (q_prev, q, status, total, force_max + 1.0, force_min + 1.0,
            loss_steps, longest, lead, run, q_prev_last, q_last)  # fmt: skip


@njit(cache=True)
def restart(q_prev, q, h_old, h_new, zeta, law, exponent):
    """Carry a state from step h_old to h_new at a period boundary (excitation phase 0).

    One more step gives ``q'`` and ``q''`` at the boundary (centred differences), and
    ``q[-1] = q - h_new q' + h_new^2 / 2 q''`` restarts the scheme: second order, the
    same start a run from ``(q, q')`` would use. Returns the new ``q_prev``.
    """
    h2 = h_old * h_old
    d, sd, rm1, c = contact_terms(q, zeta, law, exponent)
    q_next = _next(q_prev, q, 0.0, rm1, c, h2, 0.5 * h_old, -1, 0.0)
    velocity = (q_next - q_prev) / (2.0 * h_old)
    acceleration = (q_next - 2.0 * q + q_prev) / h2
    return q - h_new * velocity + 0.5 * h_new * h_new * acceleration


@njit(cache=True)
def start_from(q, velocity, h, zeta, law, exponent):
    """``q_prev`` that starts the scheme at ``(q, q')`` with excitation phase 0."""
    d, sd, rm1, c = contact_terms(q, zeta, law, exponent)
    acceleration = -rm1 - c * velocity
    return q - h * velocity + 0.5 * h * h * acceleration
