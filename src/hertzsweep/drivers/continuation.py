"""Pseudo-arclength continuation of periodic orbits in the frequency ratio w.

The branch of T-periodic orbits is the curve ``G(z, w) = 0`` with ``G = (P(x) - x) / Q``,
``x = B z`` (:mod:`hertzsweep.shooting`): three unknowns ``y = (z1, z2, w)``, two
equations. From a point ``y_k`` with unit tangent ``t_k`` (the null vector of the 2x3
Jacobian ``G_y``, oriented by ``t_k . t_{k-1} > 0``), a step of length ``ds``

    predictor  y = y_k + ds t_k
    corrector  Newton on  G(y) = 0,  t_k . (y - y_k) = ds  (Keller's pseudo-arclength)

with the exact Jacobian of the discrete map (:mod:`hertzsweep.tangent`). The step grows
after easy corrections and shrinks after hard ones, on a failed corrector and where the
tangent turns by more than :data:`MAX_TURN`; the arclength is measured in the scaled
coordinates ``(z, w)``, so that amplitude and frequency weigh alike where the response
is resonant. The augmented Jacobian ``[G_y; t_k]`` stays regular at folds, so the
continuation goes round them and follows the unstable branch between.

Bifurcations of the T-periodic orbit are sign changes between consecutive points of

* fold (saddle-node, a real multiplier through +1): ``dw/ds``, the tangent's w component;
* period doubling (a real multiplier through -1): ``det(M + I)``;
* Neimark-Sacker (a complex pair through the unit circle): ``det(M) - 1`` where the
  multipliers are a complex pair,

each located by Brent's method on the arclength from the previous point (every
evaluation a corrected point on the branch), to :data:`LOCATION_TOLERANCE` in arclength:
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
from scipy.optimize import brentq

from ..core.config import Scene
from ..core.model import check_stability
from ..errors import ConvergenceError, HertzsweepError
from .oscillator import Oscillator, Reading
from .shooting import (
    STABILITY_MARGIN,
    Evaluation,
    PeriodMap,
    find_orbit,
    newton,
    sorted_multipliers,
)

Progress = Callable[[int], None]

CORRECTOR_TOLERANCE = 1e-10  # |G|_inf = |P(x) - x|_inf / Q at a point of the branch
MAX_CORRECTOR_ITERATIONS = 7  # quadratic convergence needs 2-3 from a good predictor
EASY_CORRECTOR = 3  # at most this many evaluations: the next step grows
HARD_CORRECTOR = 5  # at least this many: the next step shrinks
GROWTH = 1.5  # step factor after an easy correction
SHRINK = 0.5  # step factor after a rejected step
MAX_TURN = 0.15  # [rad] largest angle between consecutive tangents: keeps ~20 points on a
# half turn (a fold), resolves the curve for plotting, and keeps two sign changes of a
# test function from falling into one step
MAX_STEP = 0.02  # largest step in the scaled coordinates (w, and amplitude over Q)
FIRST_STEP = 0.005  # first arclength step (scaled coordinates), a quarter of MAX_STEP
RESTART_STEP = FIRST_STEP * SHRINK**4  # the step after a bridged gap or a reversed tangent
MIN_STEP = 1e-9  # below this the continuation stops there (end = "stalled")
CORNER_STEP = 1e-6  # below this step a turn beyond MAX_TURN is accepted: a corner of the
# branch where a time step crosses the contact boundary and the map is not differentiable
# (contact damping with n < 1: c ~ d^n), not curvature (which would exceed 1e5)
BRIDGE_STEP = 1e-7  # below this step a failing corrector means a gap of the branch: the map
# is discontinuous where a step crosses d = 0 with contact damping n = 0 (c jumps by 2 zeta)
BRIDGE_REACH = (1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 3e-2)  # along the tangent, tried in turn; the
# gaps measured at sigma = 7 %, n = 0 span up to 3e-3 in w (reach 3e-2 with |t_w| ~ 0.1)
BRIDGE_DISTANCE = 5e-2  # largest Newton move from the prediction accepted across a gap (in
# z; measured 5e-3; distinct branches lie O(0.1 - 1) apart away from folds)
RETRACE_SAGITTA = 0.05  # a point within this share of a chord from it lies on it (_retraces)
FOLD_CLUSTER_SLOPE = 0.1  # |dw/ds| below which the branch counts as vertical between two
# grazing folds (see _fold_clusters); measured at most 0.045 between the zigzags of n = 1,
# sigma = 7 - 8 %, and 0.30 - 0.36 on the way into them
MAX_POINTS = 20000  # a branch that has not reached the other end by then is cut there
LOCATION_TOLERANCE = 1e-12  # arclength tolerance of Brent's method for bifurcations and ends
POINTS_PER_PROGRESS = 100  # progress units per branch (per cent of the w span)
KINDS = ("fold", "period-doubling", "neimark-sacker")


@dataclass(frozen=True)
class Bifurcation:
    """A located bifurcation of the T-periodic orbit.

    Attributes
    ----------
    kind : ``"fold"``, ``"period-doubling"`` or ``"neimark-sacker"``.
    frequency_ratio : [1] w there.
    amplitude : [1] H1 of N/F_s there (NaN when harmonic 1 is not read).
    point : index of the branch point inserted there.
    multipliers : complex[2] there.
    """

    kind: str
    frequency_ratio: float
    amplitude: float
    point: int
    multipliers: np.ndarray


@dataclass
class Branch:
    """One branch of periodic orbits at one sigma, in arclength order.

    Arrays run over the points (P) and harmonics (K): ``frequency_ratio`` (P),
    ``amplitude``/``phase`` (P, K) [1]/[degree], ``mean_force``, ``force_max``,
    ``force_min``, ``contact_loss_fraction``, ``flight_tau`` (P), ``multipliers``
    complex (P, 2), ``stable`` bool (P), ``arclength`` (P) in the scaled coordinates.
    ``complete`` is true when the branch reached the far end of the w span; ``end`` says
    how it ended: ``"end"`` (the far end), ``"start"`` (it turned back and left the span
    where it began), ``"stalled"`` (the step fell below :data:`MIN_STEP`), ``"retraced"``
    (it ran back onto itself past a corner), ``"max-points"``. ``bridges`` counts the gaps
    crossed at fixed w (see :func:`continue_branch`).
    """

    sigma: float
    frequency_ratio: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    mean_force: np.ndarray
    force_max: np.ndarray
    force_min: np.ndarray
    contact_loss_fraction: np.ndarray
    flight_tau: np.ndarray
    multipliers: np.ndarray
    stable: np.ndarray
    arclength: np.ndarray
    bifurcations: list[Bifurcation]
    complete: bool
    end: str
    bridges: int
    steps: int

    @property
    def folds(self) -> list[Bifurcation]:
        return [b for b in self.bifurcations if b.kind == "fold"]

    @property
    def size(self) -> int:
        return int(self.frequency_ratio.size)


@dataclass
class BranchResult:
    """Branches for every sigma of a scene (the input of the branch dataset)."""

    sigma: np.ndarray
    harmonics: np.ndarray
    branches: list[Branch]
    start_frequency_ratio: float
    end_frequency_ratio: float
    steps: int = 0
    extra: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- points
@dataclass
class _Point:
    y: np.ndarray  # (z1, z2, w)
    tangent: np.ndarray  # unit, oriented along the continuation
    evaluation: Evaluation
    arclength: float


def _tangent(evaluation: Evaluation, previous: np.ndarray) -> np.ndarray:
    """The unit null vector of ``G_y`` with ``t . previous > 0``: the solution of the
    bordered system ``[G_y; previous] t = (0, 0, 1)``, normalised."""
    bordered = np.vstack([evaluation.jacobian, previous])
    t = np.linalg.solve(bordered, np.array([0.0, 0.0, 1.0]))
    return t / np.linalg.norm(t)


class _Continuation:
    """The state of one continuation run (one sigma)."""

    def __init__(self, oscillator: Oscillator) -> None:
        self.oscillator = oscillator
        self.period = PeriodMap(oscillator)

    def correct(self, point: _Point, ds: float) -> tuple[_Point | None, int]:
        """Predictor ``y + ds t`` and pseudo-arclength corrector. Returns the new point
        (None if the corrector failed) and the number of map evaluations."""
        t = point.tangent
        y = point.y + ds * t
        for count in range(1, MAX_CORRECTOR_ITERATIONS + 1):
            evaluation = self.period(y[:2], float(y[2]))
            if not evaluation.ok:
                return None, count
            if evaluation.error <= CORRECTOR_TOLERANCE and count > 1:
                try:
                    tangent = _tangent(evaluation, t)
                except np.linalg.LinAlgError:
                    return None, count
                if tangent @ (y - point.y) < 0.0:
                    tangent = -tangent  # past a corner: keep going the way the step went
                return _Point(y, tangent, evaluation, point.arclength + ds), count
            system = np.vstack([evaluation.jacobian, t])
            rhs = np.concatenate([evaluation.residual, [t @ (y - point.y) - ds]])
            try:
                y = y - np.linalg.solve(system, rhs)
            except np.linalg.LinAlgError:
                return None, count
            if not np.all(np.isfinite(y)) or y[2] <= 0.0:
                return None, count
        return None, MAX_CORRECTOR_ITERATIONS

    def bridge(self, point: _Point) -> _Point | None:
        """Cross a gap of the branch: Newton at fixed w a little ahead along the tangent
        (:data:`BRIDGE_REACH`), accepted within :data:`BRIDGE_DISTANCE` of the prediction."""
        for reach in BRIDGE_REACH:
            y = point.y + reach * point.tangent
            w = float(y[2])
            orbit = newton(self.period, self.period.state(y[:2], w), w)
            if not orbit.converged:
                continue
            z = self.period.coordinates(orbit.state)
            if np.max(np.abs(z - y[:2])) > BRIDGE_DISTANCE:
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

        try:
            s = brentq(
                lambda s: function(at(s)),
                0.0,
                ds,
                xtol=LOCATION_TOLERANCE,
                rtol=4.0 * np.finfo(float).eps,
            )
            return at(s)
        except _CorrectorFailed:
            return min((point, new), key=lambda p: abs(function(p)))


class _CorrectorFailed(Exception):
    """The corrector failed inside an accepted step (only while locating)."""


def _fold_function(point: _Point) -> float:
    return float(point.tangent[2])


def _period_doubling_function(point: _Point) -> float:
    return float(np.linalg.det(point.evaluation.monodromy + np.eye(2)))


def _neimark_sacker_function(point: _Point) -> float:
    return float(np.linalg.det(point.evaluation.monodromy) - 1.0)


TEST_FUNCTIONS = {
    "fold": _fold_function,
    "period-doubling": _period_doubling_function,
    "neimark-sacker": _neimark_sacker_function,
}


def _is_complex_pair(point: _Point) -> bool:
    monodromy = point.evaluation.monodromy
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
    max_step: float = MAX_STEP,
) -> Branch:
    """Continue the branch of T-periodic orbits from ``w_begin`` to ``w_end``.

    The first orbit is the one a run from rest reaches at ``w_begin``
    (:func:`hertzsweep.shooting.find_orbit`). Bifurcations met on the way are located
    and inserted as points of the branch.

    Where the orbit loses contact the discrete map is only piecewise smooth: a time step
    crossing ``d = 0`` puts a corner in the branch (contact damping with n < 1, whose
    c ~ d^n has an unbounded or no derivative there), or a gap (n = 0: c jumps, so does
    the map). A corner is passed by accepting a large turn over a step below
    :data:`CORNER_STEP`, orienting the new tangent along the step; a point that then runs
    back along the traced branch reverses that tangent once. A gap is crossed by Newton at
    fixed w a little ahead (:data:`BRIDGE_REACH`), counted in ``Branch.bridges``.

    Parameters
    ----------
    oscillator : Oscillator
        The scene and sigma; its ``steps`` counts the integration steps.
    w_begin, w_end : float
        [1] the frequency ratios at the two ends.
    progress : callable, optional
        Called with increments; :data:`POINTS_PER_PROGRESS` in all (per cent of the span).
    max_step : float
        Largest arclength step in the scaled coordinates.

    Returns
    -------
    Branch
        ``Branch.end`` says whether it reached ``w_end`` or why it stopped short.

    Raises
    ------
    ConvergenceError
        No periodic orbit to start from at ``w_begin``.
    """
    run = _Continuation(oscillator)
    period = run.period
    direction = 1.0 if w_end > w_begin else -1.0
    low, high = min(w_begin, w_end), max(w_begin, w_end)
    steps_before = oscillator.steps
    orbit = find_orbit(period, oscillator.rest(w_begin), w_begin)
    if not orbit.converged:
        raise ConvergenceError(
            f"sigma = {oscillator.sigma:g}: no periodic orbit found at w = {w_begin:g} "
            "to start the continuation from"
        )
    y = np.append(period.coordinates(orbit.state), w_begin)
    evaluation = period(y[:2], w_begin)
    tangent = _tangent(evaluation, np.array([0.0, 0.0, direction]))
    points = [_Point(y, tangent, evaluation, 0.0)]
    trace = np.empty((MAX_POINTS, 6))  # (y, tangent) of every point, for _retraces
    trace[0] = np.concatenate((y, tangent))
    located: list[tuple[int, str, _Point]] = []  # (index of the point before, kind, point)
    ds = FIRST_STEP
    end = "end" if w_begin == w_end else ""  # a span of one frequency: one point
    done = 0
    bridges = 0
    flipped = -1  # index of the point whose tangent was reversed after a retrace
    kinks: list[int] = []  # indices of points reached over a corner or a gap
    marked: dict[int, str] = {}  # points that are themselves a bifurcation (a kinked fold)
    while not end:
        if len(points) >= MAX_POINTS:
            end = "max-points"
            break
        point = points[-1]
        new, count = run.correct(point, ds)
        kinked = False  # a corner or a gap: the tangent's orientation is not continuous
        if new is not None:
            turn = float(np.arccos(np.clip(new.tangent @ point.tangent, -1.0, 1.0)))
            if turn > MAX_TURN:
                if ds > CORNER_STEP:
                    new = None
                else:
                    kinked = True
        if new is None and ds <= BRIDGE_STEP:
            new = run.bridge(point)
            if new is not None:
                bridges += 1
                kinked = True
                count = HARD_CORRECTOR
                ds = RESTART_STEP
        if new is None:
            ds *= SHRINK
            if ds < MIN_STEP:
                end = "stalled"
            continue
        if _retraces(trace, len(points), new, ds):
            # past a corner the tangent was oriented backwards: reverse it once
            if flipped == len(points) - 1:
                end = "retraced"
                break
            flipped = len(points) - 1
            points[-1] = _Point(point.y, -point.tangent, point.evaluation, point.arclength)
            trace[len(points) - 1, 3:] = -point.tangent
            ds = RESTART_STEP
            continue
        w_new = float(new.y[2])
        if w_new < low or w_new > high:  # left the span: end exactly on its edge
            edge = high if w_new > high else low
            new = run.locate(point, new, ds, lambda p, edge=edge: float(p.y[2]) - edge)
            y_edge = new.y.copy()
            y_edge[2] = edge  # drop the residual of Brent's method (below 1e-12)
            new = _Point(y_edge, new.tangent, new.evaluation, new.arclength)
            ds = new.arclength - point.arclength
            end = "end" if edge == w_end else "start"
        for kind, function in TEST_FUNCTIONS.items():
            if kind == "neimark-sacker" and oscillator.zeta == 0.0:
                continue  # undamped: det(M) = 1 identically, every orbit is neutral
            if kind == "fold" and kinked:
                kinks.append(len(points))  # judged by w on both sides (below)
                continue
            if function(point) * function(new) < 0.0:
                found = run.locate(point, new, ds, function)
                if kind == "neimark-sacker" and not _is_complex_pair(found):
                    continue  # real multipliers with product 1: a neutral saddle
                located.append((len(points) - 1, kind, found))
        if kinks and kinks[-1] == len(points) - 1 and len(points) >= 2:
            # the point before was reached over a kink: a fold there if w turned back
            before, at = points[-2].y[2], point.y[2]
            if (at - before) * (float(new.y[2]) - at) < 0.0:
                marked[len(points) - 1] = "fold"
        trace[len(points)] = np.concatenate((new.y, new.tangent))
        points.append(new)
        if progress is not None:
            fraction = (float(new.y[2]) - w_begin) / (w_end - w_begin)
            reached = int(np.clip(fraction, 0.0, 1.0) * POINTS_PER_PROGRESS)
            if reached > done:
                progress(reached - done)
                done = reached
        if count <= EASY_CORRECTOR:
            ds = min(ds * GROWTH, max_step)
        elif count >= HARD_CORRECTOR:
            ds *= SHRINK
    if progress is not None and done < POINTS_PER_PROGRESS:
        progress(POINTS_PER_PROGRESS - done)
    return _assemble(run, points, located, marked, end, bridges, oscillator.steps - steps_before)


def _retraces(trace: np.ndarray, count: int, new: _Point, ds: float) -> bool:
    """Whether ``new`` runs back along the branch already traced.

    ``trace`` holds ``(y, tangent)`` of the ``count`` points so far. A retrace puts the
    new point on the traced polyline (within its sagitta: a step turns the tangent by at
    most MAX_TURN, so a chord of length l stays within 0.02 l of the curve) with the
    opposite tangent. The other arm of a hairpin fold of radius r lies 2 r away, some 13
    chords of at most 0.15 r: it is not mistaken for the branch itself.
    """
    if count < 4:
        return False
    start = trace[: count - 3, :3]  # segments j -> j + 1, not the last two
    chord = trace[1 : count - 2, :3] - start
    length = np.linalg.norm(chord, axis=1)
    along = np.clip(np.einsum("ij,ij->i", new.y - start, chord) / np.maximum(length, 1e-300)**2,
                    0.0, 1.0)  # fmt: skip
    distance = np.linalg.norm(start + along[:, None] * chord - new.y, axis=1)
    on_it = distance <= RETRACE_SAGITTA * length + 0.5 * ds
    opposite = trace[: count - 3, 3:] @ new.tangent < -0.9
    return bool(np.any(on_it & opposite))


def _assemble(
    run: _Continuation,
    points: list[_Point],
    located: list[tuple[int, str, _Point]],
    marked: dict[int, str],
    end: str,
    bridges: int,
    steps: int,
) -> Branch:
    """Insert the located bifurcations among the points, read every point, and report
    each cluster of grazing folds once (:func:`_fold_clusters`)."""
    ordered: list[tuple[_Point, str | None]] = []  # (point, bifurcation kind or None)
    by_index: dict[int, list[tuple[str, _Point]]] = {}
    for index, kind, found in located:
        by_index.setdefault(index, []).append((kind, found))
    for i, point in enumerate(points):
        ordered.append((point, marked.get(i)))
        extra = sorted(by_index.get(i, []), key=lambda item: item[1].arclength)
        ordered.extend((found, kind) for kind, found in extra)
    oscillator = run.oscillator
    harmonics = list(oscillator.harmonics)
    h1 = harmonics.index(1) if 1 in harmonics else None
    readings: list[Reading] = []
    multipliers = np.empty((len(ordered), 2), dtype=complex)
    for i, (point, _) in enumerate(ordered):
        w = float(point.y[2])
        _, reading = oscillator.measure(run.period.state(point.y[:2], w), w, 1)
        readings.append(reading)
        multipliers[i] = sorted_multipliers(point.evaluation.monodromy)
    candidates = [i for i, (_, kind) in enumerate(ordered) if kind is not None]
    kept = _fold_clusters(ordered, readings, candidates)
    bifurcations = []
    for i in kept:
        point, kind = ordered[i]
        amplitude = float(readings[i].amplitude[h1]) if h1 is not None else float("nan")
        bifurcations.append(Bifurcation(kind, float(point.y[2]), amplitude, i, multipliers[i]))

    def stack(name: str) -> np.ndarray:
        return np.array([getattr(r, name) for r in readings])

    steps_measured = len(ordered) * oscillator.steps_per_period
    return Branch(
        sigma=oscillator.sigma,
        frequency_ratio=np.array([p.y[2] for p, _ in ordered]),
        amplitude=stack("amplitude"),
        phase=stack("phase"),
        mean_force=stack("mean_force"),
        force_max=stack("force_max"),
        force_min=stack("force_min"),
        contact_loss_fraction=stack("contact_loss_fraction"),
        flight_tau=stack("flight_tau"),
        multipliers=multipliers,
        stable=np.max(np.abs(multipliers), axis=1) < 1.0 - STABILITY_MARGIN,  # as Orbit.stable
        arclength=np.array([p.arclength for p, _ in ordered]),
        bifurcations=bifurcations,
        complete=end == "end",
        end=end,
        bridges=bridges,
        steps=steps + steps_measured,
    )


def _fold_clusters(
    ordered: list[tuple[_Point, str | None]], readings: list[Reading], candidates: list[int]
) -> list[int]:
    """The located bifurcations to report, as indices into ``ordered``.

    Where the orbit loses contact, time steps grazing ``d = 0`` make the discrete map only
    piecewise smooth, and where the branch is near a fold (nearly vertical in the (z, w)
    plane) the scheme's branch zigzags: many turning points of w close together (a few
    1e-4 in w for n = 3/2, up to 1e-2 for n = 1 at sigma = 7 %, where the branch stays
    vertical a long way). Consecutive folds with loss of contact between which the branch
    never leans more than :data:`FOLD_CLUSTER_SLOPE` from the vertical form one cluster.
    If w runs the other way after the cluster than before it, the cluster is one fold of
    the oscillator, reported at its extreme w (where the branch finally turns back: its
    minimum or maximum as it was travelling, which is where a sweep jumps); otherwise it
    is a zigzag and is dropped. Isolated folds and folds in contact are reported as
    located.
    """
    slope = np.array([abs(point.tangent[2]) for point, _ in ordered])
    w = np.array([point.y[2] for point, _ in ordered])
    steep = np.flatnonzero(slope >= FOLD_CLUSTER_SLOPE)
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
        if cluster and np.max(slope[cluster[-1] + 1 : i], initial=0.0) >= FOLD_CLUSTER_SLOPE:
            close_cluster()
        cluster.append(i)
    close_cluster()
    return sorted(kept)


def run_branch(scene: Scene, progress: Progress | None = None) -> BranchResult:
    """Branches of T-periodic orbits for every sigma of a scene, across the sweep's span.

    Parameters
    ----------
    scene : Scene
        Damping, solver, lock-in and the span ``[sweep] start .. stop``.
    progress : callable, optional
        Called with increments, ``POINTS_PER_PROGRESS`` per sigma.

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
    branches = []
    steps = 0
    for sigma in scene.excitation.sigma:
        oscillator = Oscillator(scene, sigma)
        try:
            branch = continue_branch(oscillator, w_begin, w_end, progress)
        except HertzsweepError as exc:
            raise type(exc)(f"{scene.source}: branch: {exc}") from None
        branches.append(branch)
        steps += branch.steps
    return BranchResult(
        sigma=np.asarray(scene.excitation.sigma, dtype=float),
        harmonics=np.asarray(scene.lockin.harmonics, dtype=np.int64),
        branches=branches,
        start_frequency_ratio=w_begin,
        end_frequency_ratio=w_end,
        steps=steps,
    )


def progress_total(scene: Scene) -> int:
    """Progress units :func:`run_branch` reports for a scene."""
    return POINTS_PER_PROGRESS * len(scene.excitation.sigma)


__all__ = [
    "Bifurcation",
    "Branch",
    "BranchResult",
    "KINDS",
    "continue_branch",
    "progress_total",
    "run_branch",
    "start_end",
]
