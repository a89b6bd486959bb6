"""Random excitation: T trajectories in lockstep under sampled forcing, and their tallies.

Three kernels, one contract (:data:`KERNELS`, by ``(model.kind, solver.method)``):
``advance(law, h, state, drive, g, record) -> (status, trajectory)`` integrates one segment
of ``S = record.excess.shape[0]`` steps of T trajectories in place on ``state`` and writes
each step's ``N/F_s - 1`` and contact flag into the record; ``at_rest(drive, g, h, law)``
gives the state at rest at the static equilibrium at the record's start. Trajectory t's
load is ``1 + level[t] g(tau)`` (the sine's ``1 + sigma sin``), ``g`` the unit forcing of
every realisation sampled ``per_step`` times a step (float[per_step S (+1), R], from the
segment's start). The state carries everything a step needs from the steps before it, so
that a record cut into segments gives the numbers of one long run bit for bit.

- **Single model, central difference** (:func:`advance`): the scheme of :mod:`.scheme`;
  the state is the compression pair ``(d[n-1], d[n])`` (float[2, T]).
- **Single model, rk4** (:func:`advance_rk4`): the method of :mod:`.rk` with its crossings
  located, split and their singular terms corrected as in a sine run; the loads at a
  step's start, middle and end are the samples at the steps and half steps
  (``per_step = 2``: g holds ``2 S + 1`` rows). At a crossing inside a step the loads at
  the crossing and at the middles of its two parts come from the quadratic through the
  step's three samples (:func:`_interpolated`): an error ``O(h^3 g3)`` in the load (g3
  the largest third derivative of g, about ``w_high^3``) over parts shorter than h, so
  ``O(h^4)`` in q' a crossing; over a record whose number of crossings does not grow as
  h falls, ``O(h^4)``: of the method's own order in contact and below its ``h^(7/2)``
  through impacts. The state is :data:`RK4_ROWS` (float[4, T]). N/F_s is read at the
  step's start ``(q, q')``, exactly as the state gives it.
- **Ball model, central difference** (:func:`advance_ball`): the step of :mod:`.ball`,
  the forcing on the moving mass; N/F_s is the lower contact's force (what the
  transducer reads, as in the sweep's readings: ``L = 1 + m_b g / F_s`` at rest) and
  the contact flag the lower contact's; the state is the compressions ``(u[n-1], u,
  l[n-1], l)`` (float[4, T]); its :class:`BallRecord` adds the steps with both contacts
  open (the ball in flight).

:func:`accumulate` adds a recorded segment to the running :class:`Tally` of every
trajectory (moments, extremes, contact loss, flights, histogram), whichever kernel
recorded it. For the single model with the central difference, :func:`measure` does
both in one pass, and :func:`settle` steps a transient unrecorded, in blocks of
trajectories vectorised across a step (the tallies in the block's rows, not re-read from
a record), with the same numbers bit for bit. As in :mod:`.integrate`, every trajectory
performs the operations of a single one, so one trajectory alone and T together give the
same numbers bit for bit.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from . import CACHE
from .ball import _observe
from .ball import _status as _ball_status
from .integrate import LANES, _finite, observe
from .rk import ZERO, _acceleration, _correct, _crossing, _rk4
from .scheme import (
    NON_FINITE,
    OK,
    STOPPED,
    UNSTABLE,
    constant,
    forcing,
    make_step,
    to_compression,
)
from .stop import REQUEST, requested

RandomDrive = namedtuple("RandomDrive", ["level", "realisation", "steps_per_period", "stop"])
"""The input of T trajectories: ``level`` float[T] (the RMS of f = F/F_s),
``realisation`` int64[T] (the column of the forcing table each one reads),
``steps_per_period`` (N: the stop request and the stability are checked every N steps) and
``stop`` (:data:`.stop.REQUEST`)."""

Record = namedtuple("Record", ["excess", "contact"])
"""One segment of S steps of T trajectories: ``excess`` float[S, T] (``N/F_s - 1``, so that
tiny inputs lose no digits to the static part) and ``contact`` bool[S, T] (``d > 0`` at
that step)."""

Tally = namedtuple("Tally", ["sums", "histogram", "low", "width"])
"""The running tallies of T trajectories across segments: ``sums`` float[FIELDS, T]
(:data:`TALLY_FIELDS`), ``histogram`` float[B, T] of N/F_s on the bins
``[low + b width, low + (b + 1) width)`` (``low``, ``width`` float[T]; values below the
first bin are counted in it, values at or above the last in the last)."""

TALLY_FIELDS = (
    "count",  # steps tallied
    "sum1",  # sum of x = N/F_s - 1
    "sum2",  # sum of x^2
    "sum3",  # sum of x^3
    "sum4",  # sum of x^4
    "minimum",  # smallest x
    "maximum",  # largest x
    "loss",  # steps out of contact (d <= 0)
    "lift_offs",  # flights begun (a step out of contact after one in contact)
    "landings",  # flights ended (a step in contact after one out of it)
    "flight_total",  # steps of the flights ended
    "flight_longest",  # steps of the longest flight ended
    "run",  # steps of the flight in progress (0 in contact)
)
(COUNT, SUM1, SUM2, SUM3, SUM4, MINIMUM, MAXIMUM, LOSS, LIFT_OFFS, LANDINGS) = range(10)
FLIGHT_TOTAL, FLIGHT_LONGEST, RUN = 10, 11, 12
FIELDS = len(TALLY_FIELDS)


def new_record(steps: int, trajectories: int) -> Record:
    """The buffers of one segment of ``steps`` steps."""
    return Record(np.zeros((steps, trajectories)), np.zeros((steps, trajectories), dtype=np.bool_))


@njit(cache=CACHE)
def new_tally(trajectories, bins, low, width):
    """Empty tallies of ``trajectories`` trajectories on ``bins`` bins from ``low``, of
    width ``width`` (floats, the same for every trajectory): the smallest value at +inf
    and the largest at -inf, so that the first step sets both."""
    sums = np.zeros((FIELDS, trajectories))
    sums[MINIMUM] = np.inf
    sums[MAXIMUM] = -np.inf
    histogram = np.zeros((bins, trajectories))
    return Tally(sums, histogram, np.full(trajectories, low), np.full(trajectories, width))


def at_rest(drive: RandomDrive, g: np.ndarray, h: float, law: object = None) -> np.ndarray:
    """The state of T trajectories at rest at the static equilibrium at the record's start
    (q = 0, q' = 0 at tau = 0), float[2, T]: ``d[0] = 1`` and ``d[-1]`` of ``q[-1] = h^2
    q''(0) / 2 = h^2 f_0 / 2`` (the Taylor start of :func:`.integrate.start_from`, with
    the load ``1 + f_0`` of the first step: second order). ``q[-1] = q[0]`` would start
    with ``q' = h f_0 / 2``, an error of order h that the trajectory keeps. ``law`` is
    not used (the contract of :data:`KERNELS`)."""
    f0 = drive.level * g[0, drive.realisation]
    state = np.ones((2, drive.level.size))
    state[0] = 1.0 + (0.5 * h * h * f0) * (2.0 / 3.0)  # to_compression of q[-1]
    return state


def inputs(level: np.ndarray, realisation: np.ndarray, steps_per_period: int) -> RandomDrive:
    """The :class:`RandomDrive` of the levels and realisations of T trajectories."""
    return RandomDrive(
        np.ascontiguousarray(level, dtype=np.float64),
        np.ascontiguousarray(realisation, dtype=np.int64),
        int(steps_per_period),
        REQUEST,
    )


@njit(cache=CACHE, error_model="numpy")
def _check(peak, limit, first, second, compressed, stop):
    """``(status, trajectory)``: the first trajectory unstable (its largest root at or
    beyond ``limit``), else the first non-finite (its state rows ``first``, ``second``:
    compressions when ``compressed``, checked as displacements, :func:`.integrate._finite`;
    else velocity and displacement), else :data:`~.scheme.STOPPED` (-1) when a stop was
    requested, else OK (-1)."""
    for t in range(peak.shape[0]):
        if peak[t] >= limit:
            return UNSTABLE, t
    for t in range(peak.shape[0]):
        a, b = first[t], second[t]
        finite = _finite(a, b) if compressed else math.isfinite(a) and math.isfinite(b)
        if not finite:
            return NON_FINITE, t
    if requested(stop):
        return STOPPED, -1
    return OK, -1


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance(law, h, state, drive, g, record):
    """One segment of ``S = record.excess.shape[0]`` steps of T trajectories, in place on
    ``state`` (float[2, T]: ``d[n-1]``, ``d[n]``), recording every step.

    Parameters
    ----------
    law : a damping law of :mod:`.laws`
    h : float
        The step in tau (``2 pi / N``).
    state : float[2, T]
        The compressions ``(d[n-1], d[n])``; the segment's first step is step n.
    drive : RandomDrive
    g : float[>= S, R]
        The unit forcing of every realisation at the segment's steps.
    record : Record
        Receives ``N/F_s - 1`` (``R + c q'`` with the centred ``q'``, as
        :func:`.integrate.observe` reads it) and ``d[n] > 0`` of each step.

    Returns
    -------
    (status, trajectory)
        OK and -1; or, checked every ``drive.steps_per_period`` steps and at the end, the
        first trajectory unstable or non-finite, or STOPPED and -1 on a stop request.
    """
    s = make_step(law, h)
    k = constant(s)
    level = drive.level
    column = drive.realisation
    count = level.shape[0]
    d_prev = state[0]
    d = state[1]
    excess = record.excess
    contact = record.contact
    peak = np.zeros(count)
    since = 0
    for j in range(excess.shape[0]):
        row = g[j]
        for t in range(count):
            dt = d[t]
            root, d_next, x, _ = observe(
                law, d_prev[t], dt, forcing(level[t], row[column[t]]), k, s.rate
            )
            peak[t] = root if root > peak[t] else peak[t]
            excess[j, t] = x
            contact[j, t] = dt > 0.0
            d_prev[t] = dt
            d[t] = d_next
        since += 1
        if since == drive.steps_per_period or j == excess.shape[0] - 1:
            since = 0
            status, bad = _check(peak, s.limit, state[0], state[1], True, drive.stop)
            if status != OK:
                return status, bad
    return OK, -1


@njit(cache=CACHE, inline="always")
def _bin(value, low, width, bins):
    """The histogram bin of ``value`` (the end bins take the values beyond them)."""
    u = (value - low) / width
    if u < 1.0:
        return 0
    if u >= bins - 1.0:
        return bins - 1
    return int(u)


@njit(cache=CACHE, error_model="numpy", nogil=True)
def accumulate(record, tally):
    """Add a recorded segment (its S steps) to the tallies of every trajectory
    (:data:`TALLY_FIELDS`, the histogram of ``N/F_s = 1 + x``).

    A flight is a run of steps out of contact: its lift-off is counted at its first step,
    its length at its landing (the first step in contact after it); one in progress at a
    segment's end carries into the next (``run``). Each trajectory's sums run over the
    steps in order, its running values in registers (the trajectory loop outside): the
    same numbers for one trajectory alone and in a batch.
    """
    sums = tally.sums
    histogram = tally.histogram
    bins = histogram.shape[0]
    steps = record.excess.shape[0]
    for t in range(sums.shape[1]):
        low = tally.low[t]
        width = tally.width[t]
        s1, s2, s3, s4 = sums[SUM1, t], sums[SUM2, t], sums[SUM3, t], sums[SUM4, t]
        smallest, largest = sums[MINIMUM, t], sums[MAXIMUM, t]
        loss, lift_offs, landings = sums[LOSS, t], sums[LIFT_OFFS, t], sums[LANDINGS, t]
        total, longest, run = sums[FLIGHT_TOTAL, t], sums[FLIGHT_LONGEST, t], sums[RUN, t]
        for j in range(steps):
            x = record.excess[j, t]
            x2 = x * x
            s1 += x
            s2 += x2
            s3 += x2 * x
            s4 += x2 * x2
            smallest = x if x < smallest else smallest
            largest = x if x > largest else largest
            histogram[_bin(1.0 + x, low, width, bins), t] += 1.0
            if record.contact[j, t]:
                if run > 0.0:
                    landings += 1.0
                    total += run
                    longest = run if run > longest else longest
                    run = 0.0
            else:
                lift_offs += 1.0 if run == 0.0 else 0.0
                run += 1.0
                loss += 1.0
        sums[COUNT, t] += steps
        sums[SUM1, t], sums[SUM2, t], sums[SUM3, t], sums[SUM4, t] = s1, s2, s3, s4
        sums[MINIMUM, t], sums[MAXIMUM, t] = smallest, largest
        sums[LOSS, t], sums[LIFT_OFFS, t], sums[LANDINGS, t] = loss, lift_offs, landings
        sums[FLIGHT_TOTAL, t], sums[FLIGHT_LONGEST, t], sums[RUN, t] = total, longest, run


# --------------------------------------------------------------------------- measured, fused
# The rows of a block of :func:`measure`'s working array (LANES trajectories a block, as in
# :func:`.integrate.measure`: rows a constant LANES apart, so that a step across a block is
# one vectorised loop): the state, the level, the peak root, the step's reading, the
# forcing sample, the histogram bin, then the running tallies of a step. Of
# TALLY_FIELDS, COUNT is added once a segment, and LANDINGS and FLIGHT_TOTAL follow from
# the others (every lift-off but that of a flight in progress has landed, and every step
# out of contact belongs to a flight ended or to the one in progress): ``landings =
# lift_offs - (run > 0)``, ``flight_total = loss - run``.
B_PREV, B_D, B_LEVEL, B_PEAK, B_X, B_G, B_BIN = range(7)
B_TALLIED = (SUM1, SUM2, SUM3, SUM4, MINIMUM, MAXIMUM, LOSS, LIFT_OFFS, FLIGHT_LONGEST, RUN)
B_TALLY = 7
B_ROWS = B_TALLY + len(B_TALLIED)
B_SUM1, B_SUM2, B_SUM3, B_SUM4, B_MIN, B_MAX, B_LOSS, B_LIFT, B_LONGEST, B_RUN = range(
    B_TALLY, B_ROWS
)


@njit(cache=CACHE, inline="always")
def _place(t, realisations):
    """``(block, lane)`` of trajectory t in :func:`measure`'s blocks: each level's R
    realisations fill ``ceil(R / LANES)`` blocks of their own, so that lane i of a block
    reads the forcing's column ``i + LANES (block's rank in its level)``."""
    per_level = (realisations + LANES - 1) // LANES
    level, r = t // realisations, t % realisations
    return level * per_level + r // LANES, r % LANES


@njit(cache=CACHE)
def _blocks(state, drive, tally, realisations):
    """The working array of :func:`measure`: float[blocks, B_ROWS x LANES], its rows on
    64-byte lines."""
    count = drive.level.shape[0]
    blocks = (count // realisations) * ((realisations + LANES - 1) // LANES)
    shape = (blocks, B_ROWS * LANES)
    size = shape[0] * shape[1]
    raw = np.zeros(size + 8)
    first = ((-raw.ctypes.data) % 64) // 8
    lanes = raw[first : first + size].reshape(shape)
    for t in range(count):
        block, i = _place(t, realisations)
        row = lanes[block]
        row[i + B_PREV * LANES] = state[0, t]
        row[i + B_D * LANES] = state[1, t]
        row[i + B_LEVEL * LANES] = drive.level[t]
        for r in range(len(B_TALLIED)):
            row[i + (B_TALLY + r) * LANES] = tally.sums[B_TALLIED[r], t]
    return lanes


@njit(cache=CACHE)
def _unblock(lanes, state, tally, steps, realisations):
    """The blocks' state and tallies back into ``state`` and ``tally`` (``steps`` more
    counted; LANDINGS and FLIGHT_TOTAL from the others; None: the state alone)."""
    for t in range(state.shape[1]):
        block, i = _place(t, realisations)
        row = lanes[block]
        state[0, t] = row[i + B_PREV * LANES]
        state[1, t] = row[i + B_D * LANES]
        if tally is None:
            continue
        sums = tally.sums
        sums[COUNT, t] += steps
        for r in range(len(B_TALLIED)):
            sums[B_TALLIED[r], t] = row[i + (B_TALLY + r) * LANES]
        sums[LANDINGS, t] = sums[LIFT_OFFS, t] - (1.0 if sums[RUN, t] > 0.0 else 0.0)
        sums[FLIGHT_TOTAL, t] = sums[LOSS, t] - sums[RUN, t]


@njit(cache=CACHE, error_model="numpy", inline="always")
def _tally_lane(row, i, x, touching, bin_of):
    """One step's ``x = N/F_s - 1`` and contact flag into lane i's tallies (the operations
    of :func:`accumulate` for that step, branch-free) and its histogram bin (``bin_of =
    (low, width, bins)``: :func:`_bin`'s; a NaN in the first bin) into its row."""
    x2 = x * x
    row[i + B_SUM1 * LANES] += x
    row[i + B_SUM2 * LANES] += x2
    row[i + B_SUM3 * LANES] += x2 * x
    row[i + B_SUM4 * LANES] += x2 * x2
    smallest = row[i + B_MIN * LANES]
    largest = row[i + B_MAX * LANES]
    row[i + B_MIN * LANES] = x if x < smallest else smallest
    row[i + B_MAX * LANES] = x if x > largest else largest
    run = row[i + B_RUN * LANES]
    longest = row[i + B_LONGEST * LANES]
    row[i + B_LOSS * LANES] += 0.0 if touching else 1.0
    row[i + B_LIFT * LANES] += 1.0 if (not touching and run == 0.0) else 0.0
    row[i + B_LONGEST * LANES] = run if (touching and run > longest) else longest
    row[i + B_RUN * LANES] = 0.0 if touching else run + 1.0
    low, width, bins = bin_of
    u = (1.0 + x - low) / width
    top = bins - 1.0
    row[i + B_BIN * LANES] = 0.0 if not u >= 1.0 else (top if u >= top else math.floor(u))


@njit(cache=CACHE, error_model="numpy")
def _lanes_check(lanes, count, limit, stop, realisations):
    """:func:`_check` of the blocks (compressions)."""
    peak = np.empty(count)
    d_prev = np.empty(count)
    d = np.empty(count)
    for t in range(count):
        block, i = _place(t, realisations)
        row = lanes[block]
        peak[t] = row[i + B_PEAK * LANES]
        d_prev[t] = row[i + B_PREV * LANES]
        d[t] = row[i + B_D * LANES]
    return _check(peak, limit, d_prev, d, True, stop)


@njit(cache=CACHE, error_model="numpy", nogil=True)
def measure(law, h, state, drive, g, record, tally):
    """:func:`advance` and :func:`accumulate` of a segment in one pass, the same numbers
    bit for bit (every trajectory's operations and their order are theirs).

    The trajectories are the run's: L levels of R realisations, the level outer
    (``drive.realisation[t] == t % R``, R = ``g.shape[1]``), the histogram's bins the
    same for all (``tally.low``, ``tally.width`` constant). A block of
    :data:`~.integrate.LANES` realisations of one level at a time: each step across the
    block in one vectorised loop, the tallies and the histogram bins in another, then the
    bins counted and N/F_s - 1 written to ``record.excess``; ``record.contact`` is not
    written (the flights are tallied here). Returns :func:`advance`'s ``(status,
    trajectory)``; on a status other than OK neither the state nor the tallies are
    written back (the segment is not counted)."""
    return _segment(law, h, state, drive, g, record.excess, tally, True)


@njit(cache=CACHE, error_model="numpy", nogil=True)
def settle(law, h, state, drive, g, steps):
    """``steps`` steps of :func:`measure`'s trajectories, unrecorded and untallied (a
    transient): :func:`advance`'s state and status, bit for bit."""
    tally = new_tally(drive.level.shape[0], 1, 0.0, 1.0)  # not written
    return _segment(law, h, state, drive, g, np.empty((steps, 0)), tally, False)


@njit(cache=CACHE, error_model="numpy", inline="always")
def _step_block(law, row, width, k, rate):
    """One step of the first ``width`` lanes of a block (``row``): :func:`.integrate.observe`
    under the load ``1 + level g`` (g in the row B_G), the peak root and the reading, in
    one loop over the lanes; the compression before the step is left in B_PREV."""
    for i in range(width):
        dt = row[i + B_D * LANES]
        load = forcing(row[i + B_LEVEL * LANES], row[i + B_G * LANES])
        root, d_next, x, _ = observe(law, row[i + B_PREV * LANES], dt, load, k, rate)
        peak = row[i + B_PEAK * LANES]
        row[i + B_PEAK * LANES] = root if root > peak else peak
        row[i + B_X * LANES] = x
        row[i + B_PREV * LANES] = dt
        row[i + B_D * LANES] = d_next


@njit(cache=CACHE, error_model="numpy", inline="always")
def _segment(law, h, state, drive, g, excess, tally, tallied):
    """``excess.shape[0]`` steps of :func:`measure` (``tallied``) or :func:`settle`."""
    s = make_step(law, h)
    k = constant(s)
    rate = s.rate
    count = drive.level.shape[0]
    realisations = g.shape[1]
    per_level = (realisations + LANES - 1) // LANES
    levels = count // realisations
    histogram = tally.histogram
    # the bins counted through a flat view with unsigned indices: no negative index to
    # wrap (the bin is >= 0 by construction; with 2-d indices the steps with their
    # readings cost 4.1 ns a trajectory-step, measured, against 3.5)
    flat = histogram.reshape(histogram.size)  # a view (numba refuses a non-contiguous one)
    stride = np.uint64(histogram.shape[1])
    bin_of = (tally.low[0], tally.width[0], float(histogram.shape[0]))
    lanes = _blocks(state, drive, tally, realisations)
    since = 0
    for j in range(excess.shape[0]):
        row_g = g[j]
        # blocks by level and rank: indices from ranges and products only, so that the
        # compiler sees every one >= 0 (numba wraps a negative index, and a remainder's
        # sign is not known: the loops then stay scalar)
        for level in range(levels):
            for rank in range(per_level):
                row = lanes[level * per_level + rank]
                column = rank * LANES  # lane i's column: column + i
                base = level * realisations + column  # and its trajectory: base + i
                width = min(LANES, realisations - column)
                for i in range(width):
                    row[i + B_G * LANES] = row_g[column + i]
                _step_block(law, row, width, k, rate)
                if not tallied:
                    continue
                for i in range(width):
                    x = row[i + B_X * LANES]
                    _tally_lane(row, i, x, row[i + B_PREV * LANES] > 0.0, bin_of)
                out = excess[j]
                for i in range(width):
                    out[base + i] = row[i + B_X * LANES]
                    flat[np.uint64(row[i + B_BIN * LANES]) * stride + base + i] += 1.0
        since += 1
        if since == drive.steps_per_period or j == excess.shape[0] - 1:
            since = 0
            status, bad = _lanes_check(lanes, count, s.limit, drive.stop, realisations)
            if status != OK:
                return status, bad
    _unblock(lanes, state, tally if tallied else None, excess.shape[0], realisations)
    return OK, -1


# --------------------------------------------------------------------------- rk4
RK4_ROWS = (
    "velocity",  # q'
    "displacement",  # q
    "crossing",  # steps from the record's start to the last crossing located (-inf: none)
    "steps",  # steps taken from the record's start (a whole number, every trajectory's)
)
"""The rows of :func:`advance_rk4`'s state (float[4, T])."""
VELOCITY, DISPLACEMENT, CROSSING, STEPS = range(4)

NoLockin = namedtuple("NoLockin", ["harmonics", "orders", "sin_table", "lockin_sin"])
"""What :func:`.rk._correct` reads of a drive: a random run has no lock-in harmonics."""


def at_rest_rk4(drive: RandomDrive, g: np.ndarray, h: float, law: object = None) -> np.ndarray:
    """The state of T trajectories at rest at the static equilibrium at the record's start
    (:data:`RK4_ROWS`: q = 0, q' = 0 exactly, no crossing yet, no step taken)."""
    state = np.zeros((len(RK4_ROWS), drive.level.size))
    state[CROSSING] = -np.inf
    return state


@njit(cache=CACHE, inline="always")
def _interpolated(sigma, samples, s):
    """The load ``1 + sigma P(s)`` at the fraction s of a step, P the quadratic through
    the unit forcing's ``samples = (g(0), g(h/2), g(h))`` (exact at 0, 1/2 and 1)."""
    g0, gm, g1 = samples
    slope = 4.0 * gm - 3.0 * g0 - g1
    curvature = 2.0 * (g0 - 2.0 * gm + g1)
    return 1.0 + sigma * (g0 + s * (slope + s * curvature))


@njit(cache=CACHE)
def _split(law, h, ends, forcing_samples, event, scratch):
    """A step of rk4 that crossed ``d = 0``, taken again as :func:`.rk._split` takes it:
    RK4 to the crossing located on the Hermite interpolant, the singular terms' correction
    (:func:`.rk._correct`) there, RK4 from it, each part with the law held on its side.

    Parameters
    ----------
    law : a damping law of :mod:`.laws`
    h : float
    ends : (q, q', q1, q1')
        The state at the step's start and the whole step's result.
    forcing_samples : (sigma, (g0, gm, g1))
        The level and the unit forcing at the step's start, middle and end.
    event : (inside, now, last)
        In contact at the start; the step's start and the last crossing, in steps from
        the record's start (``-inf``: none).
    scratch : (float[1], float[0, 2], NoLockin)
        What :func:`.rk._correct` adds its integrals to (not read).

    Returns
    -------
    (q, q', crossing)
        The state at the step's end and the crossing, in steps from the record's start.
    """
    q, v, q1, v1 = ends
    sigma, samples = forcing_samples
    inside, now, last = event
    sums, fourier, lockin = scratch
    fraction = _crossing(q, v, q1, v1, h)
    side = 1 if inside else -1
    first = fraction * h
    second = h - first
    at = now + fraction
    reach = (at - last) * h if inside else np.inf  # a lift-off's contact began at ``last``
    load_e = _interpolated(sigma, samples, fraction)
    loads = (1.0 + sigma * samples[0], _interpolated(sigma, samples, 0.5 * fraction), load_e)
    q, v, _, _ = _rk4(law, q, v, first, loads, side)
    a_e, _, _ = _acceleration(law, -1.5, v, load_e, 1)  # the contact side's, at d = 0
    direction = -1.0 if inside else 1.0
    crossing = (0.0, v, a_e, direction, 0.0, ZERO, ZERO)  # no lock-in: tau_e, w unused
    contact = (second if direction > 0.0 else first, reach, ZERO, ZERO, False)
    cq, cv, _, _ = _correct(law, lockin, h, crossing, contact, sums, fourier, 0)
    middle = _interpolated(sigma, samples, 0.5 * (1.0 + fraction))
    loads = (load_e, middle, 1.0 + sigma * samples[2])
    q, v, _, _ = _rk4(law, q + cq, v + cv, second, loads, -side)
    return q, v, at


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance_rk4(law, h, state, drive, g, record):
    """One segment of ``S = record.excess.shape[0]`` rk4 steps of T trajectories, in place
    on ``state`` (:data:`RK4_ROWS`), recording every step: :func:`advance`'s contract.

    Parameters
    ----------
    law : a damping law of :mod:`.laws`
    h : float
        The step in tau (``2 pi / N``).
    state : float[4, T]
        :data:`RK4_ROWS`: ``(q', q)``, the last crossing and the steps taken, from the
        record's start.
    drive : RandomDrive
    g : float[>= 2 S + 1, R]
        The unit forcing of every realisation at the segment's steps and half steps
        (row 2j at step j, 2j + 1 at its middle).
    record : Record
        Receives N/F_s - 1 at each step's start (``R + c q'``) and ``d > 0`` there.

    Returns
    -------
    (status, trajectory)
        As :func:`advance` (the limit ``h omega < 2 sqrt(2)``, :mod:`.rk`).
    """
    level = drive.level
    column = drive.realisation
    count = level.shape[0]
    excess = record.excess
    contact = record.contact
    nothing = NoLockin(np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros(1), np.zeros(1))
    scratch = (np.zeros(1), np.zeros((0, 2)), nothing)
    limit = 8.0 / (h * h)  # (h omega)^2 < 8 with omega^2 = sqrt(d): core.model.STABILITY
    peak = np.zeros(count)
    loads = np.empty((3, count))  # a step's loads at its start, middle and end
    ends = np.empty((2, count))  # a step's (q, q') at its end
    velocity, displacement = state[VELOCITY], state[DISPLACEMENT]
    start = state[STEPS, 0] if count else 0.0
    since = 0
    for j in range(excess.shape[0]):
        now = start + j
        g0, gm, g1 = g[2 * j], g[2 * j + 1], g[2 * j + 2]
        # Three passes a step. The loads are gathered into rows; every trajectory's RK4
        # step then has no call and no gather in it, so the compiler vectorises it across
        # the trajectories; the few steps that crossed d = 0 are taken again by _split
        # from the state at their start, still in ``state``. The numbers are those of one
        # pass per trajectory, bit for bit.
        for t in range(count):
            r, sigma = column[t], level[t]
            loads[0, t] = forcing(sigma, g0[r])
            loads[1, t] = forcing(sigma, gm[r])
            loads[2, t] = forcing(sigma, g1[r])
        for t in range(count):
            v, q = velocity[t], displacement[t]
            inside = to_compression(q) > 0.0
            step_loads = (loads[0, t], loads[1, t], loads[2, t])
            q1, v1, x, root = _rk4(law, q, v, h, step_loads, 1 if inside else -1)
            peak[t] = root if root > peak[t] else peak[t]
            excess[j, t] = x[0]
            contact[j, t] = inside
            ends[0, t], ends[1, t] = q1, v1
        for t in range(count):
            q1, v1 = ends[0, t], ends[1, t]
            inside = contact[j, t]
            if (to_compression(q1) > 0.0) != inside:
                r = column[t]
                event = (inside, now, state[CROSSING, t])
                step = (displacement[t], velocity[t], q1, v1)
                samples = (level[t], (g0[r], gm[r], g1[r]))
                q1, v1, state[CROSSING, t] = _split(law, h, step, samples, event, scratch)
            velocity[t], displacement[t] = v1, q1
        since += 1
        if since == drive.steps_per_period or j == excess.shape[0] - 1:
            since = 0
            status, bad = _check(peak, limit, velocity, displacement, False, drive.stop)
            if status != OK:
                state[STEPS, :] = now + 1.0
                return status, bad
    state[STEPS, :] = start + excess.shape[0]
    return OK, -1


# --------------------------------------------------------------------------- ball model
BallRecord = namedtuple("BallRecord", ["excess", "contact", "flight"])
"""One segment of the ball model: :class:`Record`'s ``excess`` (the lower contact's
``N/F_s - 1``) and ``contact`` (the lower contact closed), and ``flight`` bool[S, T] (both
contacts open: the ball in flight)."""


def new_ball_record(steps: int, trajectories: int) -> BallRecord:
    """The buffers of one segment of ``steps`` steps of the ball model."""
    flags = np.zeros((steps, trajectories), dtype=np.bool_)
    return BallRecord(np.zeros((steps, trajectories)), flags, flags.copy())


def at_rest_ball(drive: RandomDrive, g: np.ndarray, h: float, model) -> np.ndarray:
    """The compressions ``(u[-1], u[0], l[-1], l[0])`` of T trajectories at rest at the
    static equilibrium (float[4, T]): ``u = l = 1`` at step 0; at rest the load ``1 +
    f_0`` accelerates the moving mass alone (``q1'' = f_0``, ``q2'' = 0``: the ball's
    equation balances), so ``q1[-1] = h^2 f_0 / 2`` and ``q2[-1] = 0``, as the single
    model's :func:`at_rest` (``model``: :class:`.ball.Ball`)."""
    f0 = drive.level * g[0, drive.realisation]
    state = np.ones((4, drive.level.size))
    state[0] = 1.0 + (0.5 * h * h * f0) * (2.0 / 3.0) / model.upper  # u of (q1, q2)[-1]
    return state


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance_ball(model, h, state, drive, g, record):
    """One segment of ``S = record.excess.shape[0]`` steps of the ball model for T
    trajectories, in place on ``state`` (float[4, T]: ``u[n-1], u, l[n-1], l``), recording
    every step: :func:`advance`'s contract.

    Parameters
    ----------
    model : :class:`.ball.Ball`
    h : float
        The step in tau (``2 pi / N``).
    state : float[4, T]
    drive : RandomDrive
    g : float[>= S, R]
        The unit forcing of every realisation at the segment's steps (on the moving mass).
    record : BallRecord
        Receives the lower contact's ``N/F_s - 1`` (``L R(l) + 3 a_l c(l) l'``, the centred
        ``l'``, as :func:`.ball.measure` reads it), ``l > 0`` and ``u <= 0 and l <= 0`` at
        each step.

    Returns
    -------
    (status, trajectory)
        As :func:`advance` (the ball model's limit ``h W_max^(1/2) < 2``).
    """
    level = drive.level
    column = drive.realisation
    count = level.shape[0]
    excess = record.excess
    contact = record.contact
    flight = record.flight
    c0 = h * h * (2.0 / 3.0)
    rate = 0.75 / h
    steps = np.full(count, h)
    peaks = np.zeros((2, count))
    nothing = np.empty(0)  # no sample of the state is kept
    since = 0
    for j in range(excess.shape[0]):
        row = g[j]
        for t in range(count):
            lower_in = state[3, t] > 0.0
            upper_in = state[1, t] > 0.0
            load = forcing(level[t], row[column[t]])
            ru, rl, x, _ = _observe(model, state, t, load, h, c0, rate, nothing)
            peaks[0, t] = ru if ru > peaks[0, t] else peaks[0, t]
            peaks[1, t] = rl if rl > peaks[1, t] else peaks[1, t]
            excess[j, t] = x
            contact[j, t] = lower_in
            flight[j, t] = not (lower_in or upper_in)
        since += 1
        if since == drive.steps_per_period or j == excess.shape[0] - 1:
            since = 0
            status, bad = _ball_status(model, state, peaks, steps, drive.stop)
            if status != OK:
                return status, bad
    return OK, -1


# --------------------------------------------------------------------------- the registry
Kernel = namedtuple("Kernel", ["advance", "at_rest", "new_record", "per_step", "measure", "settle"])
"""One model's and method's kernels: ``advance(law, h, state, drive, g, record)``,
``at_rest(drive, g, h, law)``, ``new_record(steps, trajectories)``, ``per_step``, the
forcing's samples a step (rk4: 2, the half steps too); and, where the model and method
have them, ``measure(law, h, state, drive, g, record, tally)``, a measured segment's
``advance`` and :func:`accumulate` in one pass, and ``settle(law, h, state, drive, g,
steps)``, a transient's ``advance`` unrecorded (None: ``advance``, then
:func:`accumulate` for a measured segment)."""

KERNELS = {
    ("single", "central-difference"): Kernel(advance, at_rest, new_record, 1, measure, settle),
    ("single", "rk4"): Kernel(advance_rk4, at_rest_rk4, new_record, 2, None, None),
    ("ball", "central-difference"): Kernel(
        advance_ball, at_rest_ball, new_ball_record, 1, None, None
    ),
}
"""The kernels of each ``(model.kind, solver.method)`` a random run takes."""


__all__ = [
    "FIELDS",
    "KERNELS",
    "RK4_ROWS",
    "TALLY_FIELDS",
    "BallRecord",
    "Kernel",
    "RandomDrive",
    "Record",
    "Tally",
    "accumulate",
    "advance",
    "advance_ball",
    "advance_rk4",
    "at_rest",
    "at_rest_ball",
    "at_rest_rk4",
    "inputs",
    "measure",
    "new_ball_record",
    "new_record",
    "new_tally",
    "settle",
]
