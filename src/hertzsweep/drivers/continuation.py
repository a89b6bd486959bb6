"""Pseudo-arclength continuation of periodic orbits in the frequency ratio w.

The branch of T-periodic orbits is the curve ``G(z, w) = 0`` with ``G = (P(x) - x) / Q``,
``x = B z`` (:mod:`hertzsweep.shooting`): three unknowns ``y = (z1, z2, w)``, two
equations. From a point ``y_k`` with unit tangent ``t_k`` (the null vector of the 2x3
Jacobian ``G_y``, oriented by ``t_k . t_{k-1} > 0``), a step of length ``ds``

    predictor  y = y_k + ds t_k
    corrector  Newton on  G(y) = 0,  t_k . (y - y_k) = ds  (Keller's pseudo-arclength)

with the exact Jacobian of the discrete map (:mod:`hertzsweep.tangent`). The step grows
after easy corrections and shrinks after hard ones, on a failed corrector and where the
tangent turns by more than ``max_turn`` (every knob is a field of
:class:`ContinuationParameters`); the arclength is measured in the scaled coordinates
``(z, w)``, so that amplitude and frequency weigh alike where the response is resonant.
The augmented Jacobian ``[G_y; t_k]`` stays regular at folds, so the continuation goes
round them and follows the unstable branch between.

Bifurcations of the T-periodic orbit are sign changes between consecutive points of

* fold (saddle-node, a real multiplier through +1): ``dw/ds``, the tangent's w component;
* period doubling (a real multiplier through -1): ``det(M + I)``;
* Neimark-Sacker (a complex pair through the unit circle): ``det(M) - 1`` where the
  multipliers are a complex pair,

each located by Brent's method on the arclength from the previous point (every
evaluation a corrected point on the branch), to ``location_tolerance`` in arclength:
far below 1e-6 in w, since ``|dw/ds| <= 1`` (and w is stationary at a fold).

Loss of contact. ``R' = sqrt(d)`` is continuous through ``d = 0``, so with viscous damping
or contact damping n >= 1 the map stays continuously differentiable and the branch runs
through loss of contact like anywhere else. Where a time step grazes ``d = 0`` it is
only piecewise smooth at the scale of one step, and near a fold the scheme's branch can
zigzag (a few 1e-4 in w for n = 3/2, up to 1e-2 for n = 1 at N = 256): such a cluster
of folds is reported as one (:func:`_fold_clusters`). With n < 1 the damping
``c ~ d^n`` has an unbounded (n = 1/2) or no (n = 0: a jump) derivative at ``d = 0``: the
branch has corners and gaps, handled as described in :func:`continue_branch`, and may
stop short of the far end (``Branch.end``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..core.config import MAX_PERIOD_MULTIPLE, Scene
from ..core.model import check_stability
from ..errors import ConvergenceError, HertzsweepError
from .oscillator import Oscillator, Reading
from .readings import Readings
from .shooting import (
    STABILITY_MARGIN,
    Evaluation,
    PeriodMap,
    find_orbit,
    newton,
    sorted_multipliers,
)

Progress = Callable[[int], None]

POINTS_PER_PROGRESS = 100  # progress units per branch (per cent of the w span)
RETURN_TOLERANCE = 1e-8  # |P^n(x) - x|_inf / Q (in z) below which a period-doubled branch's
# orbit is its parent's period-n orbit again: 100x the corrector's tolerance, far below the
# offset one first step from the period doubling (about 2 first_step |v|_inf ~ 1e-3)
SAME_POINT = 1e-6  # in w and z: a period-doubled branch that reconnected at its parent's
# period doubling reached that point (no second branch is started from it)
KINDS = ("fold", "period-doubling", "neimark-sacker")


@dataclass(frozen=True)
class ContinuationParameters:
    """The knobs of :func:`continue_branch`, each with its default and why that value.

    Steps are arclengths in the scaled coordinates ``(z, w)`` (amplitude over Q, and w),
    where amplitude and frequency weigh alike; "n" is the contact damping exponent
    (``c ~ d^n``) and ``t_w = dw/ds`` the tangent's w component.
    """

    corrector_tolerance: float = 1e-10
    """[1] |P(x) - x|_inf / Q accepted on the branch: 1e4 x the round-off of one period."""
    max_corrector_iterations: int = 7
    """Quadratic convergence takes 2-3 from a good predictor: more than 7, the step is too long."""
    easy_corrector: int = 3
    """At most this many map evaluations: the predictor was good, the next step grows."""
    hard_corrector: int = 5
    """At least this many: the predictor was poor (the branch bends), the next step shrinks."""
    growth: float = 1.5
    """Step factor after an easy correction: regains max_step from restart_step in 11 steps."""
    shrink: float = 0.5
    """Step factor after a rejected or hard step: from max_step to corner_step in 15 tries."""
    max_turn: float = 0.15
    """[rad] Largest turn of the tangent: ~20 points round a fold, one sign change per step."""
    max_step: float = 0.02
    """Largest step: a point every 0.02 in w or less (|dw/ds| <= 1) where the branch is straight."""
    first_step: float = 0.005
    """First step, a quarter of max_step as no turn is measured yet: max_step after 4 easy steps."""
    restart_step: float = 3.125e-4
    """Step after a gap or a reversed tangent (the curvature ahead is unknown): first_step / 16."""
    min_step: float = 1e-9
    """Smallest step, then "stalled": 7 halvings below bridge_step, each one trying a bridge."""
    corner_step: float = 1e-6
    """A turn over max_turn in a step this short is a corner of c ~ d^n (n < 1): curvature > 1e5."""
    bridge_step: float = 1e-7
    """A corrector failing in a step this short meets a gap: with n = 0, c (so the map) jumps."""
    bridge_reach: tuple[float, ...] = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 3e-2)
    """Along the tangent, nearest first: n = 0 gaps span up to 3e-3 in w, 3e-2 at |t_w| ~ 0.1."""
    bridge_distance: float = 5e-2
    """Largest Newton move in z across a gap: 10x a gap's (5e-3), below O(0.1) to other branches."""
    retrace_sagitta: float = 0.05
    """Share of a chord within which a point lies on it: a turn of max_turn sags 0.02 of it."""
    fold_cluster_slope: float = 0.1
    """Vertical |dw/ds| in a grazing cluster: above 0.05 between zigzags, below 0.3 into them."""
    max_points: int = 20000
    """Points before the cut ("max-points"): 400 of arclength at max_step, so only a stuck step."""
    doubling_proximity: float = 0.1
    """Within this distance |mu + 1| of a multiplier to -1 the next step is at most
    ``max_step |mu + 1| / doubling_proximity``, not below doubling_step: a period-doubling
    bubble (two sign changes of det(M + I)) narrower than a step would hide both. Near
    w = 2 the pair's closest approach is 1 - |mu| ~ zeta T (0.014 at zeta = 0.45 %), so the
    steps there are at most 0.003 in w: the bubble at sigma = 20 % (1.993 to 2.006) is
    found whatever the span; one narrower than about 0.003 (within 0.5 % of its lowest
    level, about 36 zeta) can still be missed."""
    doubling_step: float = 1e-3
    """The shortest step :attr:`doubling_proximity` asks for: inside a bubble, where |mu + 1|
    is small, a point every 0.001 in w or less."""
    location_tolerance: float = 1e-12
    """Brent's arclength tolerance at bifurcations and edges: far below 1e-6 in w (|dw/ds| <= 1)."""


DEFAULT_PARAMETERS = ContinuationParameters()


@dataclass(frozen=True)
class Bifurcation:
    """A located bifurcation of the T-periodic orbit.

    Attributes
    ----------
    kind : ``"fold"``, ``"period-doubling"`` or ``"neimark-sacker"``.
    frequency_ratio : [1] w there.
    amplitude : [1] H1 of N/F_s there (NaN when harmonic 1 is not read).
    point : index of the branch point inserted there.
    multipliers : complex[n] there (2 for the single model, 4 for the ball model).
    """

    kind: str
    frequency_ratio: float
    amplitude: float
    point: int
    multipliers: np.ndarray


@dataclass
class Branch(Readings):
    """One branch of periodic orbits at one sigma, in arclength order.

    Arrays run over the points (P) and harmonics (K): ``frequency_ratio`` (P),
    ``amplitude``/``phase`` (P, K) [1]/[degree], ``mean_force``, ``force_max``,
    ``force_min``, ``contact_loss_fraction``, ``flight_tau`` (P), ``multipliers``
    complex (P, n), ``stable`` bool (P), ``arclength`` (P) in the scaled coordinates.
    ``complete`` is true when the branch reached the far end of the w span; ``end`` says
    how it ended: ``"end"`` (the far end), ``"start"`` (it turned back and left the span
    where it began), ``"stalled"`` (the step fell below ``min_step``), ``"retraced"``
    (it ran back onto itself past a corner), ``"max-points"``, and for a period-doubled
    branch ``"reconnected"`` (it returned to its parent's branch: :func:`continue_doubled`).
    ``bridges`` counts the gaps crossed at fixed w (see :func:`continue_branch`).

    ``period_multiple`` n: the orbits repeat after n excitation periods (fixed points of
    ``P^n``); ``parent``: the index among its sigma's branches of the branch it was
    switched from at a period doubling (-1 for the primary branch), ``parent_bifurcation``
    the index of that period doubling in the parent's ``bifurcations`` (-1). ``y`` and
    ``tangent`` (P, size + 1): each point's ``(z, w)`` and unit tangent, from which a
    period-doubled branch is started.
    """

    sigma: float
    frequency_ratio: np.ndarray
    multipliers: np.ndarray
    stable: np.ndarray
    arclength: np.ndarray
    bifurcations: list[Bifurcation]
    complete: bool
    end: str
    bridges: int
    steps: int
    period_multiple: int = 1
    parent: int = -1
    parent_bifurcation: int = -1
    y: np.ndarray | None = None
    tangent: np.ndarray | None = None

    @property
    def folds(self) -> list[Bifurcation]:
        return [b for b in self.bifurcations if b.kind == "fold"]

    @property
    def size(self) -> int:
        return int(self.frequency_ratio.size)


@dataclass
class BranchResult:
    """Branches for every sigma of a scene (the input of the branch dataset).

    ``branches``: the primary (period-1) branch of each sigma. ``followed``: per sigma,
    the period-doubled branches continued from its period doublings (``[branch]
    follow_period_doubling``; their ``parent`` indexes the sigma's :meth:`family`, whose
    first member is the primary), empty lists otherwise.
    """

    sigma: np.ndarray
    harmonics: np.ndarray
    branches: list[Branch]
    start_frequency_ratio: float
    end_frequency_ratio: float
    steps: int = 0
    extra: dict = field(default_factory=dict)
    followed: list[list[Branch]] | None = None

    @property
    def follows_period_doubling(self) -> bool:
        """Whether period-doubled branches were followed (the dataset's ``branch``
        dimension)."""
        return self.followed is not None

    def family(self, s: int) -> list[Branch]:
        """The branches of sigma number ``s``: the primary, then the followed ones."""
        return [self.branches[s], *(self.followed[s] if self.followed is not None else [])]


# --------------------------------------------------------------------------- points
@dataclass
class _Point:
    y: np.ndarray  # (z, w): z of the method's state, w last
    tangent: np.ndarray  # unit, oriented along the continuation
    evaluation: Evaluation
    arclength: float


def _tangent(evaluation: Evaluation, previous: np.ndarray) -> np.ndarray:
    """The unit null vector of ``G_y`` with ``t . previous > 0``: the solution of the
    bordered system ``[G_y; previous] t = (0, 0, 1)``, normalised."""
    bordered = np.vstack([evaluation.jacobian, previous])
    last = np.zeros(bordered.shape[0])
    last[-1] = 1.0
    t = np.linalg.solve(bordered, last)
    return t / np.linalg.norm(t)


@dataclass
class ContinuationState:
    """Where one continuation run stands; :func:`iterate` moves it on by one step.

    Attributes
    ----------
    points : list of _Point
        The points so far, in arclength order.
    trace : float[max_points, 6]
        ``(y, tangent)`` of every point so far, for :func:`_retraces`.
    ds : float
        The arclength step to try next.
    located : list of (int, str, _Point)
        Every located bifurcation: the index of the point before it, its kind, the point.
    end : str
        Empty while the run goes on; then how the branch ended (see :class:`Branch`).
    done : int
        Progress units reported so far.
    bridges : int
        Gaps crossed at fixed w.
    flipped : int
        Index of the point whose tangent was reversed after a retrace; -1 before any.
    kinks : list of int
        Indices of the points reached over a corner or a gap.
    marked : dict of int to str
        Points that are themselves a bifurcation (a fold at a kink), by index.
    """

    points: list[_Point]
    trace: np.ndarray
    ds: float
    located: list[tuple[int, str, _Point]] = field(default_factory=list)
    end: str = ""
    done: int = 0
    bridges: int = 0
    flipped: int = -1
    kinks: list[int] = field(default_factory=list)
    marked: dict[int, str] = field(default_factory=dict)


class _Continuation:
    """One continuation run (one sigma): the map, the span, the parameters and progress."""

    def __init__(
        self,
        oscillator: Oscillator,
        w_begin: float,
        w_end: float,
        parameters: ContinuationParameters,
        progress: Progress | None,
        periods: int = 1,
        check: int = 0,
    ) -> None:
        self.oscillator = oscillator
        self.periods = int(periods)
        self.period = PeriodMap(oscillator, periods, check)
        self.doublings: list[np.ndarray] = []  # (z, w) of the parent's period doublings
        self.w_begin = w_begin
        self.w_end = w_end
        self.low, self.high = min(w_begin, w_end), max(w_begin, w_end)
        self.parameters = parameters
        self.progress = progress

    def start(self) -> ContinuationState:
        """The first point: the orbit a run from rest reaches at ``w_begin``, with its
        tangent pointing into the span."""
        period, w_begin = self.period, self.w_begin
        orbit = find_orbit(period, self.oscillator.rest(w_begin), w_begin)
        if not orbit.converged:
            raise ConvergenceError(
                f"sigma = {self.oscillator.sigma:g}: no periodic orbit found at "
                f"w = {w_begin:g} to start the continuation from"
            )
        y = np.append(period.coordinates(orbit.state), w_begin)
        evaluation = period(y[:-1], w_begin)
        direction = 1.0 if self.w_end > w_begin else -1.0
        along_w = np.zeros(y.size)
        along_w[-1] = direction
        tangent = _tangent(evaluation, along_w)
        trace = np.empty((self.parameters.max_points, 2 * y.size))
        trace[0] = np.concatenate((y, tangent))
        first = _Point(y, tangent, evaluation, 0.0)
        state = ContinuationState([first], trace, self.parameters.first_step)
        if w_begin == self.w_end:
            state.end = "end"  # a span of one frequency: one point
        return state

    def correct(
        self, point: _Point, ds: float, normal: np.ndarray | None = None
    ) -> tuple[_Point | None, int]:
        """Predictor ``y + ds t`` and pseudo-arclength corrector. Returns the new point
        (None if the corrector failed) and the number of map evaluations.

        ``normal``: the corrector's hyperplane ``normal . (y - y_k) = ds normal . t``
        instead of ``t . (y - y_k) = ds`` (a branch switch, :func:`continue_doubled`)."""
        t = point.tangent
        y = point.y + ds * t
        along = None if normal is None else ds * float(normal @ t)
        iterations = self.parameters.max_corrector_iterations
        for count in range(1, iterations + 1):
            evaluation = self.period(y[:-1], float(y[-1]))
            if not evaluation.ok:
                return None, count
            if evaluation.error <= self.parameters.corrector_tolerance and count > 1:
                try:
                    tangent = _tangent(evaluation, t)
                except np.linalg.LinAlgError:
                    return None, count
                if tangent @ (y - point.y) < 0.0:
                    tangent = -tangent  # past a corner: keep going the way the step went
                return _Point(y, tangent, evaluation, point.arclength + ds), count
            if normal is None:
                system = np.vstack([evaluation.jacobian, t])
                rhs = np.concatenate([evaluation.residual, [t @ (y - point.y) - ds]])
            else:
                system = np.vstack([evaluation.jacobian, normal])
                rhs = np.concatenate([evaluation.residual, [normal @ (y - point.y) - along]])
            try:
                y = y - np.linalg.solve(system, rhs)
            except np.linalg.LinAlgError:
                return None, count
            if not np.all(np.isfinite(y)) or y[-1] <= 0.0:
                return None, count
        return None, iterations

    def bridge(self, point: _Point) -> _Point | None:
        """Cross a gap of the branch: Newton at fixed w a little ahead along the tangent
        (``bridge_reach``), accepted within ``bridge_distance`` of the prediction."""
        for reach in self.parameters.bridge_reach:
            y = point.y + reach * point.tangent
            w = float(y[-1])
            orbit = newton(self.period, self.period.state(y[:-1], w), w)
            if not orbit.converged:
                continue
            z = self.period.coordinates(orbit.state)
            if np.max(np.abs(z - y[:-1])) > self.parameters.bridge_distance:
                continue
            evaluation = self.period(z, w)
            y_new = np.append(z, w)
            try:
                tangent = _tangent(evaluation, point.tangent)
            except np.linalg.LinAlgError:
                continue
            arclength = point.arclength + float(np.linalg.norm(y_new - point.y))
            return _Point(y_new, tangent, evaluation, arclength)
        return None

    def locate(
        self, point: _Point, new: _Point, ds: float, function: Callable[[_Point], float]
    ) -> _Point:
        """The point between ``point`` (s = 0) and ``new`` (the accepted step ``ds``) where
        ``function`` changes sign: Brent's method on the arclength, every evaluation a
        corrected point. Where the corrector fails inside the step (the map is not smooth
        there), the end of the step with the smaller ``|function|``."""

        def at(s: float) -> _Point:
            if s <= 0.0:
                return point
            out, _ = self.correct(point, s)
            if out is None:
                raise _CorrectorFailed
            return out

        from scipy.optimize import brentq  # here: scipy.optimize takes 0.6 s to import

        try:
            s = brentq(
                lambda s: function(at(s)),
                0.0,
                ds,
                xtol=self.parameters.location_tolerance,
                rtol=4.0 * np.finfo(float).eps,
            )
            return at(s)
        except _CorrectorFailed:
            return min((point, new), key=lambda p: abs(function(p)))

    def report(self, state: ContinuationState, w: float) -> None:
        """Report the progress up to ``w``, in per cent of the span (never backwards)."""
        if self.progress is None:
            return
        fraction = (w - self.w_begin) / (self.w_end - self.w_begin)
        reached = int(np.clip(fraction, 0.0, 1.0) * POINTS_PER_PROGRESS)
        if reached > state.done:
            self.progress(reached - state.done)
            state.done = reached


class _CorrectorFailed(Exception):
    """The corrector failed inside an accepted step (only while locating)."""


def _fold_function(point: _Point) -> float:
    return float(point.tangent[-1])


def _period_doubling_function(point: _Point) -> float:
    monodromy = point.evaluation.monodromy
    return float(np.linalg.det(monodromy + np.eye(monodromy.shape[0])))


def _neimark_sacker_function(point: _Point) -> float:
    """``det M - 1`` (the product of the two multipliers) for the single model; for a
    larger state (the ball model's), whose other multipliers are the ball mode's, damped
    far inside the unit circle, ``|mu|^2 - 1`` of the largest complex pair (or of the
    largest multiplier where none is complex)."""
    monodromy = point.evaluation.monodromy
    if monodromy.shape == (2, 2):
        return float(np.linalg.det(monodromy) - 1.0)
    mu = sorted_multipliers(monodromy)
    pair = mu[np.abs(mu.imag) > 0.0]
    return float(abs(pair[0] if pair.size else mu[0]) ** 2 - 1.0)


TEST_FUNCTIONS = {
    "fold": _fold_function,
    "period-doubling": _period_doubling_function,
    "neimark-sacker": _neimark_sacker_function,
}


def _is_complex_pair(point: _Point) -> bool:
    monodromy = point.evaluation.monodromy
    if monodromy.shape != (2, 2):  # the multiplier nearest the unit circle is complex
        mu = sorted_multipliers(monodromy)
        return bool(abs(mu[np.argmin(np.abs(np.abs(mu) - 1.0))].imag) > 0.0)
    discriminant = np.trace(monodromy) ** 2 - 4.0 * np.linalg.det(monodromy)
    return bool(discriminant < 0.0)


def start_end(scene: Scene) -> tuple[float, float]:
    """``(w_begin, w_end)``: the continuation starts at the end of the sweep span that
    lies farther from the linear resonance (the larger ``|1 - w^2|``) and goes across."""
    w = scene.sweep.frequency_ratios
    low, high = float(w[0]), float(w[-1])
    if abs(1.0 - low * low) >= abs(1.0 - high * high):
        return low, high
    return high, low


def continue_branch(
    oscillator: Oscillator,
    w_begin: float,
    w_end: float,
    progress: Progress | None = None,
    parameters: ContinuationParameters = DEFAULT_PARAMETERS,
) -> Branch:
    """Continue the branch of T-periodic orbits from ``w_begin`` to ``w_end``.

    The first orbit is the one a run from rest reaches at ``w_begin``
    (:func:`hertzsweep.shooting.find_orbit`); :func:`iterate` then steps along the branch
    until it ends. Bifurcations met on the way are located and inserted as points of the
    branch.

    Where the orbit loses contact the discrete map is only piecewise smooth: a time step
    crossing ``d = 0`` puts a corner in the branch (contact damping with n < 1, whose
    c ~ d^n has an unbounded or no derivative there), or a gap (n = 0: c jumps, so does
    the map). A corner is passed by accepting a large turn over a step below
    ``corner_step``, orienting the new tangent along the step; a point that then runs
    back along the traced branch reverses that tangent once. A gap is crossed by Newton at
    fixed w a little ahead (``bridge_reach``), counted in ``Branch.bridges``.

    Parameters
    ----------
    oscillator : Oscillator
        The scene and sigma; its ``steps`` counts the integration steps.
    w_begin, w_end : float
        [1] the frequency ratios at the two ends.
    progress : callable, optional
        Called with increments; :data:`POINTS_PER_PROGRESS` in all (per cent of the span).
    parameters : ContinuationParameters
        Step control, corrector, corners and gaps, and the location of bifurcations.

    Returns
    -------
    Branch
        ``Branch.end`` says whether it reached ``w_end`` or why it stopped short.

    Raises
    ------
    ConvergenceError
        No periodic orbit to start from at ``w_begin``.
    """
    run = _Continuation(oscillator, w_begin, w_end, parameters, progress)
    steps_before = oscillator.steps
    state = run.start()
    while not state.end:
        iterate(run, state)
    if progress is not None and state.done < POINTS_PER_PROGRESS:
        progress(POINTS_PER_PROGRESS - state.done)
    return _assemble(run, state, oscillator.steps - steps_before)


def iterate(run: _Continuation, state: ContinuationState) -> None:
    """One step of the continuation from the last point of ``state``.

    A corrected step of ``state.ds`` (:func:`_advance`) either fails (the step shrinks;
    below ``min_step`` the branch ends, "stalled"), or runs back along the traced branch
    (:func:`_reverse_tangent`), or is accepted: clipped to the span
    (:func:`_clip_to_span`), searched for bifurcations (:func:`_detect`), appended, and
    the next step grown or shrunk by how many map evaluations the corrector needed.

    Parameters
    ----------
    run : _Continuation
        The map, the span, the :class:`ContinuationParameters` and the progress callback.
    state : ContinuationState
        Moved on in place; ``state.end`` is set when the branch ends.
    """
    parameters = run.parameters
    if len(state.points) >= parameters.max_points:
        state.end = "max-points"
        return
    point = state.points[-1]
    new, count, kinked = _advance(run, state, point)
    if new is None:
        state.ds *= parameters.shrink
        if state.ds < parameters.min_step:
            state.end = "stalled"
        return
    if _retraces(state.trace, len(state.points), new, state.ds, parameters.retrace_sagitta):
        _reverse_tangent(state, parameters)
        return
    new = _clip_to_span(run, state, point, new)
    new = _clip_to_parent(run, state, point, new)
    _detect(run, state, point, new, kinked, fold=state.end != "reconnected")
    _mark_kinked_fold(state, new)
    state.trace[len(state.points)] = np.concatenate((new.y, new.tangent))
    state.points.append(new)
    run.report(state, float(new.y[-1]))
    if count <= parameters.easy_corrector:
        state.ds = min(state.ds * parameters.growth, parameters.max_step)
    elif count >= parameters.hard_corrector:
        state.ds *= parameters.shrink
    state.ds = min(state.ds, _doubling_step(new, parameters))


def _doubling_step(point: _Point, parameters: ContinuationParameters) -> float:
    """The largest next step from ``point`` by its multipliers' distance to -1
    (:attr:`ContinuationParameters.doubling_proximity`)."""
    monodromy = point.evaluation.monodromy
    if not np.all(np.isfinite(monodromy)):
        return parameters.max_step
    near = float(np.min(np.abs(np.linalg.eigvals(monodromy) + 1.0)))
    if near >= parameters.doubling_proximity:
        return parameters.max_step
    step = parameters.max_step * near / parameters.doubling_proximity
    return max(step, parameters.doubling_step)


def _advance(
    run: _Continuation, state: ContinuationState, point: _Point
) -> tuple[_Point | None, int, bool]:
    """A step of ``state.ds`` from ``point``: ``(new point or None, evaluations, kinked)``.

    A turn of the tangent beyond ``max_turn`` rejects the step, unless the step is below
    ``corner_step``: then it is a corner, accepted. A step below ``bridge_step`` that still
    fails meets a gap: it is bridged (:meth:`_Continuation.bridge`), counted as a hard
    correction, and the next step is ``restart_step``. Over a corner or a gap (kinked) the
    tangent's orientation is not continuous.
    """
    parameters = run.parameters
    new, count = run.correct(point, state.ds)
    kinked = False
    if new is not None:
        turn = float(np.arccos(np.clip(new.tangent @ point.tangent, -1.0, 1.0)))
        if turn > parameters.max_turn:
            if state.ds > parameters.corner_step:
                new = None
            else:
                kinked = True
    if new is None and state.ds <= parameters.bridge_step:
        new = run.bridge(point)
        if new is not None:
            state.bridges += 1
            state.ds = parameters.restart_step
            return new, parameters.hard_corrector, True
    return new, count, kinked


def _reverse_tangent(state: ContinuationState, parameters: ContinuationParameters) -> None:
    """The step ran back along the branch: past a corner the last tangent was oriented
    backwards. Reverse it and restart at ``restart_step``; a second retrace from the same
    point ends the branch ("retraced")."""
    last = len(state.points) - 1
    if state.flipped == last:
        state.end = "retraced"
        return
    state.flipped = last
    point = state.points[last]
    state.points[last] = _Point(point.y, -point.tangent, point.evaluation, point.arclength)
    state.trace[last, 3:] = -point.tangent
    state.ds = parameters.restart_step


def _clip_to_span(
    run: _Continuation, state: ContinuationState, point: _Point, new: _Point
) -> _Point:
    """``new``, or if the step left the span, the point exactly on its edge: the branch
    ends there ("end" at ``w_end``, "start" where it turned back to ``w_begin``)."""
    w_new = float(new.y[-1])
    if not (w_new < run.low or w_new > run.high):
        return new
    edge = run.high if w_new > run.high else run.low
    found = run.locate(point, new, state.ds, lambda p: float(p.y[-1]) - edge)
    y_edge = found.y.copy()
    y_edge[-1] = edge  # drop the residual of Brent's method (below 1e-12)
    state.ds = found.arclength - point.arclength
    state.end = "end" if edge == run.w_end else "start"
    return _Point(y_edge, found.tangent, found.evaluation, found.arclength)


def _clip_to_parent(
    run: _Continuation, state: ContinuationState, point: _Point, new: _Point
) -> _Point:
    """A period-doubled branch (a map of 2n periods watching its state after n:
    :attr:`PeriodMap.check`) ends where it returns to a period-n orbit: the offset
    ``P^n(x) - x`` reverses there (the pitchfork of ``P^{2n}`` at the parent's period
    doubling: beyond it lies the other half of the branch, the same orbits n periods
    on), or vanishes (the step fell onto the parent's branch). The branch ends
    ("reconnected") at the parent's period doubling the step crossed (the nearest to it
    of ``run.doublings``: the pitchfork of ``P^{2n}`` is singular, where Brent's corrected
    points would fail), else where Brent's method puts the reversal."""
    if run.period.check == 0 or len(state.points) < 2:
        return new
    before, after = point.evaluation.offset, new.evaluation.offset
    if float(np.max(np.abs(after))) <= RETURN_TOLERANCE:
        state.end = "reconnected"
        return new
    if float(before @ after) >= 0.0:
        return new
    state.end = "reconnected"
    reach = 2.0 * float(np.linalg.norm(new.y - point.y)) + SAME_POINT
    for y in run.doublings:  # the parent's period doublings: the step crossed one
        if _distance_to_chord(y, point.y, new.y) <= reach:
            arclength = point.arclength + float(np.linalg.norm(y - point.y))
            evaluation = run.period(y[:-1], float(y[-1]))
            state.ds = arclength - point.arclength
            return _Point(y.copy(), new.tangent, evaluation, arclength)
    found = run.locate(point, new, state.ds, lambda p: float(p.evaluation.offset @ before))
    state.ds = found.arclength - point.arclength
    return found


def _distance_to_chord(y: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """The distance from ``y`` to the segment ``a -> b``."""
    chord = b - a
    along = float(np.clip((y - a) @ chord / max(float(chord @ chord), 1e-300), 0.0, 1.0))
    return float(np.linalg.norm(a + along * chord - y))


def _detect(
    run: _Continuation,
    state: ContinuationState,
    point: _Point,
    new: _Point,
    kinked: bool,
    fold: bool = True,
) -> None:
    """Locate the bifurcations of the step ``point -> new``: sign changes of the test
    functions (:data:`TEST_FUNCTIONS`), into ``state.located``. Over a kink the fold's
    test function (the tangent's w component) says nothing: the new point is listed in
    ``state.kinks`` and judged by w instead (:func:`_mark_kinked_fold`). Without ``fold``
    (the step that reconnects a period-doubled branch to its parent's: w turns at that
    pitchfork, which is no saddle-node) folds are not sought."""
    before = len(state.points) - 1
    for kind, function in TEST_FUNCTIONS.items():
        if kind == "neimark-sacker" and run.oscillator.zeta == 0.0:
            continue  # undamped: det(M) = 1 identically, every orbit is neutral
        if kind == "fold" and not fold:
            continue
        if kind == "fold" and kinked:
            state.kinks.append(before + 1)
            continue
        if function(point) * function(new) < 0.0:
            found = run.locate(point, new, state.ds, function)
            if kind == "neimark-sacker" and not _is_complex_pair(found):
                continue  # real multipliers with product 1: a neutral saddle
            state.located.append((before, kind, found))


def _mark_kinked_fold(state: ContinuationState, new: _Point) -> None:
    """The last point, reached over a kink, is a fold if w turns back there (it went one
    way from the point before and goes the other way to ``new``)."""
    points = state.points
    if state.kinks and state.kinks[-1] == len(points) - 1 and len(points) >= 2:
        before, at = points[-2].y[-1], points[-1].y[-1]
        if (at - before) * (float(new.y[-1]) - at) < 0.0:
            state.marked[len(points) - 1] = "fold"


def _retraces(trace: np.ndarray, count: int, new: _Point, ds: float, sagitta: float) -> bool:
    """Whether ``new`` runs back along the branch already traced.

    ``trace`` holds ``(y, tangent)`` of the ``count`` points so far. A retrace puts the
    new point on the traced polyline (within ``sagitta`` of a chord's length: a step turns
    the tangent by at most ``max_turn``, so a chord of length l stays within 0.02 l of the
    curve) with the opposite tangent. The other arm of a hairpin fold of radius r lies 2 r
    away, some 13 chords of at most 0.15 r: it is not mistaken for the branch itself.
    """
    if count < 4:
        return False
    size = new.y.size  # (z, w): 3 numbers, 5 for the ball model
    start = trace[: count - 3, :size]  # segments j -> j + 1, not the last two
    chord = trace[1 : count - 2, :size] - start
    length = np.linalg.norm(chord, axis=1)
    offset = np.einsum("ij,ij->i", new.y - start, chord)
    along = np.clip(offset / np.maximum(length, 1e-300) ** 2, 0.0, 1.0)
    distance = np.linalg.norm(start + along[:, None] * chord - new.y, axis=1)
    on_it = distance <= sagitta * length + 0.5 * ds
    opposite = trace[: count - 3, size:] @ new.tangent < -0.9
    return bool(np.any(on_it & opposite))


def _ordered(state: ContinuationState) -> list[tuple[_Point, str | None]]:
    """The points with the located bifurcations inserted after the point before each, in
    arclength order: ``(point, bifurcation kind or None)``."""
    ordered: list[tuple[_Point, str | None]] = []
    by_index: dict[int, list[tuple[str, _Point]]] = {}
    for index, kind, found in state.located:
        by_index.setdefault(index, []).append((kind, found))
    for i, point in enumerate(state.points):
        ordered.append((point, state.marked.get(i)))
        extra = sorted(by_index.get(i, []), key=lambda item: item[1].arclength)
        ordered.extend((found, kind) for kind, found in extra)
    return ordered


def _assemble(run: _Continuation, state: ContinuationState, steps: int) -> Branch:
    """Insert the located bifurcations among the points, read every point, and report
    each cluster of grazing folds once (:func:`_fold_clusters`)."""
    ordered = _ordered(state)
    oscillator = run.oscillator
    periods = run.period.reading_periods
    harmonics = list(oscillator.harmonics)
    h1 = harmonics.index(1) if 1 in harmonics else None
    readings: list[Reading] = []
    multipliers = np.empty((len(ordered), run.period.size), dtype=complex)
    for i, (point, _) in enumerate(ordered):
        w = float(point.y[-1])
        state_at = run.period.state(point.y[:-1], w)
        _, reading = oscillator.measure(state_at, w, periods)  # whole periods
        readings.append(reading)
        multipliers[i] = sorted_multipliers(point.evaluation.monodromy)
    candidates = [i for i, (_, kind) in enumerate(ordered) if kind is not None]
    kept = _fold_clusters(ordered, readings, candidates, run.parameters.fold_cluster_slope)
    bifurcations = []
    for i in kept:
        point, kind = ordered[i]
        amplitude = float(readings[i].amplitude[h1]) if h1 is not None else float("nan")
        bifurcations.append(Bifurcation(kind, float(point.y[-1]), amplitude, i, multipliers[i]))

    def stack(name: str) -> np.ndarray:
        return np.array([getattr(r, name) for r in readings])

    steps_measured = len(ordered) * oscillator.steps_per_period * periods
    return Branch(
        sigma=oscillator.sigma,
        frequency_ratio=np.array([p.y[-1] for p, _ in ordered]),
        amplitude=stack("amplitude"),
        phase=stack("phase"),
        mean_force=stack("mean_force"),
        force_max=stack("force_max"),
        force_min=stack("force_min"),
        contact_loss_fraction=stack("contact_loss_fraction"),
        flight_tau=stack("flight_tau"),
        multipliers=multipliers,
        stable=np.max(np.abs(multipliers), axis=1) < 1.0 - STABILITY_MARGIN,
        arclength=np.array([p.arclength for p, _ in ordered]),
        bifurcations=bifurcations,
        complete=state.end == "end",
        end=state.end,
        bridges=state.bridges,
        steps=steps + steps_measured,
        period_multiple=run.periods,
        y=np.array([p.y for p, _ in ordered]),
        tangent=np.array([p.tangent for p, _ in ordered]),
    )


def _fold_clusters(
    ordered: list[tuple[_Point, str | None]],
    readings: list[Reading],
    candidates: list[int],
    vertical: float,
) -> list[int]:
    """The located bifurcations to report, as indices into ``ordered``.

    Where the orbit loses contact, time steps grazing ``d = 0`` make the discrete map only
    piecewise smooth, and where the branch is near a fold (nearly vertical in the (z, w)
    plane) the scheme's branch zigzags: many turning points of w close together (a few
    1e-4 in w for n = 3/2, up to 1e-2 for n = 1 where the branch stays vertical a long
    way). Consecutive folds with loss of contact between which ``|dw/ds|`` never reaches
    ``vertical`` (``fold_cluster_slope``) form one cluster. If w runs the other way after
    the cluster than before it, the cluster is one fold of the oscillator, reported at its
    extreme w (where the branch finally turns back: its minimum or maximum as it was
    travelling, which is where a sweep jumps); otherwise it is a zigzag and is dropped.
    Isolated folds and folds in contact are reported as located.
    """
    slope = np.array([abs(point.tangent[2]) for point, _ in ordered])
    w = np.array([point.y[-1] for point, _ in ordered])
    steep = np.flatnonzero(slope >= vertical)
    kept: list[int] = []
    cluster: list[int] = []

    def close_cluster() -> None:
        if not cluster:
            return
        if len(cluster) == 1:
            kept.append(cluster[0])
        else:
            # the way w went into the cluster and out of it, from where the branch was
            # last and is next steep (positions: immune to the tangent's orientation)
            first, last = cluster[0], cluster[-1]
            entry = steep[steep < first]
            exit_ = steep[steep > last]
            into = w[first] - w[entry[-1] if entry.size else 0]
            out = w[exit_[0] if exit_.size else w.size - 1] - w[last]
            if into * out < 0.0:  # turned back: one fold, at the extreme w
                extreme = min if into < 0.0 else max
                kept.append(extreme(cluster, key=lambda i: w[i]))
        cluster.clear()

    for i in candidates:
        kind = ordered[i][1]
        grazing = kind == "fold" and readings[i].contact_loss_fraction > 0.0
        if not grazing:
            close_cluster()
            kept.append(i)
            continue
        if cluster and np.max(slope[cluster[-1] + 1 : i], initial=0.0) >= vertical:
            close_cluster()
        cluster.append(i)
    close_cluster()
    return sorted(kept)


def doubling_direction(period: PeriodMap, monodromy: np.ndarray) -> np.ndarray:
    """The unit eigenvector ``v`` (in the scaled coordinates z) of the multiplier nearest
    -1 of an n-period monodromy, oriented so that its first component (q at excitation
    phase 0 over Q) is positive (its largest component where that one vanishes)."""
    mu, vectors = np.linalg.eig(monodromy)
    k = int(np.argmin(np.abs(mu + 1.0)))
    v = period.inverse @ np.real(vectors[:, k])
    v /= np.linalg.norm(v)
    lead = v[0] if abs(v[0]) > 1e-9 else v[int(np.argmax(np.abs(v)))]
    return v if lead > 0.0 else -v


def continue_doubled(
    oscillator: Oscillator,
    parent: Branch,
    index: int,
    w_begin: float,
    w_end: float,
    parameters: ContinuationParameters = DEFAULT_PARAMETERS,
) -> Branch:
    """Continue the period-2n branch born at the period doubling ``parent.bifurcations
    [index]`` of a period-n branch.

    At the period doubling ``(z_PD, w_PD)`` the n-period monodromy has a multiplier -1,
    eigenvector ``v``; for the 2n-period map ``P^{2n}`` that point is a pitchfork: the
    period-n branch (tangent ``t_n``) crosses the period-2n branch, whose tangent there is
    ``(v, 0)`` (w is stationary, the orbits' difference from the period-n one grows as
    ``sqrt(|w - w_PD|)``). Branch switching: the first point is the period doubling
    itself (its multipliers for ``P^{2n}`` are the squares of the parent's), with tangent
    ``(v, 0)``; the first step predicts ``y_PD + ds (v, 0)`` and corrects in the
    hyperplane normal to ``(v, 0)`` made orthogonal to ``t_n`` (through the predictor),
    which meets the period-n branch only O(sqrt(ds)) away, so that Newton does not fall
    back onto it (a step that does, its orbit repeating after n periods, is halved).
    Thereafter the continuation goes on as :func:`continue_branch`'s, with the Floquet
    multipliers, folds and period doublings of the 2n-period orbits.

    Which half. The two halves of the pitchfork, ``x_PD + s v`` and ``x_PD - s v``, are the
    same orbits n periods apart; the half followed is the one along ``+v``, ``v`` oriented
    with a positive displacement component (:func:`doubling_direction`): the orbit whose
    q at excitation phase 0 starts above the period-n orbit's.

    It ends at the span's ends (``"end"``/``"start"``: ``w_end``, ``w_begin``), or where it
    returns to a period-n orbit (``"reconnected"``, :func:`_clip_to_parent`: at the other
    period doubling of a bubble, say), or as :func:`continue_branch`'s does.
    """
    found = parent.bifurcations[index]
    n = parent.period_multiple
    run = _Continuation(oscillator, w_begin, w_end, parameters, None, 2 * n, n)
    run.doublings = [parent.y[f.point] for f in parent.bifurcations if f.kind == KINDS[1]]
    steps_before = oscillator.steps
    y_pd = parent.y[found.point].copy()
    w_pd = float(y_pd[-1])
    parent_map = PeriodMap(oscillator, n)
    v = doubling_direction(run.period, parent_map(y_pd[:-1], w_pd).monodromy)
    t0 = np.append(v, 0.0)
    first = _Point(y_pd, t0, run.period(y_pd[:-1], w_pd), 0.0)
    t_parent = parent.tangent[found.point]
    normal = t0 - float(t0 @ t_parent) * t_parent
    normal /= np.linalg.norm(normal)
    trace = np.empty((parameters.max_points, 2 * y_pd.size))
    trace[0] = np.concatenate((y_pd, t0))
    state = ContinuationState([first], trace, parameters.first_step)
    while True:
        new, _ = run.correct(first, state.ds, normal)
        if new is not None:
            away = float(np.max(np.abs(new.evaluation.offset)))
            if away > 0.5 * state.ds * float(np.max(np.abs(v))):
                break  # a 2n-periodic orbit, not the parent's
        state.ds *= parameters.shrink
        if state.ds < parameters.min_step:
            state.end = "stalled"
            break
    if not state.end:
        new = _clip_to_span(run, state, first, new)
        _detect(run, state, first, new, False)
        state.trace[1] = np.concatenate((new.y, new.tangent))
        state.points.append(new)
    while not state.end:
        iterate(run, state)
    return _assemble(run, state, oscillator.steps - steps_before)


def follow_doublings(
    oscillator: Oscillator,
    primary: Branch,
    w_begin: float,
    w_end: float,
    parameters: ContinuationParameters = DEFAULT_PARAMETERS,
    progress: Progress | None = None,
) -> list[Branch]:
    """The period-doubled branches of a primary branch, recursively: from every period
    doubling of a period-n branch with ``2 n <= 8`` (:data:`MAX_PERIOD_MULTIPLE`) the
    period-2n branch (:func:`continue_doubled`), each with ``parent`` (the index in
    ``[primary, *returned]``) and ``parent_bifurcation`` set. A period doubling that a
    branch already reconnected at (the other end of a bubble) starts none. ``progress``
    receives :data:`POINTS_PER_PROGRESS` units in all, as the branches finish."""
    family = [primary]
    reached: list[tuple[int, np.ndarray]] = []  # (parent, y) where a branch reconnected
    budget = POINTS_PER_PROGRESS
    i = 0
    while i < len(family):
        parent = family[i]
        doublings = []
        if 2 * parent.period_multiple <= MAX_PERIOD_MULTIPLE:
            doublings = [j for j, f in enumerate(parent.bifurcations) if f.kind == KINDS[1]]
        for count, j in enumerate(doublings):
            at = parent.y[parent.bifurcations[j].point]
            if any(p == i and np.max(np.abs(y - at)) <= SAME_POINT for p, y in reached):
                continue
            child = continue_doubled(oscillator, parent, j, w_begin, w_end, parameters)
            child.parent, child.parent_bifurcation = i, j
            family.append(child)
            if child.end == "reconnected":
                reached.append((i, child.y[-1]))
            if progress is not None:
                share = budget // (len(doublings) - count + len(family) - i)
                progress(share)
                budget -= share
        i += 1
    if progress is not None and budget > 0:
        progress(budget)
    return family[1:]


def run_branch(
    scene: Scene,
    progress: Progress | None = None,
    parameters: ContinuationParameters = DEFAULT_PARAMETERS,
) -> BranchResult:
    """Branches of T-periodic orbits for every sigma of a scene, across the sweep's span.

    Parameters
    ----------
    scene : Scene
        Damping, solver, lock-in and the span ``[sweep] start .. stop``.
    progress : callable, optional
        Called with increments, ``POINTS_PER_PROGRESS`` per sigma.
    parameters : ContinuationParameters
        The tuning of every continuation (:func:`continue_branch`).

    Raises
    ------
    StabilityError
        The time step is beyond the stability limit.
    ConvergenceError
        A continuation could not start (no periodic orbit at the first frequency). A
        branch that stops short is returned as it is (``Branch.end``).
    """
    check_stability(scene)
    w_begin, w_end = start_end(scene)
    follow = scene.branch.follow_period_doubling
    branches = []
    followed: list[list[Branch]] | None = [] if follow else None
    steps = 0
    for sigma in scene.excitation.sigma:
        oscillator = Oscillator(scene, sigma)
        try:
            branch = continue_branch(oscillator, w_begin, w_end, progress, parameters)
            if followed is not None:
                children = follow_doublings(
                    oscillator, branch, w_begin, w_end, parameters, progress
                )
                followed.append(children)
                steps += sum(child.steps for child in children)
        except HertzsweepError as exc:
            raise exc.with_context(f"{scene.source}: branch") from None
        branches.append(branch)
        steps += branch.steps
    return BranchResult(
        sigma=np.asarray(scene.excitation.sigma, dtype=float),
        harmonics=np.asarray(scene.lockin.harmonics, dtype=np.float64),
        branches=branches,
        start_frequency_ratio=w_begin,
        end_frequency_ratio=w_end,
        steps=steps,
        followed=followed,
    )


def progress_total(scene: Scene) -> int:
    """Progress units :func:`run_branch` reports for a scene: per sigma, the primary
    branch's and, following period doublings, as many for the doubled branches."""
    per_sigma = POINTS_PER_PROGRESS * (2 if scene.branch.follow_period_doubling else 1)
    return per_sigma * len(scene.excitation.sigma)


__all__ = [
    "Bifurcation",
    "Branch",
    "BranchResult",
    "ContinuationParameters",
    "ContinuationState",
    "KINDS",
    "continue_branch",
    "continue_doubled",
    "follow_doublings",
    "progress_total",
    "run_branch",
    "start_end",
]
