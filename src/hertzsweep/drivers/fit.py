"""Identification: the model's parameters from measurements, by least squares.

The paper identifies its model from the rig: the linearised natural frequency and the
damping ratio from a sweep at sigma = 0.03 % (section 4.1, Figure 3), the damping law in
intermittent contact from the downward jump frequency against the input level (section
4.2-4.3, Figure 11 against Figure 15). :func:`fit` does the same for any of
:data:`FREE_KEYS`: ``rig.natural_frequency`` (f0 [Hz]), ``damping.ratio`` (zeta) and
``damping.exponent`` (n of eq. 11), by :func:`scipy.optimize.least_squares` within
:data:`BOUNDS`.

Measurements, as a lock-in gives them: :class:`SweepMeasurements` (peak amplitude and
phase lag of harmonic k of N/F_s, SPEC convention, at frequencies in Hz or as frequency
ratios) and :class:`JumpMeasurements` (the frequency where a sweep jumped).

Model evaluations (:data:`METHODS`), the fastest that holds for the data:

``linear``
    The linear response of eq. (8) about the static load,
    ``N_1/F_s = sigma (1 + 2 i zeta w) / (1 - w^2 + 2 i zeta w)``, the same for every
    damping law (``d^n = 1`` to first order), so it cannot see n. The Hertz softening
    shifts the resonance by ``a^2 / 54`` of f0 at a response amplitude a (the backbone
    of ``(1 + 2q/3)^(3/2) = 1 + q + q^2/6 - q^3/54``): ``auto`` takes it when the largest
    measured H1 is at most :data:`LINEAR_AMPLITUDE`.
``shooting``
    Each measured sweep in its own order (up: rising frequency, down: falling), through
    the model's periodic orbits: Newton on the period map from the previous orbit, where
    that fails integration to the new attractor (a jump), H1 read over one period of the
    orbit: the sweep of an infinitely long dwell, at the measured frequencies, with the
    scene's ``solver.steps_per_period``.
``fold``
    For jump frequencies: the same sweep of periodic orbits, from w = :data:`WALK_TOP`
    down (or from :data:`WALK_BOTTOM` up) in adaptive steps; where H1 jumps (by more
    than :data:`FOLD_JUMP`) the step is halved, until it is below
    :data:`JUMP_TOLERANCE`: the fold where the swept branch ends
    (:func:`jump_frequency_ratio`), the infinite-dwell jump. It works for every contact
    law (pseudo-arclength continuation stops short with n < 1) and costs less than
    continuing the whole branch. Where the discrete map zigzags near the fold (contact
    loss, n = 1, N = 128) the fold moves in steps of up to 6e-4 in w as the parameters
    change: the Jacobian's steps (:data:`STEPS`) span them.

Residuals are relative: ``model / measured - 1`` for amplitudes and jump frequencies, and
``model - measured`` [radian] for phases (wrapped): for small errors the real and
imaginary parts of the relative error of the complex reading ``A exp(-i phi)``, so a
reading known to 1 % gives residuals of 0.01. Only harmonic 1 is fitted.

Statistics: standard errors and correlations from the Jacobian J at the optimum (central
differences): covariance ``s^2 (J^T J)^-1`` with ``s^2 = |r|^2 / (m - p)``. The usual
linearised estimate: it holds for independent errors of one size in the residuals and a
model nearly linear over a few standard errors; it says nothing about the model's own
error (a wrong damping law, the discretisation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import KW_ONLY, dataclass, field, fields, replace
from typing import TYPE_CHECKING

import numpy as np

from ..core.config import LockinConfig, Scene
from ..core.model import check_stability
from ..core.rig import derive
from ..errors import HertzsweepError

if TYPE_CHECKING:  # the shooting machinery is imported only where a model integrates
    from .oscillator import Oscillator, State
    from .shooting import PeriodMap

Progress = Callable[[int], None]

FREE_KEYS = ("rig.natural_frequency", "damping.ratio", "damping.exponent")
METHODS = ("auto", "linear", "shooting", "fold")
BOUNDS = {  # key -> (lower, upper); the natural frequency's relative to where it starts
    "rig.natural_frequency": (0.5, 2.0),  # a factor 2 either way: far beyond a Hertz estimate
    "damping.ratio": (1e-5, 0.5),  # 0.001 % (no damping left) to 50 % (no resonance left)
    "damping.exponent": (0.0, 3.0),  # the paper's laws are 0..3/2; twice that is generous
}
LAW_EXPONENTS = (0.0, 0.5, 1.0, 1.5)  # the contact laws --compare-laws fits (Figure 15)
LINEAR_AMPLITUDE = 0.05  # [1] largest H1 for which auto takes the linear response: the Hertz
# softening then shifts the resonance by at most 0.05^2/54 = 4.6e-5 of f0 (0.01 Hz at 233 Hz)
STEPS = {  # method -> relative step of the finite-difference Jacobian (of each parameter
    # scaled by its starting value; the exponent by 1)
    "linear": 1e-6,  # exact formula: only round-off (1e-16) limits the step
    "shooting": 1e-5,  # orbits to 1e-10: a derivative error of 1e-5; w moves 1e-5, far
    # below a resonance's width (2 zeta >= 1e-3), so the response is nearly linear over it
    "fold": 1e-2,  # the located fold is smooth only to ~6e-4 in w (zigzags of the discrete
    # map); 1 % of zeta (or 0.01 in n) moves it by 2e-3 to 4e-3
}
TOLERANCES = {  # method -> least squares' xtol and ftol (relative changes of the scaled
    # parameters and of the cost at which the search stops)
    "linear": 1e-10,  # exact model: as far as round-off allows
    "shooting": 1e-8,  # scipy's default; the model is exact to 1e-10
    "fold": 1e-5,  # the folds are smooth only to ~1e-4 of the jump's change per step: a
    # tighter search only wanders; 1e-5 of zeta or n is far below their standard errors
}
MAX_EVALUATIONS = 60  # least-squares iterations' budget (each also costs one Jacobian)
WALK_TOP = 1.05  # [1] a down walk starts here: above every up-fold of the Hertz contact
# (softening: w_u < 1), where one orbit exists and a run from rest reaches it
WALK_BOTTOM = 0.2  # [1] an up walk starts here, a down walk gives up here (no jump)
WALK_STEP = 0.02  # [1] largest step of the walk (off resonance: a few dozen steps in all)
WALK_CHANGE = 0.1  # relative change of H1 above which the walk halves its step
FOLD_JUMP = 0.05  # relative change of H1 that is a jump when it does not shrink with the
# step: at the last steps (1e-6) a smooth branch changes H1 by 1e-6 / zeta, below 1e-3 for
# zeta >= 0.1 %, while falling off a fold changes it by the fold's whole jump (measured,
# zeta = 0.45 %: 28 % up and 43 % down at sigma = 0.6 %, 83 % down at 1 %)
JUMP_TOLERANCE = 1e-6  # [1] the walk stops when its step is below this: the fold lies within
# it beyond the last point, 1e-3 of the smallest change of the fold the Jacobian steps make
TRANSIENT_BLOCK = 10  # periods integrated between two checks of a transient's mismatch
READ_BLOCKS = 5  # blocks between two H1 readings of a transient that may have jumped (a
# reading costs 30x a block's integration at N = 128; a jump is seen 50 periods late)
TRANSIENT_TOLERANCE = 1e-3  # one-period mismatch / Q below which Newton is tried again
SETTLED_TOLERANCE = 1e-7  # one-period mismatch / Q taken as steady without Newton (a
# contact law with n < 1 whose map has corners or gaps where Newton may not converge)


# --------------------------------------------------------------------------- measurements
@dataclass(frozen=True)
class MeasuredPoints:
    """What every kind of measurements holds: where each value was measured (arrays of
    one length M) and where the values come from.

    Attributes
    ----------
    direction : str[M]
        ``"up"`` or ``"down"``: the direction of the sweep that measured the value.
    sigma : float[M]
        [1] input level F/F_s.
    frequency : float[M]
        [Hz], or [1] frequency ratios w when ``in_hertz`` is false.
    in_hertz : bool
        ``frequency`` is in Hz (f0 can be identified) or is the ratio w.
    source : str
        Where the measurements come from (a file), for messages.
    reference : str[M], optional
        Where each value comes from (free text; empty when not given).
    """

    direction: np.ndarray
    sigma: np.ndarray
    frequency: np.ndarray
    _: KW_ONLY
    in_hertz: bool = True
    source: str = "<measurements>"
    reference: np.ndarray | None = None


@dataclass(frozen=True)
class SweepMeasurements(MeasuredPoints):
    """Stepped-sine readings, one value per measured point, at the frequencies the sweep
    visited (``direction``: the order it visited them in).

    Attributes
    ----------
    harmonic : float[M]
        Order k of the reading (whole, or a multiple of 1/2, 1/3, 1/4 in a sweep's).
    amplitude : float[M]
        [1] peak amplitude A_k of N/F_s.
    phase : float[M]
        [degree] phase lag phi_k in [0, 360) (SPEC convention); NaN: not measured.
    direction, sigma, frequency, in_hertz, source, reference : as :class:`MeasuredPoints`.
    """

    harmonic: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray

    kind = "sweep"

    def first_harmonic(self) -> SweepMeasurements:
        """The readings of harmonic 1 only (the ones a fit uses)."""
        keep = self.harmonic == 1
        arrays = (f.name for f in fields(self) if isinstance(getattr(self, f.name), np.ndarray))
        return replace(self, **{name: getattr(self, name)[keep] for name in arrays})


@dataclass(frozen=True)
class JumpMeasurements(MeasuredPoints):
    """Jump frequencies, one per (direction, sigma): ``"down"``, where a down sweep fell
    off the resonant branch; ``"up"``, where an up sweep jumped onto it. The attributes
    are those of :class:`MeasuredPoints`.
    """

    kind = "jumps"


Measurements = SweepMeasurements | JumpMeasurements


# --------------------------------------------------------------------------- parameters
def parameter_values(scene: Scene) -> dict[str, float]:
    """The scene's values of :data:`FREE_KEYS` (f0 as the rig derives it)."""
    return {
        "rig.natural_frequency": derive(scene.rig).natural_frequency,
        "damping.ratio": float(scene.damping.ratio),
        "damping.exponent": float(scene.damping.exponent),
    }


def with_values(scene: Scene, values: Mapping[str, float]) -> Scene:
    """The scene with parameters of :data:`FREE_KEYS` set (a measured f0 on the rig)."""
    rig, damping = scene.rig, scene.damping
    if "rig.natural_frequency" in values:
        rig = replace(rig, natural_frequency=float(values["rig.natural_frequency"]))
    if "damping.ratio" in values:
        damping = replace(damping, ratio=float(values["damping.ratio"]))
    if "damping.exponent" in values:
        damping = replace(damping, exponent=float(values["damping.exponent"]))
    return replace(scene, rig=rig, damping=damping)


def linear_response(
    frequency_ratio: np.ndarray, sigma: np.ndarray, zeta: float
) -> tuple[np.ndarray, np.ndarray]:
    """H1 of N/F_s of eq. (8) linearised about the static load: amplitude [1] and phase
    lag [degree] in [0, 360).

    ``q'' + 2 zeta q' + q = sigma sin(w tau)`` and ``N/F_s - 1 = q + 2 zeta q'``, so
    ``N_1 = sigma (1 + 2 i zeta w) / (1 - w^2 + 2 i zeta w)``; ``A sin(w tau - phi)`` has
    the complex amplitude ``A exp(-i phi)``.
    """
    w = np.asarray(frequency_ratio, dtype=float)
    damped = 2j * zeta * w
    response = np.asarray(sigma, dtype=float) * (1.0 + damped) / (1.0 - w * w + damped)
    return np.abs(response), np.degrees(-np.angle(response)) % 360.0


# --------------------------------------------------------------------------- orbits
def _first_harmonic(osc: Oscillator, state: State, w: float) -> tuple[float, float]:
    """H1 amplitude and phase read over one period from ``state`` (at a period start)."""
    _, reading = osc.measure(state, w, 1)
    return float(reading.amplitude[0]), float(reading.phase[0])


def _jumped(amplitude: float, reference: float, direction: str, threshold: float) -> bool:
    """A down sweep fell (H1 dropped by more than ``threshold`` of the larger value), an
    up sweep jumped up (rose by as much): the sweep's jump criterion, one-sided."""
    change = reference - amplitude if direction == "down" else amplitude - reference
    return change > threshold * max(amplitude, reference)


@dataclass(frozen=True)
class _Steady:
    """The steady state a dwell reached: the state, its H1, and whether it jumped."""

    state: State
    amplitude: float
    phase: float
    jumped: bool = False


def steady_state(
    osc: Oscillator,
    period: PeriodMap,
    state: State,
    w: float,
    reference: tuple[float, str, float] | None = None,
) -> _Steady:
    """The attractor a run from ``state`` reaches at ``w``: Newton (monotone) on the
    period map first; where it fails or lands on an unstable orbit, integration in blocks
    of :data:`TRANSIENT_BLOCK` periods, Newton tried again each time the one-period
    mismatch has fallen tenfold below :data:`TRANSIENT_TOLERANCE`, accepted by
    integration alone below :data:`SETTLED_TOLERANCE`, at most ``max_settle_periods``.

    ``reference`` = (H1, direction, threshold) ends the integration as soon as H1 has
    jumped from the reference (:func:`_jumped`), the attractor not being needed then.
    """
    from .shooting import mismatch, newton

    def done(orbit_state: State) -> _Steady:
        a, phi = _first_harmonic(osc, orbit_state, w)
        return _Steady(orbit_state, a, phi, reference is not None and _jumped(a, *reference))

    state = osc.retune(state, w)
    orbit = newton(period, state, w, monotone=True)
    if orbit.stable:
        return done(orbit.state)
    limit = osc.scene.sweep.max_settle_periods
    periods, next_newton = 0, TRANSIENT_TOLERANCE
    while True:
        start = osc.advance(state, w, TRANSIENT_BLOCK - 1)
        state = osc.advance(start, w, 1)
        periods += TRANSIENT_BLOCK
        if reference is not None and periods % (TRANSIENT_BLOCK * READ_BLOCKS) == 0:
            a, phi = _first_harmonic(osc, state, w)
            if _jumped(a, *reference):
                return _Steady(state, a, phi, True)
        gap = mismatch(period, start, state)
        if gap <= next_newton:
            next_newton = gap / 10.0
            orbit = newton(period, state, w, monotone=True)
            if orbit.stable:
                return done(orbit.state)
        if gap <= SETTLED_TOLERANCE or periods >= limit:
            return done(state)


def sweep_first_harmonic(
    scene: Scene, sigma: float, frequency_ratios: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """H1 amplitude and phase [degree] of a sweep of periodic orbits that visits
    ``frequency_ratios`` in the given order, from rest at the first (:func:`steady_state`
    at each, carrying the state)."""
    from .oscillator import Oscillator
    from .shooting import PeriodMap

    osc = Oscillator(scene, sigma)
    period = PeriodMap(osc)
    amplitude = np.empty(len(frequency_ratios))
    phase = np.empty(len(frequency_ratios))
    state = osc.rest(float(frequency_ratios[0]))
    for i, w in enumerate(frequency_ratios):
        steady = steady_state(osc, period, state, float(w))
        state, amplitude[i], phase[i] = steady.state, steady.amplitude, steady.phase
    return amplitude, phase


def jump_frequency_ratio(scene: Scene, sigma: float, direction: str) -> float:
    """Where the model's sweep in ``direction`` jumps at ``sigma``: NaN when it does not
    between :data:`WALK_BOTTOM` and :data:`WALK_TOP` (:func:`walk`)."""
    return walk(scene, sigma, direction)[0]


def walk(scene: Scene, sigma: float, direction: str) -> tuple[float, float]:
    """The model's sweep in ``direction`` at ``sigma``: ``(jump, resonance)``, the
    frequency ratio where it jumps and, when it does not (NaN), where H1's phase lag
    crossed 90 degrees (the phase resonance, where a jump appears as the damping falls;
    NaN if it did not either).

    A walk through periodic orbits (:func:`steady_state`) from rest at one end,
    :data:`WALK_TOP` for a down sweep, :data:`WALK_BOTTOM` for an up sweep, to the other.
    A step after which H1 jumped (by more than :data:`FOLD_JUMP`, down for a down sweep,
    up for an up sweep) is halved and tried again from the last orbit; an accepted step
    is halved after a change of H1 above :data:`WALK_CHANGE`, doubled (up to
    :data:`WALK_STEP`) after two below a quarter of it. The walk ends when the step is
    below :data:`JUMP_TOLERANCE`: the last frequency ratio on the swept branch is the
    jump, the fold lying within the tolerance beyond it. A change that shrinks with the
    step is no jump, so the result is the fold whatever the steps, a bistable band
    narrower than a step included.
    """
    from .oscillator import Oscillator
    from .shooting import PeriodMap

    osc = Oscillator(scene, sigma)
    period = PeriodMap(osc)
    start, end = (WALK_TOP, WALK_BOTTOM) if direction == "down" else (WALK_BOTTOM, WALK_TOP)
    sign = 1.0 if end > start else -1.0
    w = start
    steady = steady_state(osc, period, osc.rest(w), w)
    step, smooth, resonance = WALK_STEP, 0, math.nan
    while step > JUMP_TOLERANCE:
        w_next = end if sign * (w + sign * step - end) >= 0.0 else w + sign * step
        trial = steady_state(
            osc, period, steady.state, w_next, (steady.amplitude, direction, FOLD_JUMP)
        )
        if trial.jumped:
            step, smooth = step / 2.0, 0
            continue
        if math.isnan(resonance):
            resonance = _phase_crossing(w, steady.phase, w_next, trial.phase)
        change = abs(trial.amplitude - steady.amplitude) / max(
            trial.amplitude, steady.amplitude, 1e-300
        )
        w, steady = w_next, trial
        if w == end:
            return math.nan, resonance
        smooth = smooth + 1 if change < WALK_CHANGE / 4.0 else 0
        if change > WALK_CHANGE:
            step /= 2.0
        elif smooth >= 2:
            step, smooth = min(2.0 * step, WALK_STEP), 0
    return w, math.nan


def _phase_crossing(w0: float, phase0: float, w1: float, phase1: float) -> float:
    """Where the phase lag crosses 90 degrees between two neighbouring orbits (linear
    interpolation), NaN if it does not (or wraps between them)."""
    if abs(phase1 - phase0) >= 180.0 or (phase0 - 90.0) * (phase1 - 90.0) > 0.0:
        return math.nan
    if phase1 == phase0:
        return w1
    return w0 + (90.0 - phase0) / (phase1 - phase0) * (w1 - w0)


# --------------------------------------------------------------------------- models
class _Model:
    """A model of the measurements: predictions and residuals at given parameter values.

    Attributes
    ----------
    method : one of :data:`METHODS` (not ``auto``).
    evaluations : model evaluations so far.
    """

    method = ""

    def __init__(self, scene: Scene, data: Measurements, progress: Progress | None) -> None:
        self.scene = scene
        self.data = data
        self.progress = progress
        self.evaluations = 0
        self.f0 = derive(scene.rig).natural_frequency

    def ratios(self, values: Mapping[str, float]) -> np.ndarray:
        """The measured frequencies as ratios w for the values' f0."""
        if not self.data.in_hertz:
            return self.data.frequency
        return self.data.frequency / values.get("rig.natural_frequency", self.f0)

    def counted(self) -> None:
        self.evaluations += 1
        if self.progress is not None:
            self.progress(1)

    def predict(self, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def point_residuals(
        self, model: Mapping[str, np.ndarray], values: Mapping[str, float]
    ) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        raise NotImplementedError


class _SweepModel(_Model):
    """H1 readings: the linear response, or sweeps of periodic orbits (``shooting``)."""

    def __init__(
        self, scene: Scene, data: SweepMeasurements, method: str, progress: Progress | None
    ) -> None:
        super().__init__(scene, data, progress)
        self.method = method
        self.groups = []  # (indices in sweep order) per (direction, sigma)
        for direction in ("up", "down"):
            for sigma in np.unique(data.sigma):
                index = np.flatnonzero((data.direction == direction) & (data.sigma == sigma))
                if index.size:
                    order = np.argsort(data.frequency[index], kind="stable")
                    self.groups.append(index[order if direction == "up" else order[::-1]])
        self.has_phase = np.isfinite(data.phase)

    def predict(self, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        """``{"amplitude", "phase"}`` of the model at every measured point."""
        scene = with_values(self.scene, values)
        w = self.ratios(values)
        if self.method == "linear":
            amplitude, phase = linear_response(w, self.data.sigma, scene.damping.ratio)
        else:
            amplitude = np.empty(w.size)
            phase = np.empty(w.size)
            for index in self.groups:
                sigma = float(self.data.sigma[index[0]])
                amplitude[index], phase[index] = sweep_first_harmonic(scene, sigma, w[index])
        self.counted()
        return {"amplitude": amplitude, "phase": phase}

    def point_residuals(
        self, model: Mapping[str, np.ndarray], values: Mapping[str, float]
    ) -> dict[str, np.ndarray]:
        """Per point: relative amplitude error and phase error [radian] (NaN: no phase)."""
        data = self.data
        lag = np.radians(model["phase"] - data.phase)
        return {
            "amplitude": model["amplitude"] / data.amplitude - 1.0,
            "phase": np.angle(np.exp(1j * lag)),
        }

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        point = self.point_residuals(self.predict(values), values)
        return np.concatenate([point["amplitude"], point["phase"][self.has_phase]])


class _JumpModel(_Model):
    """Jump frequencies: the model's jump of each measured (direction, sigma)."""

    method = "fold"

    def predict(self, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        """``frequency_ratio``: the model's jumps (NaN: none in the walk);
        ``resonance``: its phase resonances where it has none (:func:`walk`);
        ``frequency``: the jumps in the data's unit (Hz with the values' f0, or 1)."""
        scene = with_values(self.scene, values)
        walks = np.array(
            [
                walk(scene, float(sigma), str(direction))
                for direction, sigma in zip(self.data.direction, self.data.sigma, strict=True)
            ]
        ).reshape(-1, 2)
        self.counted()
        ratio = walks[:, 0]
        return {
            "frequency_ratio": ratio,
            "resonance": walks[:, 1],
            "frequency": ratio * self.unit(values),
        }

    def unit(self, values: Mapping[str, float]) -> float:
        """The data's frequency unit in frequency ratios: f0 [Hz], or 1."""
        return values.get("rig.natural_frequency", self.f0) if self.data.in_hertz else 1.0

    def point_residuals(
        self, model: Mapping[str, np.ndarray], values: Mapping[str, float]
    ) -> dict[str, np.ndarray]:
        """Relative error of each jump. A model level without a jump counts at its phase
        resonance, where a jump appears as the damping falls (so the search feels which
        way to go), or without that at the walk's far end (:data:`WALK_BOTTOM` down,
        :data:`WALK_TOP` up)."""
        ends = np.where(self.data.direction == "down", WALK_BOTTOM, WALK_TOP)
        ratio = model["frequency_ratio"]
        ratio = np.where(np.isfinite(ratio), ratio, model["resonance"])
        ratio = np.where(np.isfinite(ratio), ratio, ends)
        return {"jump": ratio * self.unit(values) / self.data.frequency - 1.0}

    def residuals(self, values: Mapping[str, float]) -> np.ndarray:
        return self.point_residuals(self.predict(values), values)["jump"]


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class LawFit:
    """One row of the contact-law comparison: the fit with ``exponent`` fixed (NaN: n
    free) and its residual RMS."""

    exponent: float
    result: FitResult


@dataclass(frozen=True)
class FitResult:
    """What :func:`fit` found.

    Attributes
    ----------
    keys : the free parameters, in :data:`FREE_KEYS` order.
    estimate, standard_error, initial, lower, upper : float[p]
        The optimum, its standard errors (inf: not determined by the data), where the
        search started and its bounds.
    at_bound : bool[p]
        The estimate lies on a bound (its standard error then means little).
    correlation : float[p, p]
        Correlations of the estimates.
    residuals : float[m]
        The residual vector at the optimum (module notes); ``residual_rms`` its RMS.
    method : the model evaluation used.
    evaluations : model evaluations (least squares, Jacobians and curves).
    success, message : :func:`scipy.optimize.least_squares`'s verdict.
    data : the measurements fitted (harmonic 1 of a sweep).
    model : the model at the optimum at every measured point (``amplitude``, ``phase``
        or ``frequency_ratio``, ``frequency``).
    point_residuals : the residuals per measured point (``amplitude``, ``phase`` [radian]
        or ``jump``).
    scene : the scene with the estimates set.
    curve_sigma, curve_frequency_ratio : for jumps, the model's jumps on levels between
        the measured ones: float[L] and float[2 (down, up), L].
    laws : the contact-law comparison (empty unless asked for).
    """

    keys: tuple[str, ...]
    estimate: np.ndarray
    standard_error: np.ndarray
    initial: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    at_bound: np.ndarray
    correlation: np.ndarray
    residuals: np.ndarray
    residual_rms: float
    method: str
    evaluations: int
    success: bool
    message: str
    data: Measurements
    model: dict[str, np.ndarray]
    point_residuals: dict[str, np.ndarray]
    scene: Scene
    curve_sigma: np.ndarray = field(default_factory=lambda: np.empty(0))
    curve_frequency_ratio: np.ndarray = field(default_factory=lambda: np.empty((2, 0)))
    laws: tuple[LawFit, ...] = ()

    def parameters(self) -> dict[str, dict[str, float]]:
        """``{KEY: {"estimate", "standard_error"}}``."""
        return {
            key: {"estimate": float(x), "standard_error": float(s)}
            for key, x, s in zip(self.keys, self.estimate, self.standard_error, strict=True)
        }


def expected_evaluations(free: int, compare_laws: bool = False) -> int:
    """About how many model evaluations a fit of ``free`` parameters takes (for a
    progress bar): some ten least-squares steps of ``free + 1`` each, the Jacobian at the
    optimum and the curves; six fits to compare the laws."""
    one = 10 * (free + 1) + 2 * free + 3
    return one * (len(LAW_EXPONENTS) + 1) if compare_laws else one


# --------------------------------------------------------------------------- checks
def resolve_method(data: Measurements, method: str) -> str:
    """The model evaluation for the data: ``auto`` is ``fold`` for jumps, ``linear`` for
    sweeps whose largest H1 is at most :data:`LINEAR_AMPLITUDE`, else ``shooting``.

    Raises
    ------
    HertzsweepError
        An unknown method, or one that does not model this kind of data.
    """
    if method not in METHODS:
        raise HertzsweepError(f"--method: expected one of {', '.join(METHODS)}, got {method!r}")
    if isinstance(data, JumpMeasurements):
        if method not in ("auto", "fold"):
            raise HertzsweepError(f"--method: {method} models sweeps; jump frequencies use fold")
        return "fold"
    if method == "fold":
        raise HertzsweepError(
            "--method: fold models jump frequencies; sweeps use linear or shooting"
        )
    if method == "auto":
        return "linear" if np.nanmax(data.amplitude) <= LINEAR_AMPLITUDE else "shooting"
    return method


def check_free(
    free: Sequence[str], scene: Scene, data: Measurements, method: str
) -> tuple[str, ...]:
    """The free keys in :data:`FREE_KEYS` order, checked against the data and model.

    Raises
    ------
    HertzsweepError
        An unknown or repeated key; f0 free with frequencies given as ratios; the
        exponent free with the viscous law or the linear response (which cannot see it).
    """
    for key in free:
        if key not in FREE_KEYS:
            raise HertzsweepError(
                f"--free: {key!r} cannot be fitted (choose from {', '.join(FREE_KEYS)})"
            )
    if not free or len(set(free)) != len(free):
        raise HertzsweepError(f"--free: expected distinct keys of {', '.join(FREE_KEYS)}")
    if "rig.natural_frequency" in free and not data.in_hertz:
        raise HertzsweepError(
            f"--free: rig.natural_frequency: {data.source} gives frequency ratios, which "
            "do not depend on f0 (give frequencies in Hz)"
        )
    if "damping.exponent" in free:
        if scene.damping.law != "contact":
            raise HertzsweepError(
                "--free: damping.exponent: the scene's damping.law is 'viscous' "
                "(set damping.law = 'contact')"
            )
        if method == "linear":
            raise HertzsweepError(
                "--free: damping.exponent: the linear response is the same for every n "
                "(a sweep with contact loss, or jump frequencies, can determine it)"
            )
    return tuple(key for key in FREE_KEYS if key in free)


def _check_stability(scene: Scene, data: Measurements, values: Mapping[str, float]) -> None:
    """The scene's stability limit over the lowest frequency the model will reach."""
    w = data.frequency / values["rig.natural_frequency"] if data.in_hertz else data.frequency
    lowest = float(np.min(w)) if isinstance(data, SweepMeasurements) else WALK_BOTTOM
    sweep = replace(scene.sweep, start=lowest, stop=lowest, step=1.0)
    excitation = replace(scene.excitation, sigma=tuple(float(s) for s in np.unique(data.sigma)))
    check_stability(replace(scene, sweep=sweep, excitation=excitation))


# --------------------------------------------------------------------------- the fit
def fit(
    scene: Scene,
    data: Measurements,
    free: Sequence[str],
    method: str = "auto",
    progress: Progress | None = None,
    compare_laws: bool = False,
) -> FitResult:
    """Identify the ``free`` parameters from the measurements by least squares.

    Parameters
    ----------
    scene : Scene
        The rig, the damping law, the solver; its values of the keys not free are held,
        those of the free ones are where the search may start (:func:`initial_values`).
    data : SweepMeasurements or JumpMeasurements
        What was measured (of a sweep, harmonic 1 is fitted).
    free : sequence of str
        Keys of :data:`FREE_KEYS`.
    method : str
        One of :data:`METHODS` (module notes).
    progress : callable, optional
        Called with 1 after each model evaluation.
    compare_laws : bool
        Also fit with the contact law's exponent fixed at each of :data:`LAW_EXPONENTS`
        (``damping.exponent`` is then not among those fitted there) and with it free;
        the result is the fit with n free, ``laws`` the five fits.

    Raises
    ------
    HertzsweepError
        Free keys or method not suited to the data, no data, a model evaluation that
        failed (stability limit, non-finite state).
    """
    if isinstance(data, SweepMeasurements):
        data = data.first_harmonic()
        if data.amplitude.size == 0:
            raise HertzsweepError(f"{data.source}: no harmonic 1 readings to fit")
    if data.frequency.size == 0:
        raise HertzsweepError(f"{data.source}: no measurements to fit")
    method = resolve_method(data, method)
    scene = replace(scene, lockin=LockinConfig(harmonics=(1,)))
    if compare_laws:
        if method == "linear":
            raise HertzsweepError(
                "--compare-laws: the linear response is the same for every contact law"
            )
        if "damping.ratio" not in free:
            raise HertzsweepError("--compare-laws fits damping.ratio for each law: free it")
        scene = replace(scene, damping=replace(scene.damping, law="contact"))
        return _compare_laws(scene, data, free, method, progress)
    keys = check_free(free, scene, data, method)
    return _fit(scene, data, keys, method, progress)


def _compare_laws(
    scene: Scene, data: Measurements, free: Sequence[str], method: str, progress: Progress | None
) -> FitResult:
    """Fits with n fixed at each of :data:`LAW_EXPONENTS`, then with n free, started from
    the best of them."""
    fixed = check_free([k for k in free if k != "damping.exponent"], scene, data, method)
    rows = []
    for exponent in LAW_EXPONENTS:
        law_scene = with_values(scene, {"damping.exponent": exponent})
        rows.append(LawFit(exponent, _fit(law_scene, data, fixed, method, progress)))
    best = min(rows, key=lambda row: row.result.residual_rms).result
    keys = check_free([*fixed, "damping.exponent"], scene, data, method)
    start = replace(best.scene, source=scene.source)
    result = _fit(start, data, keys, method, progress, start_from_scene=True)
    rows.append(LawFit(math.nan, result))
    return replace(result, laws=tuple(rows))


def initial_values(model: _Model, keys: Sequence[str]) -> dict[str, float]:
    """Where the search starts: the scene's values, or for a sweep, if better (by the
    residuals), zeta from the resonance peak (``sigma / (2 max H1)``, the linear peak,
    which a weakly nonlinear resonance keeps) and f0 that puts the model's peak at the
    measured peak."""
    values = parameter_values(model.scene)
    if not isinstance(model.data, SweepMeasurements):
        return values
    data = model.data
    guess = dict(values)
    if "damping.ratio" in keys:
        peaks = [data.sigma[i[0]] / (2.0 * np.max(data.amplitude[i])) for i in model.groups]
        low, high = BOUNDS["damping.ratio"]
        guess["damping.ratio"] = float(np.clip(np.median(peaks), low, high))
    if "rig.natural_frequency" in keys:
        tallest = max(model.groups, key=lambda i: np.max(data.amplitude[i]))
        predicted = model.predict(guess)["amplitude"][tallest]
        measured_peak = data.frequency[tallest][np.argmax(data.amplitude[tallest])]
        model_peak = data.frequency[tallest][np.argmax(predicted)]
        guess["rig.natural_frequency"] *= float(measured_peak / model_peak)
    cost = [float(np.sum(model.residuals(v) ** 2)) for v in (values, guess)]
    return guess if cost[1] <= cost[0] else values


def _fit(
    scene: Scene,
    data: Measurements,
    keys: tuple[str, ...],
    method: str,
    progress: Progress | None,
    start_from_scene: bool = False,
) -> FitResult:
    """One least-squares fit of ``keys`` (checked) by the ``method``'s model."""
    from scipy.optimize import least_squares

    if isinstance(data, SweepMeasurements):
        model: _Model = _SweepModel(scene, data, method, progress)
    else:
        model = _JumpModel(scene, data, progress)
    _check_stability(scene, data, parameter_values(scene))
    start = parameter_values(scene) if start_from_scene else initial_values(model, keys)
    fixed = {k: v for k, v in parameter_values(scene).items() if k not in keys}
    x0 = np.array([start[k] for k in keys])
    scale = np.array([1.0 if k == "damping.exponent" else abs(start[k]) for k in keys])
    lower, upper = _bounds(keys, x0)
    x0 = np.clip(x0, lower, upper)

    def values(u: np.ndarray) -> dict[str, float]:
        return {**fixed, **dict(zip(keys, (u * scale).tolist(), strict=True))}

    step = STEPS[method]
    try:
        found = least_squares(
            lambda u: model.residuals(values(u)),
            x0 / scale,
            bounds=(lower / scale, upper / scale),
            diff_step=step,
            xtol=TOLERANCES[method],
            ftol=TOLERANCES[method],
            max_nfev=MAX_EVALUATIONS,
        )
    except HertzsweepError as exc:
        raise exc.with_context("fit") from None
    estimate = found.x * scale
    best = values(found.x)
    prediction = model.predict(best)
    point_residuals = model.point_residuals(prediction, best)
    residuals = np.concatenate([v[np.isfinite(v)] for v in point_residuals.values()])
    jacobian = _jacobian(model, values, found.x, step, lower / scale, upper / scale) / scale
    error, correlation = _statistics(jacobian, residuals)
    curve_sigma, curve = _curves(model, best, prediction)
    return FitResult(
        keys=keys,
        estimate=estimate,
        standard_error=error,
        initial=x0,
        lower=lower,
        upper=upper,
        at_bound=np.isclose(estimate, lower, rtol=1e-9, atol=0.0)
        | np.isclose(estimate, upper, rtol=1e-9, atol=0.0),
        correlation=correlation,
        residuals=residuals,
        residual_rms=float(np.sqrt(np.mean(residuals**2))) if residuals.size else math.nan,
        method=method,
        evaluations=model.evaluations,
        success=bool(found.success),
        message=str(found.message),
        data=data,
        model=prediction,
        point_residuals=point_residuals,
        scene=with_values(scene, best),
        curve_sigma=curve_sigma,
        curve_frequency_ratio=curve,
    )


def _bounds(keys: Sequence[str], x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lower = np.empty(len(keys))
    upper = np.empty(len(keys))
    for i, key in enumerate(keys):
        low, high = BOUNDS[key]
        relative = key == "rig.natural_frequency"
        lower[i], upper[i] = (low * x0[i], high * x0[i]) if relative else (low, high)
    return lower, upper


def _jacobian(
    model: _Model,
    values: Callable[[np.ndarray], dict[str, float]],
    u: np.ndarray,
    step: float,
    lower: np.ndarray,
    upper: np.ndarray,
) -> np.ndarray:
    """d residuals / du by central differences (one-sided at a bound), steps
    ``step * max(1, |u|)``."""
    columns = []
    for j in range(u.size):
        h = step * max(1.0, abs(u[j]))
        up, down = u.copy(), u.copy()
        up[j] = min(u[j] + h, upper[j])
        down[j] = max(u[j] - h, lower[j])
        difference = model.residuals(values(up)) - model.residuals(values(down))
        columns.append(difference / (up[j] - down[j]))
    return np.column_stack(columns)


def _statistics(jacobian: np.ndarray, residuals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Standard errors and correlations: ``s^2 (J^T J)^-1``, ``s^2 = |r|^2 / (m - p)``;
    inf where the data do not determine a parameter (a singular J^T J), NaN without
    degrees of freedom."""
    m, p = jacobian.shape
    if m <= p:
        return np.full(p, np.nan), np.full((p, p), np.nan)
    normal = jacobian.T @ jacobian
    variance = float(residuals @ residuals) / (m - p)
    try:
        if np.linalg.cond(normal) > 1e14:  # a direction the residuals do not feel
            raise np.linalg.LinAlgError
        covariance = variance * np.linalg.inv(normal)
    except np.linalg.LinAlgError:
        return np.full(p, np.inf), np.full((p, p), np.nan)
    error = np.sqrt(np.diag(covariance))
    return error, covariance / np.outer(error, error)


def _curves(
    model: _Model, values: Mapping[str, float], prediction: Mapping[str, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """For jumps, the model's jumps per direction (down, up) on the measured levels (from
    ``prediction``) and the geometric means between them; nothing for sweeps (the model
    is drawn at every measured point)."""
    if not isinstance(model, _JumpModel):
        return np.empty(0), np.empty((2, 0))
    data = model.data
    measured = np.unique(data.sigma)
    levels = np.union1d(measured, np.sqrt(measured[:-1] * measured[1:]))
    scene = with_values(model.scene, values)
    curve = np.full((2, levels.size), np.nan)
    for d, direction in enumerate(("down", "up")):
        if not np.any(data.direction == direction):
            continue
        for i, sigma in enumerate(levels):
            known = np.flatnonzero((data.direction == direction) & (data.sigma == sigma))
            if known.size:
                curve[d, i] = prediction["frequency_ratio"][known[0]]
            else:
                curve[d, i] = jump_frequency_ratio(scene, float(sigma), direction)
        model.counted()
    return levels, curve


__all__ = [
    "BOUNDS",
    "FREE_KEYS",
    "FitResult",
    "JumpMeasurements",
    "LAW_EXPONENTS",
    "LawFit",
    "METHODS",
    "MeasuredPoints",
    "Measurements",
    "SweepMeasurements",
    "check_free",
    "expected_evaluations",
    "fit",
    "initial_values",
    "jump_frequency_ratio",
    "linear_response",
    "parameter_values",
    "resolve_method",
    "steady_state",
    "sweep_first_harmonic",
    "walk",
    "with_values",
]
