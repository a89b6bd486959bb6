"""Periodic orbits by shooting: Newton on the one-period map of the scene's method.

A T-periodic response (``T = 2 pi / w``) of the method is a fixed point ``x = P(x)`` of its
one-period map, the state being the method's pair at excitation phase 0 and step ``h =
2 pi / (w N)``: ``x = (q[-1], q[0])`` for the central difference, ``(q'[0], q[0])`` for
rk4 (:mod:`hertzsweep.kernels.methods`). Newton's method with the exact Jacobian of the
discrete map,

    (M - I) dx = -(P(x) - x),    M = dP/dx  (the monodromy matrix),

converges quadratically, and its fixed point is the very state a long settled run of the
method's ``advance`` tends to (the same arithmetic, bit for bit). The Floquet multipliers
are the eigenvalues of M; the orbit is asymptotically stable when both lie inside the
unit circle.

Coordinates. Residuals are measured in units of the orbit scale ``Q`` (:func:`orbit_scale`,
the linear resonance amplitude ``sigma / (2 zeta)``), and the continuation works in the
method's scaled coordinates ``z`` with ``x = Q B z`` (``B`` constant, the method's
``basis``): for the central difference ``z = (q[0], (q[0] - q[-1]) / theta) / Q`` with
``theta = w h = 2 pi / N``, for rk4 ``z = (q[0], q'[0]) / Q``; displacement and velocity
at phase 0, both of the order of the response amplitude over Q. The multipliers do not
depend on the coordinates.

Shooting-accelerated sweeps (:func:`shooting_dwell`): at each frequency step, Newton from
the previous steady state; if it lands on a stable orbit, measure on it; otherwise a fold
was passed and the response jumps: integrate the transient to the new attractor, then
polish by Newton.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.model import force_bound
from ..kernels import tangent
from ..kernels.integrate import Readout, new_readout
from ..kernels.scheme import OK
from ..kernels.tangent import CONVERGED_PERIODS, NewtonSettings, Transient
from .oscillator import Block, Oscillator, Reading, State, dwell_by_dwell

NEWTON_TOLERANCE = 1e-10  # residual |P(x) - x|_inf / Q of a converged orbit: 1e4 x above the
# round-off of one period at N = 256 (about 1e-14 of Q), far below every reading's accuracy
MAX_NEWTON_ITERATIONS = 12  # quadratic convergence needs 3-5 from a neighbouring frequency
TRANSIENT_BLOCK = 10  # periods integrated between two checks of the one-period mismatch
TRANSIENT_TOLERANCE = 1e-3  # |x(T) - x(0)|_inf / Q below which a transient is close enough to
# its attractor to polish by Newton (Newton's basin around a stable orbit is far wider)
PREDICT_RESIDUAL = 1e-6  # a sweep's walk takes Newton's next iterate from a residual this
# small (quadratic convergence: about 1e-12, below NEWTON_TOLERANCE) without evaluating
# it, reads its period instead, and checks there that it repeats (else Newton runs again
# unpredicted); not where the monodromy jumps (continuous_monodromy)
STABILITY_MARGIN = 1e-9  # |multiplier| below 1 - this counts as stable (round-off of M)


@dataclass(frozen=True)
class Evaluation:
    """One period of the map at ``(z, w)`` in scaled coordinates.

    Attributes
    ----------
    residual : float[2]
        ``G = (P(x) - x) / Q``.
    jacobian : float[2, 3]
        ``dG / d(z1, z2, w)``.
    monodromy : float[2, 2]
        ``M = dP/dx`` (in the method's state coordinates).
    ok : bool
        The period ended finite and within the stability limit.
    offset : float[size]
        ``z`` of the state after :attr:`PeriodMap.check` periods minus ``z`` (zeros
        without a check).
    """

    residual: np.ndarray
    jacobian: np.ndarray
    monodromy: np.ndarray
    ok: bool
    offset: np.ndarray | None = None

    @property
    def error(self) -> float:
        return float(np.max(np.abs(self.residual))) if self.ok else float("inf")


@dataclass(frozen=True)
class Orbit:
    """A Newton solve at one frequency.

    Attributes
    ----------
    state : State
        The fixed point (or the last iterate when not converged), excitation phase 0.
    frequency_ratio : [1] w.
    monodromy : float[2, 2]
        M at the last iterate evaluated (NaN where none was).
    residuals : tuple of float
        ``|P(x) - x|_inf / Q`` at each iterate, the first at the starting state.
    converged : bool
        The last residual is below :data:`NEWTON_TOLERANCE`.
    """

    state: State
    frequency_ratio: float
    monodromy: np.ndarray
    residuals: tuple[float, ...]
    converged: bool

    @property
    def multipliers(self) -> np.ndarray:
        """Floquet multipliers, largest modulus first (a complex pair: positive imaginary
        part first); NaN where no period was evaluated."""
        if not np.all(np.isfinite(self.monodromy)):
            return np.full(self.monodromy.shape[0], np.nan + 0j)
        return sorted_multipliers(self.monodromy)

    @property
    def stable(self) -> bool:
        """Every multiplier inside the unit circle (asymptotically stable), judged as the
        compiled walk judges (:func:`largest_multiplier`)."""
        if not self.converged or not np.all(np.isfinite(self.monodromy)):
            return False
        return bool(largest_multiplier(self.monodromy) < 1.0 - STABILITY_MARGIN)


def largest_multiplier(monodromy: np.ndarray) -> float:
    """The largest modulus of the monodromy's eigenvalues: the compiled walk's own 2 x 2
    formula (:func:`~hertzsweep.kernels.tangent.largest_multiplier`) for the single model,
    LAPACK's eigenvalues for a larger state (the ball model's 4 x 4)."""
    if monodromy.shape == (2, 2):
        return float(tangent.largest_multiplier(monodromy))
    return float(np.max(np.abs(np.linalg.eigvals(monodromy))))


def orbit_scale(sigma: float, zeta: float) -> float:
    """``Q``: the linear resonance amplitude of q, ``sigma / (2 zeta)`` (zeta floored as in
    :func:`hertzsweep.model.force_bound`), never below sigma."""
    return force_bound(sigma, zeta) - 1.0


def sorted_multipliers(monodromy: np.ndarray) -> np.ndarray:
    """Eigenvalues of the monodromy matrix, largest modulus first (ties: imaginary part
    descending, so a complex pair is ``(mu, conj(mu))``)."""
    mu = np.linalg.eigvals(monodromy).astype(complex)
    order = np.lexsort((-mu.imag, -np.abs(mu)))
    return mu[order]


class PeriodMap:
    """The n-period map ``P^n`` of an oscillator in scaled coordinates, with its exact
    Jacobian (``periods = n``; 1 by default: the one-period map).

    ``P^n`` is n one-period maps in a row, each the method's compiled period with its
    exact tangent (:meth:`Oscillator.period_map`); the chain rule makes the n-period
    monodromy the product ``M_n ... M_1`` of the one-period ones (each at its own state of
    the orbit) and ``dP^n/dh`` the sum ``sum_k (M_n ... M_{k+1}) dP/dh|_k``: exact for every
    method and model, as the one-period tangent is. The Floquet multipliers of an
    n-periodic orbit are the eigenvalues of that product. Every evaluation adds
    ``n steps_per_period`` to ``oscillator.steps``.

    ``check`` (a divisor of n, default none): the evaluation also reports how far the
    state is from repeating after ``check`` periods (:attr:`Evaluation.offset`), which a
    period-doubled branch watches to see it return to its parent's branch.
    """

    def __init__(self, oscillator: Oscillator, periods: int = 1, check: int = 0) -> None:
        self.oscillator = oscillator
        self.periods = int(periods)
        self.check = int(check)
        self.scale = orbit_scale(oscillator.sigma, oscillator.zeta)
        self.shape = oscillator.method.basis(oscillator.steps_per_period)
        self.basis = self.scale * self.shape  # x = basis @ z
        self.inverse = np.linalg.inv(self.basis)
        self.size = self.basis.shape[0]  # 2 for the single model, 4 for the ball model
        self._derivative = np.zeros((self.size, self.size + 1))

    @property
    def reading_periods(self) -> int:
        """The periods a converged orbit is read over: whole periods of the orbit (n) and
        of every lock-in order (the orders' common denominator L), ``lcm(n, L)``."""
        return math.lcm(self.periods, self.oscillator.denominator)

    def vector(self, state: State) -> np.ndarray:
        """``x``: the state's two members (each a float, or the ball model's float[2])."""
        return np.concatenate((np.atleast_1d(state.q_prev), np.atleast_1d(state.q)))

    def coordinates(self, state: State) -> np.ndarray:
        """``z`` of a state (which must be at the step of the frequency it is used with)."""
        return self.inverse @ self.vector(state)

    def state(self, z: np.ndarray, frequency_ratio: float) -> State:
        return self._state(self.basis @ z, self.oscillator.step(frequency_ratio))

    def _state(self, x: np.ndarray, h: float) -> State:
        if self.size == 2:
            return State(float(x[0]), float(x[1]), h)
        half = self.size // 2
        return State(x[:half].copy(), x[half:].copy(), h)

    def advance(self, x: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray, int, np.ndarray]:
        """``P^n(x)`` and its derivative ``d P^n / d(x, h)`` (float[size, size + 1]) from
        ``x`` at step ``h``: n compiled periods, their tangents chained. Returns ``(end,
        derivative, status, offset)``, ``offset`` the state after ``check`` periods minus
        ``x`` (zeros without a check)."""
        osc = self.oscillator
        n = self.size
        state = self._state(x, h)
        offset = np.zeros(n)
        total = self._derivative
        status = OK
        for k in range(self.periods):
            state, status = osc.period_map(state, self._derivative)
            one = self._derivative
            if k == 0:
                total = one.copy()
            else:  # the chain rule: d x_{k+1} = M_k d x_k + (dP/dh)_k dh
                total = one[:, :n] @ total
                total[:, n] += one[:, n]
            if status != OK:
                break
            if k + 1 == self.check:
                offset = self.vector(state) - x
        return self.vector(state), total, status, offset

    def __call__(self, z: np.ndarray, frequency_ratio: float) -> Evaluation:
        n = self.size
        x = self.basis @ z
        h = self.oscillator.step(frequency_ratio)
        end, derivative, status, offset = self.advance(x, h)
        monodromy = derivative[:, :n].copy()
        residual = (end - x) / self.scale
        jacobian = np.empty((n, n + 1))
        jacobian[:, :n] = (monodromy - np.eye(n)) @ self.basis / self.scale
        jacobian[:, n] = derivative[:, n] * (-h / frequency_ratio) / self.scale  # dh/dw = -h/w
        ok = status == OK and bool(np.all(np.isfinite(residual)))
        return Evaluation(residual, jacobian, monodromy, ok, self.inverse @ offset)


def newton_settings(
    period: PeriodMap,
    monotone: bool,
    max_iterations: int = MAX_NEWTON_ITERATIONS,
    predict: float = 0.0,
) -> NewtonSettings:
    """The compiled Newton's settings for an oscillator's period map (``predict``: see
    :class:`~hertzsweep.kernels.tangent.NewtonSettings`)."""
    return NewtonSettings(
        period.scale,
        period.shape,
        NEWTON_TOLERANCE,
        max_iterations,
        monotone,
        STABILITY_MARGIN,
        predict,
    )


def newton(
    period: PeriodMap,
    state: State,
    frequency_ratio: float,
    monotone: bool = False,
    max_iterations: int = MAX_NEWTON_ITERATIONS,
) -> Orbit:
    """Newton on ``P(x) = x`` at fixed w from ``state`` (at that frequency's step),
    compiled (:func:`hertzsweep.kernels.tangent.newton`): one call per solve; on
    ``P^n(x) = x`` for a map of n > 1 periods (numpy's solve, each period compiled).

    Parameters
    ----------
    monotone : bool
        Stop (not converged) as soon as a Newton correction fails to shrink (in the
        scaled coordinates): the iterates then left the neighbourhood where Newton
        converges to the orbit nearest the start, and a sweep must integrate instead (a
        monotonicity test in the spirit of Deuflhard's, on the affine-invariant corrections
        rather than on the residuals, which may rise once on the way in).
    """
    if period.size != 2 or period.periods != 1:
        return _newton(period, state, frequency_ratio, monotone, max_iterations)
    osc = period.oscillator
    settings = newton_settings(period, monotone, max_iterations)
    residuals = np.full(max_iterations + 1, np.inf)
    monodromy = np.zeros((2, 2))
    h = osc.step(frequency_ratio)
    q_prev, q, evaluations, outcome = tangent.newton(
        state.q_prev, state.q, h, osc.law, osc.drive, settings, residuals, monodromy
    )
    osc.steps += evaluations * osc.steps_per_period
    if not np.isfinite(residuals[evaluations - 1]):
        monodromy[:] = np.nan
    orbit = State(q_prev, q, h)
    converged = outcome == tangent.CONVERGED  # settings.predict = 0: never PREDICTED
    return Orbit(orbit, frequency_ratio, monodromy, tuple(residuals[:evaluations]), converged)


def _newton(
    period: PeriodMap, state: State, frequency_ratio: float, monotone: bool, max_iterations: int
) -> Orbit:
    """:func:`newton` for a state of more than two numbers (the ball model's four) or a
    map of more than one period: the compiled Newton's iteration
    (:func:`hertzsweep.kernels.tangent.newton`, its tolerance and monotonicity test) with
    numpy's solve, each period compiled."""
    z = period.coordinates(state)
    residuals: list[float] = []
    monodromy = np.full((period.size, period.size), np.nan)
    previous = np.inf
    for iteration in range(max_iterations + 1):
        evaluation = period(z, frequency_ratio)
        residuals.append(evaluation.error)
        if not evaluation.ok:
            break
        monodromy = evaluation.monodromy
        if evaluation.error <= NEWTON_TOLERANCE:
            orbit = period.state(z, frequency_ratio)
            return Orbit(orbit, frequency_ratio, monodromy, tuple(residuals), True)
        if iteration == max_iterations:
            break
        try:
            correction = np.linalg.solve(evaluation.jacobian[:, :-1], evaluation.residual)
        except np.linalg.LinAlgError:
            break
        size = float(np.max(np.abs(correction)))
        if not np.isfinite(size) or (monotone and size >= previous):
            break
        previous = size
        z = z - correction
    orbit = period.state(z, frequency_ratio)
    return Orbit(orbit, frequency_ratio, monodromy, tuple(residuals), False)


def mismatch(period: PeriodMap, before: State, after: State) -> float:
    """``|x(nT) - x(0)|_inf / Q``: how far a state is from repeating after the map's
    periods (``after`` is ``before`` that many periods on)."""
    return float(np.max(np.abs(period.vector(after) - period.vector(before)))) / period.scale


def transient(period: PeriodMap, max_periods: int) -> Transient:
    """The compiled transient's settings: blocks of :data:`TRANSIENT_BLOCK` periods, down
    to a one-period mismatch of :data:`TRANSIENT_TOLERANCE` of Q, at most ``max_periods``."""
    return Transient(TRANSIENT_BLOCK, TRANSIENT_TOLERANCE * period.scale, int(max_periods))


def settle(period: PeriodMap, state: State, frequency_ratio: float, max_periods: int) -> Orbit:
    """Integrate the transient from ``state`` to its attractor, then polish by Newton
    (compiled: :func:`hertzsweep.kernels.tangent.settle`).

    Blocks of :data:`TRANSIENT_BLOCK` periods until the one-period mismatch is below
    :data:`TRANSIENT_TOLERANCE`; there Newton (monotone) must land on a stable orbit,
    otherwise integration goes on, at most ``max_periods`` periods in all. Returns the
    stable orbit (its residuals not kept), or, where none was reached (e.g. after a
    period doubling), the state where the integration stopped, not converged.
    """
    if period.size != 2 or period.periods != 1:
        return _settle(period, state, frequency_ratio, max_periods)
    osc = period.oscillator
    monodromy = np.zeros((2, 2))
    a, q, periods, status, stable = tangent.settle(
        state.q_prev,
        state.q,
        state.h,
        osc.law,
        osc.drive,
        newton_settings(period, monotone=True),
        transient(period, max_periods),
        monodromy,
    )
    osc.steps += periods * osc.steps_per_period
    osc.check_status(status, frequency_ratio)
    if stable:
        return Orbit(State(a, q, state.h), frequency_ratio, monodromy, (), True)
    return Orbit(State(a, q, state.h), frequency_ratio, np.full((2, 2), np.nan), (np.inf,), False)


def _settle(period: PeriodMap, state: State, frequency_ratio: float, max_periods: int) -> Orbit:
    """:func:`settle` for a state of more than two numbers or a map of n > 1 periods: the
    compiled transient's steps (blocks of :data:`TRANSIENT_BLOCK` periods, a whole number
    of n, to an n-period mismatch of :data:`TRANSIENT_TOLERANCE`, then monotone Newton on
    a stable orbit or on), each block one compiled call."""
    osc = period.oscillator
    n = period.periods
    block = -(-TRANSIENT_BLOCK // n) * n
    integrated = 0
    while integrated < max_periods:
        count = max(n, min(block, max_periods - integrated) // n * n)
        state = osc.advance(state, frequency_ratio, count - n)
        after = osc.advance(state, frequency_ratio, n)
        integrated += count
        close = mismatch(period, state, after) <= TRANSIENT_TOLERANCE
        state = after
        if close:
            orbit = newton(period, state, frequency_ratio, monotone=True)
            if orbit.stable:
                return Orbit(orbit.state, frequency_ratio, orbit.monodromy, (), True)
    nan = np.full((period.size, period.size), np.nan)
    return Orbit(state, frequency_ratio, nan, (np.inf,), False)


def find_orbit(period: PeriodMap, state: State, frequency_ratio: float) -> Orbit:
    """The stable orbit a run from ``state`` reaches: Newton first (monotone), then
    :func:`settle` if Newton fails or lands on an unstable orbit."""
    orbit = newton(period, state, frequency_ratio, monotone=True)
    if orbit.stable:
        return orbit
    max_periods = period.oscillator.scene.sweep.max_settle_periods
    return settle(period, state, frequency_ratio, max_periods)


def shooting_dwell(
    oscillator: Oscillator, state: State, frequency_ratio: float
) -> tuple[State, Reading, bool]:
    """One stepped-sine dwell by shooting: the drop-in for :meth:`Oscillator.dwell` that
    :func:`hertzsweep.sweep.run_sweep` uses when ``[sweep] steady_state = "shooting"``.

    With ``[sweep] period_multiple = n`` the orbit sought is a fixed point of the n-period
    map ``P^n`` (:class:`PeriodMap`): a period-n orbit where the sweep's state settles on
    one (a period-1 orbit is one too, its multipliers the n-th powers), measured over n
    periods.

    Newton from the previous steady state (retuned to this frequency's step); on a stable
    orbit, measure one period of it (:data:`CONVERGED_PERIODS`). Where Newton fails or lands on an
    unstable orbit (a fold was passed), integrate the transient to the new attractor and
    polish by Newton (:func:`find_orbit`). ``settled`` is true when Newton converged on a
    stable orbit; otherwise the reading is of the state the integration reached.

    Returns
    -------
    tuple
        ``(state, reading, settled)`` as :meth:`Oscillator.dwell`.
    """
    period = PeriodMap(oscillator, oscillator.scene.sweep.period_multiple)
    state = oscillator.retune(state, frequency_ratio)
    orbit = find_orbit(period, state, frequency_ratio)
    converged = CONVERGED_PERIODS * period.reading_periods
    measured = converged if orbit.stable else oscillator.scene.sweep.measure_periods
    state, reading = oscillator.measure(orbit.state, frequency_ratio, measured)
    return state, reading, orbit.stable


def continuous_monodromy(oscillator: Oscillator) -> bool:
    """Whether the monodromy matrix is continuous in the state: not with contact damping
    of exponent 0, whose coefficient jumps where the contact opens (by about c h across a
    grazing step). A predicted Newton iterate's stability is judged at the iterate before
    it, which only a continuous monodromy allows (:data:`PREDICT_RESIDUAL`)."""
    damping = oscillator.scene.damping
    return not (damping.law == "contact" and float(damping.exponent) == 0.0)


def shooting_walk(oscillator: Oscillator, state: State, frequencies: np.ndarray):
    """Shooting dwells over a sequence of frequencies (a sweep), as :func:`shooting_dwell`
    at each, in one compiled loop (:func:`hertzsweep.kernels.tangent.shooting_walk`):
    Newton from the previous orbit, and past a fold the transient to the new attractor,
    polished. Where no stable orbit is reached (a period doubling, say) the scene's
    ``measure_periods`` are read where the transient stopped, unsettled, as
    :func:`shooting_dwell` does, and the compiled loop resumes. Yields ``(positions,
    block, settled)`` as a strategy's walk.
    """
    period = PeriodMap(oscillator, oscillator.scene.sweep.period_multiple)
    if period.size != 2 or period.periods != 1:  # the ball model, or orbits of n periods:
        # one dwell at a time (Newton in numpy)
        yield from dwell_by_dwell(shooting_dwell, oscillator, state, frequencies)
        return
    n = oscillator.steps_per_period
    steps = np.array([oscillator.step(w) for w in frequencies])
    predict = PREDICT_RESIDUAL if continuous_monodromy(oscillator) else 0.0
    settings = newton_settings(period, monotone=True, predict=predict)
    settling = transient(period, oscillator.scene.sweep.max_settle_periods)
    buffers = new_readout(oscillator.harmonics.size, steps.size)
    x = np.array([state.q_prev, state.q, state.h])
    start = 0
    buffers.sums[0] = np.nan  # a dwell the compiled walk finished has its sums
    while start < steps.size:
        try:
            stop, periods, unsettled = tangent.shooting_walk(
                x, steps, oscillator.law, oscillator.drive, settings, buffers, start, settling
            )
        except KeyboardInterrupt:  # a signal stopped the walk: keep the dwells it finished
            stop = start + int(np.argmin(np.isfinite(buffers.sums[0, start:])))
            yield from _walked(oscillator, buffers, steps, start, stop)
            raise
        oscillator.steps += periods * n
        yield from _walked(oscillator, buffers, steps, start, stop)
        if stop == steps.size:
            return
        if unsettled:  # no stable orbit: read the scene's measured periods where it stopped
            measured = oscillator.scene.sweep.measure_periods
            state, reading = oscillator.measure(State(*x), frequencies[stop], measured)
            settled = False
        else:  # a kernel status stopped the dwell: run it again here, to report it
            state, reading, settled = shooting_dwell(oscillator, State(*x), frequencies[stop])
        yield slice(stop, stop + 1), Block.of(reading, state), np.array([settled])
        x[:] = state.q_prev, state.q, state.h
        start = stop + 1


def _walked(oscillator: Oscillator, buffers: Readout, steps: np.ndarray, start: int, stop: int):
    """The dwells ``start:stop`` the compiled walk finished, as a strategy's walk step."""
    if stop > start:
        run = slice(start, stop)
        done = Readout(
            buffers.coefficients[:, :, run], buffers.sums[:, run], buffers.counts[:, run],
            buffers.record, 0, buffers.extra[:, run],
        )  # fmt: skip
        samples = CONVERGED_PERIODS * oscillator.denominator * oscillator.steps_per_period
        block = Block.read(done, samples, steps[run], oscillator.periodic_tolerance)
        yield run, block, np.ones(stop - start, dtype=bool)


__all__ = [
    "Evaluation",
    "Orbit",
    "PeriodMap",
    "find_orbit",
    "largest_multiplier",
    "mismatch",
    "newton",
    "orbit_scale",
    "settle",
    "shooting_dwell",
    "shooting_walk",
    "sorted_multipliers",
]
