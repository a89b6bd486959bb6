"""One period of the map with its exact derivatives, and Newton on it for every method.

:func:`period_map` is the central difference's; rk4's is :func:`.rk.period_map`. Newton
(:func:`newton`), the compiled shooting walk (:func:`shooting_walk`) and the transient's
approach (:func:`approach`) take either method's drive and call that method's kernels
(:func:`one_period`, :func:`advance`, :func:`measure_one`, :func:`restart`: chosen by the
drive's type when numba compiles them).

The one-period map of the scheme (:mod:`.scheme`) takes the state ``x = (q[-1], q[0])`` at
the start of a period (excitation phase 0) to ``P(x) = (q[N-1], q[N])``. In the compression
``d = 1 + 2 q / 3`` one step is ``d[n+1] = (2 d - d[n-1] (1 - c h / 2) + c0 (F - R)) / D``
with ``D = 1 + c h / 2``, ``c0 = 2 h^2 / 3``, ``R = d^(3/2)``, ``c = c(d)`` (eq. 8, 11).
Differentiating it (``R' = dR/dd``, ``c' = dc/dd`` at ``d[n]``)::

    dd[n+1]/dd[n-1] = -(1 - c h / 2) / D                        (= -b)
    dd[n+1]/dd[n]   = (2 - c0 R' + (h / 2) c' (d[n-1] - d[n+1])) / D
    dd[n+1]/dh      = ((4 h / 3) (F - R) - (c / 2) (d[n+1] - d[n-1])) / D

and carrying these through the period with the chain rule gives the exact 2x2 Jacobian
(the monodromy matrix of the discrete map, whose eigenvalues are the Floquet multipliers;
the same in q as in d, since q is an affine function of d) and ``dP/dh``. The excitation
table does not depend on w (N steps per period whatever w), so
``dP/dw = -(h / w) dP/dh`` is exact too.

The trajectory is computed by :func:`.integrate.step`, the very step of
:func:`.integrate.advance`: ``P(x)`` is one period of ``advance``, bit for bit.
Out of contact ``R' = 0`` and ``c' = 0``; ``R' = 3/2 sqrt(d)`` is continuous through
``d = 0``, so the map is continuously differentiable through loss of contact (for contact
damping with n = 0 the jump of c at ``d = 0`` makes it piecewise smooth; the derivative is
taken on the side the step is on).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit
from numba.core import types
from numba.extending import overload

from . import CACHE, integrate, rk
from .integrate import Readout, _finite, denominator, step
from .laws import slopes
from .scheme import (
    NON_FINITE,
    OK,
    STOPPED,
    UNSTABLE,
    constant,
    forcing,
    make_step,
    to_compression,
    to_displacement,
)
from .stop import requested


@njit(cache=CACHE, error_model="numpy", nogil=True)
def period_map(q_prev, q, h, law, drive, derivative):
    """One period of the scheme (level ``drive.sigma[0]``) with its exact derivatives.

    Parameters
    ----------
    q_prev, q : float
        The state ``x = (q[-1], q[0])`` at excitation phase 0.
    h : float
        Step in tau, ``2 pi / (w N)``.
    law, drive
        The damping law (:mod:`.laws`) and the input (:class:`.integrate.Drive`).
    derivative : float64[2, 3]
        Output: ``d(q[N-1], q[N]) / d(q[-1], q[0], h)``; the first two columns are the
        monodromy matrix, the third is ``dP/dh``.

    Returns
    -------
    tuple
        ``(q_prev, q, status)`` after one period, as :func:`.integrate.advance`.
    """
    s = make_step(law, h)
    sigma = drive.sigma[0]
    table = drive.sin_table
    d_prev = to_compression(q_prev)
    d = to_compression(q)
    # rows: derivative of d[n-1] and of d[n] with respect to d[-1], d[0], h
    a0, a1, a2 = 1.0, 0.0, 0.0
    b0, b1, b2 = 0.0, 1.0, 0.0
    for j in range(table.shape[0]):
        load = forcing(sigma, table[j])
        root, c, d_next = step(law, d_prev, d, load, constant(s))
        if root >= s.limit:
            return to_displacement(d_prev), to_displacement(d), UNSTABLE
        stiffness, dc = slopes(law, d, root)
        inv = 1.0 / (1.0 + c * s.half_h)
        by_prev = -(1.0 - c * s.half_h) * inv
        by_d = (2.0 - s.c0 * stiffness + s.half_h * dc * (d_prev - d_next)) * inv
        by_h = ((4.0 / 3.0) * h * (load - d * root) - 0.5 * c * (d_next - d_prev)) * inv
        a0, a1, a2, b0, b1, b2 = (
            b0,
            b1,
            b2,
            by_prev * a0 + by_d * b0,
            by_prev * a1 + by_d * b1,
            by_prev * a2 + by_d * b2 + by_h,
        )
        d_prev = d
        d = d_next
    derivative[0, 0] = a0
    derivative[0, 1] = a1
    derivative[0, 2] = 1.5 * a2
    derivative[1, 0] = b0
    derivative[1, 1] = b1
    derivative[1, 2] = 1.5 * b2
    if not (_finite(d_prev, d) and math.isfinite(b0 + b1 + b2)):
        return to_displacement(d_prev), to_displacement(d), NON_FINITE
    if requested(drive.stop):
        return to_displacement(d_prev), to_displacement(d), STOPPED
    return to_displacement(d_prev), to_displacement(d), OK


# ---------------------------------------------------------------- every method's map
# Newton, the shooting walk and the transient's approach serve every method: each call
# below is the kernel of the method whose drive it is given (a drive's namedtuple type
# names its method), chosen when numba compiles the caller, so nothing is passed as a
# function and every kernel stays cached.

MODULES = {integrate.Drive: integrate, rk.Drive: rk}
"""The kernel module of each method's drive type."""
PERIOD_MAPS = {integrate.Drive: period_map, rk.Drive: rk.period_map}
"""The one-period map with its Jacobian of each method's drive type."""


def _kernel(drive, name):
    """The kernel ``name`` of the method whose drive has this numba type (``"period_map"``:
    its one-period map with the Jacobian); None if the type is no method's drive."""
    if not isinstance(drive, types.BaseNamedTuple):
        return None
    cls = drive.instance_class
    if name == "period_map":
        return PERIOD_MAPS.get(cls)
    module = MODULES.get(cls)
    return None if module is None else getattr(module, name)


def one_period(a, q, h, law, drive, derivative):
    """One period with its derivatives: :func:`period_map` or the drive's method's own."""
    raise NotImplementedError("compiled only")


def advance(a, q, h, law, drive, periods):
    """The drive's method's ``advance``."""
    raise NotImplementedError("compiled only")


def measure_one(a, q, h, law, drive, periods, readout):
    """The drive's method's ``measure_one``."""
    raise NotImplementedError("compiled only")


def restart(a, q, h_old, h_new, law, drive):
    """The drive's method's first state member carried from step h_old to h_new."""
    raise NotImplementedError("compiled only")


def _dispatch(stub, name):
    """Overload ``stub`` (six arguments, the drive fifth) by the drive's method's kernel
    ``name``, which takes the same arguments."""

    @overload(stub)
    def implementation(a, q, h, law, drive, last):
        kernel = _kernel(drive, name)
        if kernel is None:
            return None
        return lambda a, q, h, law, drive, last: kernel(a, q, h, law, drive, last)

    return implementation


_dispatch(one_period, "period_map")
_dispatch(advance, "advance")


@overload(measure_one)
def _measure_one(a, q, h, law, drive, periods, readout):
    kernel = _kernel(drive, "measure_one")
    if kernel is None:
        return None
    return lambda a, q, h, law, drive, periods, readout: kernel(
        a, q, h, law, drive, periods, readout
    )


@overload(restart)
def _restart(a, q, h_old, h_new, law, drive):
    kernel = _kernel(drive, "restart")
    if kernel is None:
        return None
    return lambda a, q, h_old, h_new, law, drive: kernel(a, q, h_old, h_new, law)


@njit(cache=CACHE, error_model="numpy", nogil=True)
def approach(a, q, h, law, drive, block, max_periods, tolerance):
    """Whole periods of one trajectory in blocks of ``block``, until the state after the
    last period of a block is within ``tolerance`` (absolute, in q and in the method's
    other member) of the state one period before, or ``max_periods`` are done: a
    transient run up to its attractor.

    Returns ``(a, q, periods, status, close)``.
    """
    periods = 0
    while periods < max_periods:
        count = min(block, max_periods - periods)
        a, q, status = advance(a, q, h, law, drive, count - 1)
        if status != OK:
            return a, q, periods, status, False
        after_a, after, status = advance(a, q, h, law, drive, 1)
        if status != OK:
            return after_a, after, periods, status, False
        periods += count
        close = max(abs(after - q), abs(after_a - a)) <= tolerance
        a, q = after_a, after
        if close:
            return a, q, periods, OK, True
    return a, q, periods, OK, False


CONVERGED_PERIODS = 1  # periods read on a converged stable orbit: all its periods are one
# period, to the Newton residual (1e-10 of Q), so one period reads what any number would;
# times the lock-in's common denominator L (:func:`.integrate.denominator`) where it reads
# orders that are not whole, which need whole response periods of L excitation periods

NewtonSettings = namedtuple(
    "NewtonSettings",
    ["scale", "basis", "tolerance", "max_iterations", "monotone", "margin", "predict"],
)
"""Newton on the one-period map (:func:`newton`): the orbit scale Q and the scaled
coordinates z of the state ``x = Q basis z`` (``basis`` float64[2, 2], the method's, of
the form ``[[b00, b01], [1, 0]]``: ``z0 = q / Q``; see :mod:`.methods`), the residual
``|P(x) - x|_inf / Q`` that counts as converged, the most iterations, whether to stop as
soon as a correction fails to shrink, the margin below 1 of the largest Floquet
multiplier's modulus that counts as stable, and the residual at or below which the
corrected iterate is returned unevaluated (:data:`PREDICTED`; 0: never), for a caller
that integrates it anyway (:func:`shooting_walk` reads its period)."""

PREDICTED_MARGIN = 1e-4  # a predicted orbit whose largest multiplier is this close to 1 (a
# fold near) is solved unpredicted: its stability is then judged at the orbit itself
FAILED, CONVERGED, PREDICTED = 0, 1, 2  # what newton returns: not converged; the last
# iterate evaluated is the fixed point; the last correction applied, not yet evaluated


@njit(cache=CACHE, error_model="numpy", nogil=True)
def newton(a, q, h, law, drive, settings, residuals, monodromy):
    """Newton's method on ``P(x) = x`` at a fixed step h, from ``x = (a, q)`` (the drive's
    method's state and its one-period map, :func:`one_period`).

    In the scaled coordinates z (``x = Q B z``, ``B = settings.basis``) each iterate
    solves ``(M - I) B dz = -(P(x) - x) / Q`` (2 x 2, Cramer's rule) with the exact
    monodromy M of the map.

    Parameters
    ----------
    residuals : float64[max_iterations + 1]
        Output: ``|P(x) - x|_inf / Q`` at each iterate evaluated (inf where a period failed).
    monodromy : float64[2, 2]
        Output: M at the last iterate evaluated.

    Returns
    -------
    tuple
        ``(a, q, evaluations, outcome)``: the last iterate evaluated (the fixed point
        when :data:`CONVERGED`; the corrected one, unevaluated, when :data:`PREDICTED`),
        the number of periods integrated, and :data:`FAILED`, :data:`CONVERGED` or
        :data:`PREDICTED` (only with ``settings.predict > 0``).
    """
    scale, b = settings.scale, settings.basis
    z0 = q / scale  # every method's basis is [[b00, b01], [1, 0]]: z0 = q / Q
    z1 = (a - b[0, 0] * q) / (b[0, 1] * scale)
    derivative = np.zeros((2, 3))
    previous = np.inf  # size of the last correction
    for iteration in range(settings.max_iterations + 1):
        x0 = scale * (b[0, 0] * z0 + b[0, 1] * z1)
        x1 = scale * (b[1, 0] * z0 + b[1, 1] * z1)
        p0, p1, status = one_period(x0, x1, h, law, drive, derivative)
        g0 = (p0 - x0) / scale
        g1 = (p1 - x1) / scale
        ok = status == OK and math.isfinite(g0) and math.isfinite(g1)
        residuals[iteration] = max(abs(g0), abs(g1)) if ok else np.inf
        monodromy[:, :] = derivative[:, :2]
        if not ok:
            return x0, x1, iteration + 1, FAILED
        if residuals[iteration] <= settings.tolerance:
            return x0, x1, iteration + 1, CONVERGED
        if iteration == settings.max_iterations:
            break
        a00, a01 = monodromy[0, 0] - 1.0, monodromy[0, 1]
        a10, a11 = monodromy[1, 0], monodromy[1, 1] - 1.0
        j00, j01 = a00 * b[0, 0] + a01 * b[1, 0], a00 * b[0, 1] + a01 * b[1, 1]  # (M - I) B
        j10, j11 = a10 * b[0, 0] + a11 * b[1, 0], a10 * b[0, 1] + a11 * b[1, 1]
        det_j = j00 * j11 - j01 * j10
        if det_j == 0.0 or not math.isfinite(det_j):
            return x0, x1, iteration + 1, FAILED
        c0 = (g0 * j11 - j01 * g1) / det_j
        c1 = (j00 * g1 - j10 * g0) / det_j
        size = max(abs(c0), abs(c1))
        if settings.monotone and size >= previous:
            return x0, x1, iteration + 1, FAILED
        previous = size
        z0 -= c0
        z1 -= c1
        if residuals[iteration] <= settings.predict:
            x0 = scale * (b[0, 0] * z0 + b[0, 1] * z1)
            x1 = scale * (b[1, 0] * z0 + b[1, 1] * z1)
            return x0, x1, iteration + 1, PREDICTED
    return x0, x1, settings.max_iterations + 1, FAILED


@njit(cache=CACHE)
def largest_multiplier(monodromy):
    """The largest modulus of the eigenvalues of a 2 x 2 monodromy matrix."""
    trace = monodromy[0, 0] + monodromy[1, 1]
    det = monodromy[0, 0] * monodromy[1, 1] - monodromy[0, 1] * monodromy[1, 0]
    disc = trace * trace - 4.0 * det
    if disc < 0.0:  # a complex pair: |mu|^2 = det
        return math.sqrt(det)
    root = math.sqrt(disc)
    return max(abs(0.5 * (trace + root)), abs(0.5 * (trace - root)))


Transient = namedtuple("Transient", ["block", "tolerance", "max_periods"])
"""A transient run up to its attractor (:func:`settle`): periods between two checks of
the one-period mismatch, the mismatch (absolute, in q and the method's other member)
below which Newton polishes, the most periods in all."""


@njit(cache=CACHE, error_model="numpy", nogil=True)
def settle(a, q, h, law, drive, settings, transient, monodromy):
    """Integrate the transient from ``(a, q)`` to its attractor, then polish by Newton.

    Blocks of ``transient.block`` periods (:func:`approach`) until the one-period
    mismatch is within ``transient.tolerance``; there Newton must land on a stable orbit,
    otherwise integration goes on from where it was, at most ``transient.max_periods``
    periods of it in all (Newton's evaluations besides).

    Returns ``(a, q, periods, status, stable)``: the stable orbit (``monodromy`` its M),
    or where the integration stopped (not stable: e.g. after a period doubling; or a
    status other than OK), and the periods integrated.
    """
    residuals = np.empty(settings.max_iterations + 1)
    integrated = 0  # periods of the transient: the budget counts no Newton evaluation
    periods = 0
    while integrated < transient.max_periods:
        count = transient.max_periods - integrated
        a, q, done, status, close = approach(
            a, q, h, law, drive, transient.block, count, transient.tolerance
        )
        integrated += done
        periods += done
        if status != OK or not close:
            return a, q, periods, status, False
        x0, x1, evaluations, outcome = newton(a, q, h, law, drive, settings, residuals, monodromy)
        periods += evaluations
        if outcome == CONVERGED and largest_multiplier(monodromy) < 1.0 - settings.margin:
            return x0, x1, periods, OK, True
    return a, q, periods, OK, False


@njit(cache=CACHE)
def _repeats(a, q, a_after, q_after, settings):
    """Whether the state ``(a, q)`` returns to itself after one period (the state read
    after it) within Newton's tolerance: the residual :func:`newton` would evaluate."""
    residual = max(abs((a_after - a) / settings.scale), abs((q_after - q) / settings.scale))
    return residual <= settings.tolerance


READ, UNSETTLED, LOST = 0, 1, 2  # a dwell of the walk: its orbit found and read; no
# stable orbit reached (the state where the integration stopped); a kernel status


@njit(cache=CACHE, error_model="numpy", nogil=True)
def shooting_walk(state, steps, law, drive, settings, readout, start, transient):
    """Stepped-sine dwells by shooting, from dwell ``start`` on: retune the state
    (float64[3]: the method's first member, q, h) to ``steps[i]``, solve the orbit
    (:func:`_dwell_orbit`), read :data:`CONVERGED_PERIODS` of it (times L) into column i
    of ``readout`` (:class:`~hertzsweep.kernels.integrate.Readout` over the dwells).

    Returns ``(stop, periods, unsettled)``: the first dwell whose orbit was not found
    (``len(steps)`` if none) and the periods integrated in all; ``unsettled``: at that
    dwell the transient ran ``transient.max_periods`` without reaching a stable orbit
    and ``state`` holds where it stopped (else ``state`` holds the dwell's retuned start:
    a kernel status stopped it, for the caller to run again and report).
    """
    one = Readout(
        np.zeros((readout.coefficients.shape[0], 2, 1)),
        np.zeros((readout.sums.shape[0], 1)),
        np.zeros((readout.counts.shape[0], 1)),
        np.zeros((0, 4, 1)),
        0,
        np.zeros((0, 1)),
    )
    unpredicted = NewtonSettings(
        settings.scale,
        settings.basis,
        settings.tolerance,
        settings.max_iterations,
        settings.monotone,
        settings.margin,
        0.0,
    )
    # the buffers every dwell reuses: residuals, M, the state read, the reading
    work = (np.empty(settings.max_iterations + 1), np.zeros((2, 2)), np.empty(2), one)
    periods = 0
    for i in range(start, steps.shape[0]):
        if steps[i] != state[2]:
            state[0] = restart(state[0], state[1], state[2], steps[i], law, drive)
            state[2] = steps[i]
        a, q, count, found = _dwell_orbit(
            state, law, drive, (settings, unpredicted), transient, work
        )
        periods += count
        if found == LOST:
            return i, periods, False
        if found == UNSETTLED:
            state[0], state[1] = a, q
            return i, periods, True
        _store(readout, i, one, state, a, q)
    return steps.shape[0], periods, False


@njit(cache=CACHE, error_model="numpy", nogil=True)
def _dwell_orbit(state, law, drive, solvers, transient, work):
    """One dwell of :func:`shooting_walk`, as ``drivers.shooting.shooting_dwell``: Newton
    (monotone) from the retuned ``state``; where it fails or lands on an unstable orbit (a
    fold was passed), the transient to the new attractor, polished (:func:`settle`).
    On a stable orbit its period is read into ``one``.

    Newton runs with ``settings.predict``: its last iterate is read without evaluating it
    first, and where it does not repeat after that period (or the largest multiplier at
    the iterate before is within :data:`PREDICTED_MARGIN` of 1), Newton runs again from
    the start without prediction: every dwell gets the iterates, the orbit and the
    stability verdict of Newton without prediction, bit for bit.

    ``solvers = (settings, unpredicted)``: Newton's settings with and without
    ``predict``; ``work = (residuals, monodromy, pair, one)``: the walk's buffers.

    Returns ``(a, q, periods, found)``: the state after the period read (:data:`READ`),
    where the transient stopped (:data:`UNSETTLED`), or nothing (:data:`LOST`).
    """
    settings, unpredicted = solvers
    residuals, monodromy, pair, one = work
    read = CONVERGED_PERIODS * denominator(drive)  # whole periods of every order read
    x0, x1, periods, outcome = newton(
        state[0], state[1], state[2], law, drive, settings, residuals, monodromy
    )
    pair[0], pair[1] = x0, x1
    q_prev, q = pair[0:1], pair[1:2]
    if outcome == PREDICTED and largest_multiplier(monodromy) < 1.0 - PREDICTED_MARGIN:
        status, _ = measure_one(q_prev, q, state[2:3], law, drive, read, one)
        periods += read
        if status != OK:  # a stop request (or a blow-up Newton would have met)
            return state[0], state[1], periods, LOST
        if _repeats(x0, x1, q_prev[0], q[0], settings):  # converged (after L periods)
            return q_prev[0], q[0], periods, READ
    if outcome == PREDICTED:  # not the orbit yet, or a fold near
        x0, x1, evaluations, outcome = newton(
            state[0], state[1], state[2], law, drive, unpredicted, residuals, monodromy
        )
        periods += evaluations
    if outcome == FAILED or largest_multiplier(monodromy) >= 1.0 - settings.margin:
        x0, x1, count, status, stable = settle(
            state[0], state[1], state[2], law, drive, unpredicted, transient, monodromy
        )
        periods += count
        if status != OK:
            return state[0], state[1], periods, LOST
        if not stable:
            return x0, x1, periods, UNSETTLED
    q_prev[0], q[0] = x0, x1
    status, _ = measure_one(q_prev, q, state[2:3], law, drive, read, one)
    if status != OK:
        return state[0], state[1], periods + read, LOST
    return q_prev[0], q[0], periods + read, READ


@njit(cache=CACHE)
def _store(readout, i, one, state, a, q):
    """Dwell i's reading into column i of the walk's readout; the state read after it."""
    readout.coefficients[:, :, i] = one.coefficients[:, :, 0]
    readout.sums[:, i] = one.sums[:, 0]
    readout.counts[:, i] = one.counts[:, 0]
    state[0], state[1] = a, q


__all__ = [
    "CONVERGED",
    "CONVERGED_PERIODS",
    "FAILED",
    "PREDICTED",
    "advance",
    "approach",
    "measure_one",
    "one_period",
    "restart",
    "NewtonSettings",
    "largest_multiplier",
    "newton",
    "period_map",
    "settle",
    "shooting_walk",
    "Transient",
]
