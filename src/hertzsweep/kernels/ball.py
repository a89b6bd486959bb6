"""The two-degree-of-freedom model (the moving mass on the ball), compiled: the kernels of
the central-difference scheme with the method contract of :mod:`.methods`.

Equations and scaling: :mod:`hertzsweep.core.ballmodel`. Each contact's terms are the
damping law's, :func:`.laws.terms`, on its own compression (u upper, l lower); the
scheme is the paper's, centred differences for both accelerations and both compression
rates with the damping coefficients at step n, which leaves one 2 x 2 linear system a step
for the increments ``x = u[n+1] - u[n-1]``, ``y = l[n+1] - l[n-1]`` (:func:`step`)::

    (a_u + g_u) x + a_l y          = c0 (F_n - R(u)) + 2 a_u (u - u[n-1]) + 2 a_l (l - l[n-1])
    -g_u x + (mu a_l + g_l) y      = c0 (L - 1 + R(u) - L R(l)) + 2 mu a_l (l - l[n-1])

with ``c0 = 2 h^2 / 3``, ``g = a c h`` (c of the law at step n). The sum of the two rows
telescopes over the steps into the discrete momentum balance: ``sum c0 (F_n - N_n / F_s
+ L - 1)`` equals the change of ``a_u (u[n] - u[n-1]) + (1 + mu) a_l (l[n] - l[n-1])``,
with ``N / F_s = L R(l) + 3 a_l c(l) l'`` and ``l' = y / (2 h)`` (what the transducer
reads).

The state crossing the boundary is ``(q_prev, q)``, each float[T, 2] (float[2] for
:func:`advance`): the moving mass's and the ball's displacement in the single model's q,
at steps n-1 and n. One trajectory is a batch of one (:func:`measure_one` is
:func:`measure`, :func:`advance` is :func:`advance_batch`), so they agree bit for bit by
construction. :func:`period_map` is one period of :func:`advance` with its exact
derivatives by the state and the step (the monodromy matrix and ``dP/dh``), as
:func:`.tangent.period_map` is the single model's.

The readout is :class:`~.integrate.Readout` with a :data:`BALL_FIELDS` block: the lower
contact is the one the transducer reads (``sums`` and ``counts`` hold its force and its
flights, as the single model's), the block adds the ball's state, the upper contact's
force and flights, and the ball's flights (both contacts open). The record holds
:data:`BALL_RECORD_COLUMNS` per sample.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from . import CACHE, integrate
from .integrate import TALLY_START, Readout, _finish, _lockin_tables, _next_index, tally
from .integrate import inputs as inputs  # the single model's drive, as every method's
from .laws import slopes, terms
from .scheme import NON_FINITE, OK, STOPPED, UNSTABLE, forcing, period_tables
from .stop import requested

Ball = namedtuple("Ball", ["law", "upper", "lower", "load", "mass_ratio"])
"""The damping law's record and the scaled constants of
:class:`hertzsweep.core.ballmodel.BallModel` (``a_u``, ``a_l``, ``L``, ``mu``)."""

STATE_FIELDS = ("q2_prev_last", "q2_last", "q2_prev", "q2")  # the ball's, as SUM_FIELDS'
TALLY_FIELDS = ("total", "max", "min", "loss", "longest", "lead", "run")  # of tally
BALL_FIELDS = (
    STATE_FIELDS
    + tuple(f"upper_{name}" for name in TALLY_FIELDS)  # the upper contact's force - 1
    + tuple(f"flight_{name}" for name in TALLY_FIELDS)  # both contacts open
)
UPPER = len(STATE_FIELDS)
FLIGHT = UPPER + len(TALLY_FIELDS)
BALL_RECORD_COLUMNS = 8  # q, q', N/F_s, lower in contact (as the single model's), then
# the ball's q2 and q2', the upper contact's force over F_s, upper in contact


def make_model(law, upper: float, lower: float, load: float, mass_ratio: float) -> Ball:
    """The kernels' record of the ball model with the damping law ``law``."""
    return Ball(law, float(upper), float(lower), float(load), float(mass_ratio))


def new_readout(harmonics: int, trajectories: int, record=None, stride: int = 0) -> Readout:
    """Output buffers for :func:`measure` (``record`` float[M, 8, T], the
    :data:`BALL_FIELDS` block)."""
    return integrate.new_readout(
        harmonics, trajectories, record, stride, BALL_RECORD_COLUMNS, len(BALL_FIELDS)
    )


@njit(cache=CACHE, inline="always")
def compressions(model, q1, q2):
    """``(u, l)`` of the displacements ``(q1, q2)``."""
    return (
        1.0 + (q1 - q2) * (2.0 / 3.0) / model.upper,
        1.0 + q2 * (2.0 / 3.0) / model.lower,
    )


@njit(cache=CACHE, inline="always")
def displacements(model, u, l):
    """``(q1, q2)`` of the compressions ``(u, l)``."""
    q2 = 1.5 * model.lower * (l - 1.0)
    return q2 + 1.5 * model.upper * (u - 1.0), q2


@njit(cache=CACHE)
def contact_terms(law, d):
    """:func:`.laws.terms` of one contact, compiled on its own: inlined twice into one
    function, numba's SSA pass would see the two copies' variables clash (LLVM inlines
    this call instead)."""
    return terms(law, d)


@njit(cache=CACHE)
def step(model, u_prev, u, l_prev, l, load, h, c0):
    """One step: ``(sqrt(u), sqrt(l), c(u), c(l), x, y)``, ``u[n+1] = u[n-1] + x``,
    ``l[n+1] = l[n-1] + y`` (the module docstring's system, solved by Cramer's rule)."""
    root_u, cu = contact_terms(model.law, u)
    root_l, cl = contact_terms(model.law, l)
    au = model.upper
    big = model.load
    ru = u * root_u
    el = 2.0 * model.lower * (l - l_prev)
    r1 = c0 * (load - ru) + 2.0 * au * (u - u_prev) + el
    r2 = c0 * (big - 1.0 + ru - big * (l * root_l)) + model.mass_ratio * el
    x, y = solve(model, system(model, cu, cl, h), r1, r2)
    return root_u, root_l, cu, cl, x, y


@njit(cache=CACHE, inline="always")
def system(model, cu, cl, h):
    """The step's matrix ``[[a_u + g_u, a_l], [-g_u, mu a_l + g_l]]`` as ``(g_u, a_u +
    g_u, mu a_l + g_l, 1 / det)`` (c of the law at step n)."""
    gu = model.upper * cu * h
    mass_u = model.upper + gu
    mass_l = model.mass_ratio * model.lower + model.lower * cl * h
    return gu, mass_u, mass_l, 1.0 / (mass_u * mass_l + model.lower * gu)


@njit(cache=CACHE, inline="always")
def solve(model, matrix, r1, r2):
    """``(x, y)`` of the step's system with the right-hand side ``(r1, r2)`` (Cramer)."""
    gu, mass_u, mass_l, inv = matrix
    return (r1 * mass_l - model.lower * r2) * inv, (mass_u * r2 + gu * r1) * inv


@njit(cache=CACHE, inline="always")
def unstable(model, root_u, root_l, h):
    """Whether ``h W_max^(1/2) >= 2`` at the roots of the compressions (the largest
    squared frequency of :meth:`~hertzsweep.core.ballmodel.BallModel.squared_frequencies`)."""
    ku = root_u / model.upper
    kl = model.load * root_l / model.lower
    mu = model.mass_ratio
    b = ku * (1.0 + mu) + kl
    high = (b + math.sqrt(b * b - 4.0 * mu * ku * kl)) / (2.0 * mu)
    return not high * h * h < 4.0  # an infinite peak (inf - inf in b^2 - ...) is unstable


@njit(cache=CACHE)
def _rows(model, q_prev, q):
    """The running state, one row each: ``u[n-1], u, l[n-1], l`` (float[4, T])."""
    rows = np.empty((4, q.shape[0]))
    for t in range(q.shape[0]):
        rows[0, t], rows[2, t] = compressions(model, q_prev[t, 0], q_prev[t, 1])
        rows[1, t], rows[3, t] = compressions(model, q[t, 0], q[t, 1])
    return rows


@njit(cache=CACHE)
def _store(model, rows, q_prev, q):
    """The running state back into the displacements ``q_prev``, ``q`` (float[T, 2])."""
    for t in range(q.shape[0]):
        q_prev[t, 0], q_prev[t, 1] = displacements(model, rows[0, t], rows[2, t])
        q[t, 0], q[t, 1] = displacements(model, rows[1, t], rows[3, t])


@njit(cache=CACHE)
def _status(model, rows, peaks, h, stop):
    """``(status, trajectory)`` after a period: the first unstable trajectory, else the
    first non-finite, else :data:`~.scheme.STOPPED` when a stop was requested."""
    for t in range(rows.shape[1]):
        if unstable(model, peaks[0, t], peaks[1, t], h[t]):
            return UNSTABLE, t
    for t in range(rows.shape[1]):
        for n in (0, 1):  # steps n-1 and n, as displacements (a finite d may overflow them)
            q1, q2 = displacements(model, rows[n, t], rows[n + 2, t])
            if not (math.isfinite(q1) and math.isfinite(q2)):
                return NON_FINITE, t
    if requested(stop):
        return STOPPED, -1
    return OK, -1


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance_batch(q_prev, q, h, model, drive, periods):
    """Whole periods of T trajectories, in place on ``q_prev``, ``q`` (float[T, 2]), each
    at its own step ``h[t]`` and level ``drive.sigma[t]``. Returns ``(status,
    trajectory)`` as :func:`.integrate.advance_batch`."""
    rows = _rows(model, q_prev, q)
    peaks = np.zeros((2, q.shape[0]))
    c0 = h * h * (2.0 / 3.0)
    table = drive.sin_table
    for _ in range(periods):
        for j in range(table.shape[0]):
            sj = table[j]
            for t in range(q.shape[0]):
                u_prev, u, l_prev, l = rows[0, t], rows[1, t], rows[2, t], rows[3, t]
                ru, rl, _, _, x, y = step(
                    model, u_prev, u, l_prev, l, forcing(drive.sigma[t], sj), h[t], c0[t]
                )
                peaks[0, t] = ru if ru > peaks[0, t] else peaks[0, t]
                peaks[1, t] = rl if rl > peaks[1, t] else peaks[1, t]
                rows[0, t], rows[1, t] = u, u_prev + x
                rows[2, t], rows[3, t] = l, l_prev + y
        status, bad = _status(model, rows, peaks, h, drive.stop)
        if status != OK:
            _store(model, rows, q_prev, q)
            return status, bad
    _store(model, rows, q_prev, q)
    return OK, -1


def advance(q_prev, q, h, model, drive, periods):
    """Whole periods of one trajectory (``drive.sigma[0]``) from ``(q_prev, q)``
    (float[2] each). Returns new ``(q_prev, q, status)``: :func:`advance_batch` on a batch
    of one."""
    a = np.array(q_prev, dtype=float).reshape(1, 2)
    b = np.array(q, dtype=float).reshape(1, 2)
    status, _ = advance_batch(a, b, np.array([h], dtype=float), model, drive, periods)
    return a[0], b[0], status


@njit(cache=CACHE)
def contact_slopes(law, d, root):
    """:func:`.laws.slopes` of one contact, compiled on its own (as :func:`contact_terms`)."""
    return slopes(law, d, root)


@njit(cache=CACHE)
def _linear_step(model, row, load, h, c0, jacobian):
    """One :func:`step` of ``row`` (float[4]: ``u[n-1], u, l[n-1], l``, in place) with
    its derivatives: ``jacobian`` (float[2, 5]) gets ``d(x, y) / d(u[n-1], u, l[n-1], l,
    h)``. Returns ``(sqrt(u), sqrt(l))``.

    Differentiating the module docstring's system ``A (x, y) = r`` gives ``A d(x, y) = dr
    - dA (x, y)`` with the same matrix ``A``; ``dA`` is ``[[dg_u, 0], [-dg_u, dg_l]]``,
    ``dg = a (c' h dd + c dh)``, and ``dr`` is ``r``'s partial derivatives (``R' = dR/dd``,
    ``dc0/dh = 4 h / 3``; the load does not depend on h). Both are taken on the side of
    ``d = 0`` the step is on, as :func:`.laws.slopes`."""
    u_prev, u, l_prev, l = row[0], row[1], row[2], row[3]
    root_u, root_l, cu, cl, x, y = step(model, u_prev, u, l_prev, l, load, h, c0)
    stiff_u, dcu = contact_slopes(model.law, u, root_u)
    stiff_l, dcl = contact_slopes(model.law, l, root_l)
    au = model.upper
    al = model.lower
    big = model.load
    mu = model.mass_ratio
    matrix = system(model, cu, cl, h)
    dc0 = (4.0 / 3.0) * h
    ru = u * root_u
    # (dr1, dr2, dg_u, dg_l) by u[n-1], u, l[n-1], l, h
    for k in range(5):
        if k == 0:
            dr1, dr2, dgu, dgl = -2.0 * au, 0.0, 0.0, 0.0
        elif k == 1:
            dr1, dr2, dgu, dgl = 2.0 * au - c0 * stiff_u, c0 * stiff_u, au * dcu * h, 0.0
        elif k == 2:
            dr1, dr2, dgu, dgl = -2.0 * al, -2.0 * mu * al, 0.0, 0.0
        elif k == 3:
            dr1 = 2.0 * al
            dr2 = 2.0 * mu * al - c0 * big * stiff_l
            dgu, dgl = 0.0, al * dcl * h
        else:
            dr1 = dc0 * (load - ru)
            dr2 = dc0 * (big - 1.0 + ru - big * (l * root_l))
            dgu, dgl = au * cu, al * cl
        jacobian[0, k], jacobian[1, k] = solve(
            model, matrix, dr1 - dgu * x, dr2 + dgu * x - dgl * y
        )
    row[0], row[1] = u, u_prev + x
    row[2], row[3] = l, l_prev + y
    return root_u, root_l


@njit(cache=CACHE)
def _carry(tangent, jacobian):
    """The chain rule through one step: ``tangent`` (float[4, 5], the derivatives of
    ``u[n-1], u, l[n-1], l`` by the period's ``(x_0, h)``) becomes that of ``u, u[n+1],
    l, l[n+1]``, in place, with ``jacobian`` of :func:`_linear_step`."""
    for k in range(5):
        dx = jacobian[0, 4] if k == 4 else 0.0
        dy = jacobian[1, 4] if k == 4 else 0.0
        for i in range(4):
            dx += jacobian[0, i] * tangent[i, k]
            dy += jacobian[1, i] * tangent[i, k]
        up, u, lp, l = tangent[0, k], tangent[1, k], tangent[2, k], tangent[3, k]
        tangent[0, k], tangent[1, k] = u, up + dx
        tangent[2, k], tangent[3, k] = l, lp + dy


@njit(cache=CACHE, error_model="numpy", nogil=True)
def period_map(q_prev, q, h, model, drive, derivative):
    """One period of the ball model (level ``drive.sigma[0]``) with its exact derivatives.

    The trajectory is :func:`advance_batch`'s, step for step (:func:`step` on the same
    operands), so the state returned is one period of :func:`advance`, bit for bit. The
    derivatives are carried through the steps alongside it (:func:`_linear_step`,
    :func:`_carry`), in the compressions, and turned into the displacements' at the end
    (both are affine in each other).

    Parameters
    ----------
    q_prev, q : float64[2]
        The moving mass's and the ball's displacement at steps -1 and 0, excitation phase 0:
        the state ``x = (q_prev[0], q_prev[1], q[0], q[1])``.
    h : float
        Step in tau, ``2 pi / (w N)``.
    model, drive
        The model's record (:class:`Ball`) and the input (:class:`.integrate.Drive`).
    derivative : float64[4, 5]
        Output: ``d(x_end) / d(x, h)``, ``x_end`` ordered as ``x``; the first four columns
        are the monodromy matrix, the fifth is ``d(x_end)/dh``.

    Returns
    -------
    tuple
        ``(q_prev, q, status)``: new float64[2] after one period, and the status as
        :func:`_status` gives it (:data:`~.scheme.UNSTABLE` from the period's peak roots,
        :data:`~.scheme.NON_FINITE` for the state or the derivative, then
        :data:`~.scheme.STOPPED`).
    """
    sigma = drive.sigma[0]
    table = drive.sin_table
    c0 = h * h * (2.0 / 3.0)
    row = np.empty(4)
    row[0], row[2] = compressions(model, q_prev[0], q_prev[1])
    row[1], row[3] = compressions(model, q[0], q[1])
    # the derivatives of u[-1], u, l[-1], l by (x, h): compressions() is affine
    tangent = np.zeros((4, 5))
    by_u = (2.0 / 3.0) / model.upper
    by_l = (2.0 / 3.0) / model.lower
    for n in (0, 1):  # step -1 from columns 0, 1; step 0 from columns 2, 3
        tangent[n, 2 * n], tangent[n, 2 * n + 1] = by_u, -by_u
        tangent[n + 2, 2 * n + 1] = by_l
    jacobian = np.empty((2, 5))
    peak_u = 0.0
    peak_l = 0.0
    for j in range(table.shape[0]):
        root_u, root_l = _linear_step(model, row, forcing(sigma, table[j]), h, c0, jacobian)
        peak_u = root_u if root_u > peak_u else peak_u
        peak_l = root_l if root_l > peak_l else peak_l
        _carry(tangent, jacobian)
    # back to the displacements: q2 = 3/2 a_l (l - 1), q1 = q2 + 3/2 a_u (u - 1)
    finite = True
    for k in range(5):
        for n in (0, 1):
            ball_k = 1.5 * model.lower * tangent[n + 2, k]
            derivative[2 * n, k] = ball_k + 1.5 * model.upper * tangent[n, k]
            derivative[2 * n + 1, k] = ball_k
            finite = finite and math.isfinite(derivative[2 * n, k] + ball_k)
    q1p, q2p = displacements(model, row[0], row[2])
    q1, q2 = displacements(model, row[1], row[3])
    new_prev = np.array([q1p, q2p])
    new = np.array([q1, q2])
    if unstable(model, peak_u, peak_l, h):
        return new_prev, new, UNSTABLE
    if not (finite and math.isfinite(q1p + q2p + q1 + q2)):
        return new_prev, new, NON_FINITE
    if requested(drive.stop):
        return new_prev, new, STOPPED
    return new_prev, new, OK


@njit(cache=CACHE, inline="always")
def _tally_row(block, first, t, x, touching):
    """:func:`.integrate.tally` of the running sums in ``block[first:first + 7, t]``."""
    acc = (
        block[first, t],
        block[first + 1, t],
        block[first + 2, t],
        block[first + 3, t],
        block[first + 4, t],
        block[first + 5, t],
        block[first + 6, t],
    )
    acc = tally(acc, x, touching)
    for i in range(7):
        block[first + i, t] = acc[i]


@njit(cache=CACHE, inline="always")
def _observe(model, rows, t, load, h, c0, rate, sample):
    """One step of trajectory t read like the instruments; ``sample`` (float[8], or
    empty when nothing is recorded) gets the record's columns. Returns ``(root_u,
    root_l, N/F_s - 1, upper/F_s - 1)``."""
    u_prev, u, l_prev, l = rows[0, t], rows[1, t], rows[2, t], rows[3, t]
    ru, rl, cu, cl, x, y = step(model, u_prev, u, l_prev, l, load, h, c0)
    au = model.upper
    al = model.lower
    lower = model.load * (l * rl) - 1.0 + 2.0 * al * cl * y * rate  # 3 a c l' = 2 a c y rate
    upper = u * ru - 1.0 + 2.0 * au * cu * x * rate
    if sample.shape[0]:
        q1, q2 = displacements(model, u, l)
        sample[0] = q1
        sample[1] = (al * y + au * x) * rate  # q1' = 3/2 (a_u u' + a_l l')
        sample[2] = lower + 1.0
        sample[3] = 1.0 if l > 0.0 else 0.0
        sample[4] = q2
        sample[5] = al * y * rate  # q2' = 3/2 a_l l'
        sample[6] = upper + 1.0
        sample[7] = 1.0 if u > 0.0 else 0.0
    rows[0, t], rows[1, t] = u, u_prev + x
    rows[2, t], rows[3, t] = l, l_prev + y
    return ru, rl, lower, upper


@njit(cache=CACHE)
def _start_sums(readout, count):
    """The running sums of :func:`measure` at their start (float[7, T] and the ball's)."""
    sums = np.empty((len(TALLY_START), count))
    for r in range(len(TALLY_START)):
        sums[r, :] = TALLY_START[r]
        readout.extra[UPPER + r, :] = TALLY_START[r]
        readout.extra[FLIGHT + r, :] = TALLY_START[r]
    return sums


@njit(cache=CACHE)
def _end_state(model, rows, readout, first):
    """The state at the start of the last period (``first = 0``) or at the end
    (``first = 2``) into the readout's sums and the ball's block."""
    for t in range(rows.shape[1]):
        q1p, q2p = displacements(model, rows[0, t], rows[2, t])
        q1, q2 = displacements(model, rows[1, t], rows[3, t])
        readout.sums[3 + first, t], readout.sums[4 + first, t] = q1p, q1
        readout.extra[first, t], readout.extra[first + 1, t] = q2p, q2


@njit(cache=CACHE, error_model="numpy", nogil=True)
def measure(q_prev, q, h, model, drive, periods, readout):
    """Whole periods of T trajectories (in place on ``q_prev``, ``q``, float[T, 2]), read
    like the rig's instruments into ``readout`` (:func:`new_readout`): the lower contact's
    force ``N/F_s`` as :func:`.integrate.measure` reads the single model's (lock-in sums,
    mean, extremes, flights), and the ball's block (:data:`BALL_FIELDS`). Returns
    ``(status, trajectory)`` as :func:`advance_batch`."""
    count = q.shape[0]
    rows = _rows(model, q_prev, q)
    peaks = np.zeros((2, count))
    c0 = h * h * (2.0 / 3.0)
    rate = 0.75 / h
    table = drive.sin_table
    n = table.shape[0]
    sums = _start_sums(readout, count)
    fourier = np.zeros((2, drive.orders.shape[0], count))
    index, shift = _lockin_tables(drive)
    references = drive.lockin_sin.shape[0]
    sample = np.empty(BALL_RECORD_COLUMNS)
    nothing = np.empty(0)
    recorded = 0
    for p in range(periods):
        if p == periods - 1:
            _end_state(model, rows, readout, 0)
        for j in range(n):
            sj = table[j]
            keep = readout.stride > 0 and (p * n + j) % readout.stride == 0
            for t in range(count):
                lower_in = rows[3, t] > 0.0
                upper_in = rows[1, t] > 0.0
                ru, rl, x, xu = _observe(
                    model,
                    rows,
                    t,
                    forcing(drive.sigma[t], sj),
                    h[t],
                    c0[t],
                    rate[t],
                    sample if keep else nothing,
                )
                peaks[0, t] = ru if ru > peaks[0, t] else peaks[0, t]
                peaks[1, t] = rl if rl > peaks[1, t] else peaks[1, t]
                _tally_row(sums, 0, t, x, lower_in)
                _tally_row(readout.extra, UPPER, t, xu, upper_in)
                _tally_row(readout.extra, FLIGHT, t, 0.0, upper_in or lower_in)
                for i in range(index.shape[0]):
                    fourier[0, i, t] += x * drive.lockin_cos[index[i]]
                    fourier[1, i, t] += x * drive.lockin_sin[index[i]]
                if keep:
                    for c in range(BALL_RECORD_COLUMNS):
                        readout.record[recorded, c, t] = sample[c]
            if keep:
                recorded += 1
            _next_index(index, shift, references)
        status, bad = _status(model, rows, peaks, h, drive.stop)
        if status != OK:
            _store(model, rows, q_prev, q)
            return status, bad
    for t in range(count):
        acc = (sums[0, t], sums[1, t], sums[2, t], sums[3, t], sums[4, t], sums[5, t], sums[6, t])
        _finish(readout, t, acc, fourier[0, :, t], fourier[1, :, t])
    _end_state(model, rows, readout, 2)
    _store(model, rows, q_prev, q)
    return OK, -1


measure_one = measure  # one trajectory is a batch of one: the same numbers by construction


def start(q, velocity, h, model):
    """Not available: the ball model starts from rest or from a run's state (nothing that
    needs a start from ``(q, q')``, shooting or the benchmark's dwell, runs it)."""
    raise NotImplementedError("the ball model starts from rest or from a run's state")


@njit(cache=CACHE, error_model="numpy")
def _restart(model, row, h_old, h_new):
    """:func:`.integrate.restart` for one trajectory's ``row`` (u[n-1], u, l[n-1], l) in
    place: one more step gives the rates and curvatures at the boundary."""
    u_prev, u, l_prev, l = row[0], row[1], row[2], row[3]
    c0 = h_old * h_old * (2.0 / 3.0)
    _, _, _, _, x, y = step(model, u_prev, u, l_prev, l, 1.0, h_old, c0)
    row[0] = _restarted(u_prev, u, x, h_old, h_new)
    row[2] = _restarted(l_prev, l, y, h_old, h_new)


@njit(cache=CACHE, inline="always")
def _restarted(before, now, increment, h_old, h_new):
    """``d[-1]`` at step ``h_new`` from ``d[n-1]``, ``d[n]`` and ``d[n+1] - d[n-1]`` at
    ``h_old``: ``d - h_new d' + h_new^2 / 2 d''`` with centred differences."""
    rate = increment / (2.0 * h_old)
    curvature = (increment - 2.0 * (now - before)) / (h_old * h_old)
    return now - h_new * rate + 0.5 * h_new * h_new * curvature


@njit(cache=CACHE, error_model="numpy")
def retune_batch(q_prev, q, h, h_new, model):
    """Carry every trajectory whose step changes to ``h_new`` (its ``q_prev`` changes,
    ``h`` becomes ``h_new``; q and the other trajectories are left as they are)."""
    row = np.empty(4)
    for t in range(q.shape[0]):
        if h_new[t] != h[t]:
            row[0], row[2] = compressions(model, q_prev[t, 0], q_prev[t, 1])
            row[1], row[3] = compressions(model, q[t, 0], q[t, 1])
            _restart(model, row, h[t], h_new[t])
            q_prev[t, 0], q_prev[t, 1] = displacements(model, row[0], row[2])
            h[t] = h_new[t]


def restart(q_prev, q, h_old, h_new, model):
    """The new ``q_prev`` (float[2]) of one trajectory at step ``h_new``."""
    a = np.array(q_prev, dtype=float).reshape(1, 2)
    b = np.array(q, dtype=float).reshape(1, 2)
    retune_batch(a, b, np.array([h_old], dtype=float), np.array([h_new], dtype=float), model)
    return a[0]


tables = period_tables
