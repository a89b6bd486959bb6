"""Integration kernels: whole periods of one or many trajectories, and the instruments.

Contract: plain floats, arrays and the small records of :mod:`.laws` and :mod:`.scheme` in;
plain tuples out; no I/O. The state crossing the boundary is ``(q[n-1], q[n])`` (the
displacement); inside, the kernels carry the compression (:mod:`.scheme`). A dwell is a
whole number of periods of N steps, so the excitation ``sin(2 pi j / N)`` and the lock-in
references come from per-period tables (:class:`Drive`).

Many trajectories (``T``, the sweeps of a scene: every direction x sigma) advance in one
loop with the trajectory index innermost and no branches, so that LLVM vectorises across
them; each trajectory performs exactly the operations of a single one (:func:`step`), so
one trajectory alone and T together give the same numbers bit for bit. The readings of a
single trajectory are those of a batch of one: there is one set of instruments,
:func:`measure`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from . import CACHE
from .laws import terms
from .scheme import (
    NON_FINITE,
    OK,
    STOPPED,
    UNSTABLE,
    compressions,
    constant,
    constants,
    displacements,
    forcing,
    make_step,
    make_steps,
    period_tables,
    to_compression,
    to_displacement,
    update,
)
from .stop import REQUEST, requested

Drive = namedtuple(
    "Drive",
    ["sigma", "sin_table", "cos_table", "harmonics", "stop", "lockin_sin", "lockin_cos", "orders"],
)
"""The input and the lock-in: ``sigma`` float[T] (input level of each trajectory),
``sin_table``, ``cos_table`` float[N] (``sin``/``cos(2 pi j / N)``: the excitation),
``harmonics`` float64[K] (the orders k demodulated, each below N/2: whole, or multiples of
1/2, 1/3, 1/4), ``stop`` (:data:`.stop.REQUEST`, polled once a period: a loop returns
:data:`~.scheme.STOPPED` when it is set), and the lock-in's references: ``lockin_sin``,
``lockin_cos`` float[N L] (``sin``/``cos(2 pi i / (N L))``, L the orders' common
denominator, :func:`.methods.common_denominator`; entry ``j L`` is entry j of the
excitation's table, the very same arrays when L = 1) and ``orders`` int64[K] (``m = k L``:
order k advances m entries a step). A measured record starts at reference phase 0 and
its index runs on over the periods (order k's phase after p periods is ``2 pi k p``), so a
reading spans whole response periods of L excitation periods."""

Readout = namedtuple("Readout", ["coefficients", "sums", "counts", "record", "stride", "extra"])
"""What :func:`measure` reads, per trajectory t (last axis):
``coefficients`` float[K, 2, T]: ``sum (N/F_s - 1) cos(k theta_j)``, ``... sin(k theta_j)``;
``sums`` float[SUMS, T] (:data:`SUM_FIELDS`); ``counts`` float64[COUNTS, T]
(:data:`COUNT_FIELDS`, flight runs in steps: ``lead`` starts the record, ``trail`` ends it,
so that a flight across the period boundary can be joined); ``record`` float[M, 4, T]: every
``stride``-th step ``q, q', N/F_s, in contact`` (``stride = 0``: none); ``extra`` float[E, T]:
a model's own sums (E = 0 for the single model; :data:`.ball.BALL_FIELDS`)."""

SUM_FIELDS = ("total", "force_max", "force_min", "q_prev_last", "q_last", "q_prev", "q")
COUNT_FIELDS = ("loss", "longest", "lead", "trail")


def new_readout(
    harmonics: int,
    trajectories: int,
    record=None,
    stride: int = 0,
    columns: int = 4,
    extra: int = 0,
) -> Readout:
    """Output buffers for :func:`measure` (``record`` float[M, columns, T]; ``extra`` rows
    of a model's own sums, none for the single model)."""
    if record is None or stride <= 0:
        record, stride = np.zeros((0, columns, trajectories)), 0
    sums = np.zeros((len(SUM_FIELDS), trajectories))
    counts = np.zeros((len(COUNT_FIELDS), trajectories))  # whole numbers, as floats
    coefficients = np.zeros((harmonics, 2, trajectories))
    own = np.zeros((extra, trajectories))
    return Readout(coefficients, sums, counts, record, int(stride), own)


@njit(cache=CACHE, inline="always")
def step(law, d_prev, d, load, constants):
    """One step: ``(sqrt(d), c(d), d[n+1])`` (the only place the scheme is evaluated)."""
    root, c = terms(law, d)
    return root, c, update(law, d_prev, d, root, c, load, constants)


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance(q_prev, q, h, law, drive, periods):
    """Whole periods of one trajectory (``drive.sigma[0]``), without measuring.

    Returns ``(q_prev, q, status)``: :data:`~.scheme.UNSTABLE` when ``h^2 omega^2 >= 4``
    was reached, :data:`~.scheme.NON_FINITE` when the state is no longer finite (checked
    after each period).
    """
    s = make_step(law, h)
    sigma = drive.sigma[0]
    table = drive.sin_table
    d_prev = to_compression(q_prev)
    d = to_compression(q)
    peak = 0.0
    for _ in range(periods):
        for j in range(table.shape[0]):
            root, c, d_next = step(law, d_prev, d, forcing(sigma, table[j]), constant(s))
            peak = root if root > peak else peak
            d_prev = d
            d = d_next
        status = _status(d_prev, d, peak, s.limit, drive.stop)
        if status != OK:
            return to_displacement(d_prev), to_displacement(d), status
    return to_displacement(d_prev), to_displacement(d), OK


@njit(cache=CACHE, inline="always")
def _finite(d_prev, d):
    """Whether the state is finite as a displacement (a finite d near the largest double
    overflows in ``q = 3 (d - 1) / 2``)."""
    return math.isfinite(to_displacement(d)) and math.isfinite(to_displacement(d_prev))


@njit(cache=CACHE, inline="always")
def _status(d_prev, d, peak, limit, stop):
    if peak >= limit:
        return UNSTABLE
    if not _finite(d_prev, d):
        return NON_FINITE
    if requested(stop):
        return STOPPED
    return OK


@njit(cache=CACHE, error_model="numpy")
def _batch_status(d_prev, d, peak, limit, stop):
    """``(status, trajectory)``: the first trajectory unstable, else the first non-finite,
    else :data:`~.scheme.STOPPED` (trajectory -1) when a stop was requested."""
    for t in range(d.shape[0]):
        if peak[t] >= limit[t]:
            return UNSTABLE, t
    for t in range(d.shape[0]):
        if not _finite(d_prev[t], d[t]):
            return NON_FINITE, t
    if requested(stop):
        return STOPPED, -1
    return OK, -1


@njit(cache=CACHE, error_model="numpy")
def _periods(law, s, d_prev, d, drive, periods, peak):
    """Whole periods of T trajectories in place (the vectorised loop of :func:`advance`)."""
    table = drive.sin_table
    sigma = drive.sigma
    for _ in range(periods):
        for j in range(table.shape[0]):
            sj = table[j]
            for t in range(d.shape[0]):
                dt = d[t]
                root, c, d_next = step(law, d_prev[t], dt, forcing(sigma[t], sj), constants(s, t))
                peak[t] = root if root > peak[t] else peak[t]
                d_prev[t] = dt
                d[t] = d_next
        status, t = _batch_status(d_prev, d, peak, s.limit, drive.stop)
        if status != OK:
            return status, t
    return OK, -1


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance_batch(q_prev, q, h, law, drive, periods):
    """Whole periods of T trajectories, in place on ``q_prev``, ``q`` (float[T]), each at
    its own step ``h[t]`` and level ``drive.sigma[t]``. Returns ``(status, trajectory)``:
    OK and -1, or the first trajectory that failed (checked after each period)."""
    d_prev = compressions(q_prev)
    d = compressions(q)
    status, t = _periods(law, make_steps(law, h), d_prev, d, drive, periods, np.zeros(q.shape[0]))
    displacements(d_prev, q_prev)
    displacements(d, q)
    return status, t


TALLY_START = (0.0, -np.inf, np.inf, 0.0, 0.0, -1.0, 0.0)  # total, max, min, loss, longest,
# lead (-1: no contact seen yet), run: the running sums of :func:`tally`


@njit(cache=CACHE, inline="always")
def observe(law, d_prev, d, load, constants, rate):
    """One step read like the rig's instruments: ``(sqrt(d), d[n+1], N/F_s - 1, q')`` with
    ``N/F_s = R + c q'`` and ``q' = (q[n+1] - q[n-1]) / (2 h)`` (``rate = 3 / (4 h)``)."""
    root, c, d_next = step(law, d_prev, d, load, constants)
    v = (d_next - d_prev) * rate
    return root, d_next, d * root - 1.0 + c * v, v


@njit(cache=CACHE, inline="always")
def tally(acc, x, touching):
    """The running sums after one more step of ``N/F_s - 1 = x``: its sum and extremes, the
    steps out of contact, the longest inner flight, the run before the first contact
    (``lead``) and the current run (whole numbers, as floats)."""
    total, force_max, force_min, loss, longest, lead, run = acc
    return (
        total + x,
        x if x > force_max else force_max,
        x if x < force_min else force_min,
        loss + (0.0 if touching else 1.0),
        run if (touching and lead >= 0.0 and run > longest) else longest,
        run if (touching and lead < 0.0) else lead,
        0.0 if touching else run + 1.0,
    )


@njit(cache=CACHE)
def _finish(readout, t, acc, cos_sum, sin_sum):
    """Trajectory t's sums into the readout (the extremes as N/F_s)."""
    total, force_max, force_min, loss, longest, lead, run = acc
    for i in range(cos_sum.shape[0]):
        readout.coefficients[i, 0, t] = cos_sum[i]
        readout.coefficients[i, 1, t] = sin_sum[i]
    readout.sums[0, t] = total
    readout.sums[1, t] = force_max + 1.0
    readout.sums[2, t] = force_min + 1.0
    readout.counts[0, t] = loss
    readout.counts[1, t] = longest
    readout.counts[2, t] = run if lead < 0.0 else lead  # never in contact: one flight
    readout.counts[3, t] = run


@njit(cache=CACHE)
def _lockin_tables(drive):
    """``(index, shift)``: each harmonic's position in the lock-in's tables (0: the first
    measured step is at reference phase 0) and its step (``m mod N L``, ``m = k L``)."""
    n = drive.lockin_sin.shape[0]
    shift = np.empty(drive.orders.shape[0], dtype=np.int64)
    for i in range(shift.shape[0]):
        shift[i] = drive.orders[i] % n
    return np.zeros_like(shift), shift


@njit(cache=CACHE, inline="always")
def denominator(drive):
    """L, the common denominator of the drive's orders (any method's drive: its lock-in's
    tables hold L times the entries of its excitation's)."""
    return drive.lockin_sin.shape[0] // drive.sin_table.shape[0]


@njit(cache=CACHE, inline="always")
def _next_index(index, shift, n):
    """Every harmonic's table position one step on (the tables of ``n`` entries)."""
    for i in range(index.shape[0]):
        m = index[i] + shift[i]
        index[i] = m - n if m >= n else m


@njit(cache=CACHE, error_model="numpy", nogil=True)
def measure_one(q_prev, q, h, law, drive, periods, readout):
    """:func:`measure` for one trajectory (``drive.sigma[0]``, ``h[0]``), its state in
    registers: the same :func:`observe` and :func:`tally`, so the same numbers bit for bit.
    """
    s = make_step(law, h[0])
    k = constant(s)
    sigma = drive.sigma[0]
    table = drive.sin_table
    n = table.shape[0]
    d_prev = to_compression(q_prev[0])
    d = to_compression(q[0])
    peak = 0.0
    acc = TALLY_START
    cos_sum = np.zeros(drive.orders.shape[0])
    sin_sum = np.zeros_like(cos_sum)
    index, shift = _lockin_tables(drive)
    references = drive.lockin_sin.shape[0]
    sample = 0
    for p in range(periods):
        if p == periods - 1:
            readout.sums[3, 0] = to_displacement(d_prev)
            readout.sums[4, 0] = to_displacement(d)
        for j in range(n):
            root, d_next, x, v = observe(law, d_prev, d, forcing(sigma, table[j]), k, s.rate)
            peak = root if root > peak else peak
            acc = tally(acc, x, d > 0.0)
            if readout.stride > 0 and (p * n + j) % readout.stride == 0:
                _sample(readout.record[sample, :, 0], d, v, x)
                sample += 1
            for i in range(index.shape[0]):
                cos_sum[i] += x * drive.lockin_cos[index[i]]
                sin_sum[i] += x * drive.lockin_sin[index[i]]
            _next_index(index, shift, references)
            d_prev = d
            d = d_next
        status = _status(d_prev, d, peak, s.limit, drive.stop)
        if status != OK:
            return status, 0
    _finish(readout, 0, acc, cos_sum, sin_sum)
    q_prev[0] = readout.sums[5, 0] = to_displacement(d_prev)
    q[0] = readout.sums[6, 0] = to_displacement(d)
    return OK, -1


LANES = 72
"""Trajectories per block of :func:`measure`'s working array. Each running quantity of
a block is a row of LANES values, so two rows lie a constant LANES elements apart: LLVM
sees that no two overlap and vectorises a step across the block without run-time alias
checks. (With rows of unknown stride it checks every pair at each loop entry, and its
cost model then keeps loops of fewer than 24 to 40 trajectories scalar: the readings of
16 trajectories cost 5 ns a trajectory-step, against 0.8 for the bare step; in blocks,
2.) 72 values are 9 whole 64-byte lines, and no two of a block's rows lie a multiple of
4 KiB apart (64 values did, and ran slower in some processes)."""

# the rows of a block: the state, the step's constants, the readings of the step, the
# running sums of :func:`tally` (:data:`TALLY_START`), then cos and sin sums per harmonic
D_PREV, D, PEAK, LOAD, HALF_H, C0, A, B, K, RATE, X, V = range(12)
TALLY = 12
FOURIER = TALLY + len(TALLY_START)


@njit(cache=CACHE, inline="always")
def _lane(t):
    """``(block, i)``: trajectory t is lane i of that block (its value of row r at
    ``i + r * LANES``)."""
    return t // LANES, t % LANES


@njit(cache=CACHE)
def _blocks(q_prev, q, s, drive):
    """The working array of :func:`measure`, filled in: float[blocks, rows x LANES],
    ``rows = FOURIER + 2 K``."""
    count = q.shape[0]
    shape = ((count + LANES - 1) // LANES, (FOURIER + 2 * drive.orders.size) * LANES)
    size = shape[0] * shape[1]
    raw = np.zeros(size + 8)  # rows start on a 64-byte line: whole vectors, one line each
    first = ((-raw.ctypes.data) % 64) // 8
    lanes = raw[first : first + size].reshape(shape)
    a, b, k = s.fixed
    for t in range(count):
        block, i = _lane(t)
        row = lanes[block]
        row[i + D_PREV * LANES] = to_compression(q_prev[t])
        row[i + D * LANES] = to_compression(q[t])
        row[i + LOAD * LANES] = drive.sigma[t]
        row[i + HALF_H * LANES] = s.half_h[t]
        row[i + C0 * LANES] = s.c0[t]
        row[i + A * LANES] = a[t]
        row[i + B * LANES] = b[t]
        row[i + K * LANES] = k[t]
        row[i + RATE * LANES] = s.rate[t]
        for r in range(len(TALLY_START)):
            row[i + (TALLY + r) * LANES] = TALLY_START[r]
    return lanes


@njit(cache=CACHE, inline="always")
def _tallied(row, i):
    """The running sums of :func:`tally` of lane i of a block."""
    j = i + TALLY * LANES
    return (
        row[j],
        row[j + LANES],
        row[j + 2 * LANES],
        row[j + 3 * LANES],
        row[j + 4 * LANES],
        row[j + 5 * LANES],
        row[j + 6 * LANES],
    )


@njit(cache=CACHE, error_model="numpy", inline="always")
def _step_block(law, row, width, sj):
    """One step of the first ``width`` lanes of a block (``row``, float[rows x LANES]):
    :func:`observe`, the peak root and :func:`tally`, in one loop over the lanes."""
    for i in range(width):
        d = row[i + D * LANES]
        constants = (
            row[i + HALF_H * LANES],
            row[i + C0 * LANES],
            row[i + A * LANES],
            row[i + B * LANES],
            row[i + K * LANES],
        )
        load = forcing(row[i + LOAD * LANES], sj)
        root, d_next, x, v = observe(
            law, row[i + D_PREV * LANES], d, load, constants, row[i + RATE * LANES]
        )
        peak = row[i + PEAK * LANES]
        row[i + PEAK * LANES] = root if root > peak else peak
        row[i + X * LANES] = x
        row[i + V * LANES] = v
        row[i + D_PREV * LANES] = d
        row[i + D * LANES] = d_next
        acc = tally(_tallied(row, i), x, d > 0.0)
        j = i + TALLY * LANES
        row[j], row[j + LANES], row[j + 2 * LANES] = acc[0], acc[1], acc[2]
        row[j + 3 * LANES], row[j + 4 * LANES] = acc[3], acc[4]
        row[j + 5 * LANES], row[j + 6 * LANES] = acc[5], acc[6]


@njit(cache=CACHE, error_model="numpy", inline="always")
def _lockin_block(sums, x, width, ck, sk):
    """One step of one harmonic's Fourier sums of a block (``sums``: its two rows)."""
    for i in range(width):
        sums[i] += x[i] * ck
        sums[i + LANES] += x[i] * sk


@njit(cache=CACHE, error_model="numpy", nogil=True)
def measure(q_prev, q, h, law, drive, periods, readout):
    """Whole periods of T trajectories (in place on ``q_prev``, ``q``), read like the rig's
    instruments into ``readout`` (:class:`Readout`, from :func:`new_readout`): the
    exact Fourier sums of ``N/F_s - 1`` for the listed harmonics (the lock-in), its sum and
    extremes, the steps out of contact and the flight runs, the state at the start of the
    last period.

    ``N/F_s = R + c q'`` with ``q' = (q[n+1] - q[n-1]) / (2 h)``; the sums hold
    ``N/F_s - 1`` so that tiny inputs lose no digits to the static part. The trajectories
    advance in blocks of :data:`LANES`, each with the operations of :func:`measure_one`.
    Returns ``(status, trajectory)`` as :func:`advance_batch`.
    """
    s = make_steps(law, h)
    table = drive.sin_table
    count = q.shape[0]
    n = table.shape[0]
    lanes = _blocks(q_prev, q, s, drive)
    index, shift = _lockin_tables(drive)
    references = drive.lockin_sin.shape[0]
    sample = 0
    for p in range(periods):
        if p == periods - 1:
            _state_into(lanes, count, readout.sums[3], readout.sums[4])
        for j in range(n):
            for block in range(lanes.shape[0]):
                row = lanes[block]
                width = min(LANES, count - block * LANES)
                _step_block(law, row, width, table[j])
                excess = row[X * LANES : (X + 1) * LANES]
                for i in range(index.shape[0]):
                    first = (FOURIER + 2 * i) * LANES
                    ck, sk = drive.lockin_cos[index[i]], drive.lockin_sin[index[i]]
                    _lockin_block(row[first : first + 2 * LANES], excess, width, ck, sk)
            if readout.stride > 0 and (p * n + j) % readout.stride == 0:
                for t in range(count):
                    block, i = _lane(t)
                    row = lanes[block]
                    _sample(
                        readout.record[sample, :, t],
                        row[i + D_PREV * LANES],
                        row[i + V * LANES],
                        row[i + X * LANES],
                    )
                sample += 1
            _next_index(index, shift, references)
        status, bad = _block_status(lanes, count, s.limit, drive.stop)
        if status != OK:
            return status, bad
    fourier = np.empty((2, drive.orders.shape[0]))
    for t in range(count):
        block, i = _lane(t)
        row = lanes[block]
        for k in range(fourier.shape[1]):
            fourier[0, k] = row[i + (FOURIER + 2 * k) * LANES]
            fourier[1, k] = row[i + (FOURIER + 2 * k + 1) * LANES]
        _finish(readout, t, _tallied(row, i), fourier[0], fourier[1])
    _state_into(lanes, count, q_prev, q)
    readout.sums[5, :] = q_prev
    readout.sums[6, :] = q
    return OK, -1


@njit(cache=CACHE)
def _state_into(lanes, count, q_prev, q):
    """The blocks' state as displacements, into ``q_prev``, ``q`` (float[T])."""
    for t in range(count):
        block, i = _lane(t)
        q_prev[t] = to_displacement(lanes[block, i + D_PREV * LANES])
        q[t] = to_displacement(lanes[block, i + D * LANES])


@njit(cache=CACHE)
def _block_status(lanes, count, limit, stop):
    """:func:`_batch_status` of the blocks."""
    peak = np.empty(count)
    d_prev = np.empty(count)
    d = np.empty(count)
    for t in range(count):
        block, i = _lane(t)
        peak[t] = lanes[block, i + PEAK * LANES]
        d_prev[t] = lanes[block, i + D_PREV * LANES]
        d[t] = lanes[block, i + D * LANES]
    return _batch_status(d_prev, d, peak, limit, stop)


@njit(cache=CACHE, inline="always")
def _sample(row, d, v, x):
    """One recorded sample: ``q, q', N/F_s, in contact``."""
    row[0] = to_displacement(d)
    row[1] = v
    row[2] = x + 1.0
    row[3] = 1.0 if d > 0.0 else 0.0


@njit(cache=CACHE, error_model="numpy")
def restart(q_prev, q, h_old, h_new, law):
    """Carry a state from step h_old to h_new at a period boundary (excitation phase 0).

    One more step gives ``q'`` and ``q''`` at the boundary (centred differences), and
    ``q[-1] = q - h_new q' + h_new^2 / 2 q''`` restarts the scheme: second order, the
    same start a run from ``(q, q')`` would use. Returns the new ``q_prev``.
    """
    s = make_step(law, h_old)
    d_prev = to_compression(q_prev)
    d = to_compression(q)
    _, _, d_next = step(law, d_prev, d, 1.0, constant(s))
    rate = (d_next - d_prev) / (2.0 * h_old)
    curvature = (d_next - 2.0 * d + d_prev) / (h_old * h_old)
    return to_displacement(d - h_new * rate + 0.5 * h_new * h_new * curvature)


@njit(cache=CACHE, error_model="numpy")
def retune_batch(q_prev, q, h, h_new, law):
    """:func:`restart` for every trajectory whose step changes; ``h`` becomes ``h_new``."""
    for t in range(q.shape[0]):
        if h_new[t] != h[t]:
            q_prev[t] = restart(q_prev[t], q[t], h[t], h_new[t], law)
            h[t] = h_new[t]


@njit(cache=CACHE, error_model="numpy")
def start_from(q, velocity, h, law):
    """``q_prev`` that starts the scheme at ``(q, q')`` with excitation phase 0."""
    root, c = terms(law, to_compression(q))
    acceleration = 1.0 - to_compression(q) * root - c * velocity
    return q - h * velocity + 0.5 * h * h * acceleration


tables = period_tables  # the per-period tables of the excitation and the lock-in


def inputs(sigma, sin_table, cos_table, harmonics, lockin=None):
    """The :class:`Drive` of the levels ``sigma`` (float[T]); ``lockin = (lockin_sin,
    lockin_cos, orders)``, default the excitation's tables and the orders as whole numbers
    (L = 1)."""
    harmonics = np.asarray(harmonics, dtype=np.float64)
    if lockin is None:
        lockin = (sin_table, cos_table, np.rint(harmonics).astype(np.int64))
    return Drive(sigma, sin_table, cos_table, harmonics, REQUEST, *lockin)


start = start_from  # the state's other member, q[-1], at (q, q')

__all__ = [
    "COUNT_FIELDS",
    "SUM_FIELDS",
    "Drive",
    "Readout",
    "advance",
    "advance_batch",
    "denominator",
    "measure",
    "measure_one",
    "new_readout",
    "restart",
    "retune_batch",
    "start_from",
    "step",
]
