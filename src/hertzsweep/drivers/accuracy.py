"""The speed/accuracy trade of the solver settings, measured on the user's own scene.

A *ladder* of settings is run with :func:`hertzsweep.drivers.sweep.run_sweep` on copies
of the scene that differ in one setting each, for every integration method
(``solver.method``, :data:`hertzsweep.kernels.methods.METHODS`; ``methods`` chooses):

- steps per period N at the scene's settling, each method on its own axis (default
  :data:`METHOD_STEPS`: 32 .. 2048 for the central difference, 16 .. 256 for rk4, powers
  of 2);
- settling at the scene's N and method: fixed 50, 100, 300, 1000 periods, and ``"auto"``
  with tolerance 1e-2 .. 1e-6;
- the steady state by shooting (``sweep.steady_state = "shooting"``) at each N of each
  method's steps axis: Newton finds the periodic orbit of the discrete method itself, so
  these rungs carry no settling error;
- the *reference*: the most accurate method's largest N with the longest fixed
  settling, and its Richardson partner at N/2 with the same settling.

Each rung is measured against the reference (:func:`sweep_errors`) and costed in wall
time (what the Pareto front and ``--target`` use: a step costs differently per method)
and integration steps. The reference itself is checked by Richardson extrapolation of
its method's order (:data:`RICHARDSON_ORDER`, :func:`richardson_error`): with an error
``C h^p``, ``|A_N - A_N/2| / (2^p - 1)`` estimates the error of ``A_N``.

The observed order comes from successive rungs of the steps axis, which share the same
settling: ``p = log2(|A_N - A_2N| / |A_2N - A_4N|)`` (max norm of H1 over the sweep).
Differences of rungs with the same settling cancel the settling error that errors
against the reference (settled longer) keep, so p is the order of the time
discretisation alone.

Wall time is measured per rung in one process, after every method's kernels are loaded
(:func:`run_ladder`): it is the machine's, and a re-run's differ by the machine's noise
(a few per cent on rungs of 0.1 s and more). Integration steps
(:attr:`SweepResult.steps`) are reported as well: deterministic, but an rk4 step is
four force evaluations, and a Newton period of shooting counts as N steps although it
also propagates the tangent map.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.config import SOLVER_METHODS, Scene
from ..core.model import stability_limit
from ..errors import ConfigError, HertzsweepError
from ..kernels.methods import MODELS
from .sweep import SweepResult, run_sweep

DEFAULT_METHOD = "central-difference"  # a Setting's method when none is named (older files)
DEFAULT_STEPS = (32, 64, 128, 256, 512, 1024, 2048)  # powers of 2: each halving of h is a rung
METHOD_STEPS = {  # each method's default steps axis: from a 1e-2 error to the round-off
    "central-difference": DEFAULT_STEPS,  # of the readings (order 2: 1e-5 at N = 2048)
    "rk4": (16, 32, 64, 128, 256),  # order 4: 1e-8 at N = 256 on the default scene
}
QUICK_METHOD_STEPS = {"central-difference": (64, 128, 256, 512, 1024), "rk4": (32, 64, 128)}
RICHARDSON_ORDER = {"central-difference": 2.0, "rk4": 3.5}  # the order where the force is
# smooth (2), and rk4's through impacts (3.5, below its 4 in contact: the safe side of the
# Richardson estimate |A_N - A_N/2| / (2^p - 1))
DEFAULT_SETTLE: tuple[int | str, ...] = (  # fixed settling around the default 300 periods,
    *(50, 100, 300, 1000),  # then "auto" from loose to tight
    *(f"auto:1e-{k}" for k in range(2, 7)),
)
QUICK_STEPS = QUICK_METHOD_STEPS["central-difference"]  # --quick: around the default 256
QUICK_SETTLE: tuple[int | str, ...] = (100, 300, 1000, "auto:1e-3", "auto:1e-5")  # and settling
FALLBACK_REFERENCE_SETTLE = 1000  # [periods] when the ladder has no fixed settling

Progress = Callable[[int], None]


# --------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class Setting:
    """One rung of the ladder: the solver settings it changes on the scene.

    Attributes
    ----------
    steps_per_period : int
        N, integration steps per excitation period.
    settle_periods : int or None
        Fixed settling [periods], or None for ``"auto"``.
    tolerance : float or None
        The tolerance of ``"auto"`` (None: the scene's).
    steady_state : str
        ``"settle"`` or ``"shooting"``.
    method : str
        ``solver.method``.
    """

    steps_per_period: int
    settle_periods: int | None
    tolerance: float | None = None
    steady_state: str = "settle"
    method: str = DEFAULT_METHOD

    @property
    def settle(self) -> str:
        """``"300"`` or ``"auto:1e-4"``."""
        if self.settle_periods is not None:
            return str(self.settle_periods)
        return "auto" if self.tolerance is None else f"auto:{format_tolerance(self.tolerance)}"

    @property
    def label(self) -> str:
        """``"N=256 settle=300"``, ``"N=256 settle=auto:1e-4"`` or ``"N=256 shooting"``,
        after the method's name unless it is the central difference (``"rk4 N=64
        shooting"``)."""
        method = "" if self.method == DEFAULT_METHOD else f"{self.method} "
        if self.steady_state == "shooting":
            return f"{method}N={self.steps_per_period} shooting"
        return f"{method}N={self.steps_per_period} settle={self.settle}"

    def overrides(self) -> list[str]:
        """The ``--set KEY=VALUE`` of ``hertzsweep sweep`` that reproduce this setting."""
        settle = self.settle_periods if self.settle_periods is not None else '"auto"'
        sets = [
            f"solver.method={self.method}",
            f"solver.steps_per_period={self.steps_per_period}",
            f"sweep.steady_state={self.steady_state}",
            f"sweep.settle_periods={settle}",
        ]
        if self.tolerance is not None:
            sets.append(f"sweep.tolerance={format_tolerance(self.tolerance)}")
        return sets

    @property
    def set_options(self) -> str:
        """:meth:`overrides` as command-line options: ``--set KEY=VALUE ...``."""
        return " ".join(f"--set {item}" for item in self.overrides())

    def apply(self, scene: Scene) -> Scene:
        """A copy of the scene with these settings."""
        sweep = replace(
            scene.sweep,
            settle_periods=self.settle_periods,
            tolerance=scene.sweep.tolerance if self.tolerance is None else self.tolerance,
            steady_state=self.steady_state,
        )
        solver = replace(scene.solver, steps_per_period=self.steps_per_period, method=self.method)
        return replace(scene, sweep=sweep, solver=solver)

    @classmethod
    def of_scene(cls, scene: Scene) -> Setting:
        """The scene's own settings (its fixed settling, or auto at its tolerance)."""
        fixed = scene.sweep.settle_periods
        return cls(
            scene.solver.steps_per_period,
            fixed,
            None if fixed is not None else scene.sweep.tolerance,
            scene.sweep.steady_state,
            scene.solver.method,
        )


def format_tolerance(tolerance: float) -> str:
    """``1e-4`` rather than ``0.0001`` or ``1e-04``."""
    return np.format_float_scientific(tolerance, trim="-", exp_digits=1)


def parse_steps(text: str, source: str = "--steps") -> tuple[int, ...]:
    """``"32,64,128"`` -> (32, 64, 128), sorted, duplicates dropped.

    Raises
    ------
    ConfigError
        An item is not a whole number >= 2.
    """
    out = set()
    for item in text.split(","):
        item = item.strip()
        if not item.isdigit() or int(item) < 2:
            raise ConfigError(
                source, "", f"expected whole numbers >= 2 separated by commas, got {item!r}"
            )
        out.add(int(item))
    return tuple(sorted(out))


def parse_settle(item: int | str, source: str = "--settle") -> tuple[int | None, float | None]:
    """``300`` -> (300, None); ``"auto:1e-4"`` -> (None, 1e-4); ``"auto"`` -> (None, None)
    (the scene's tolerance).

    Raises
    ------
    ConfigError
        Not a whole number >= 0, ``auto`` or ``auto:TOL`` with 0 < TOL < 1.
    """
    text = str(item).strip()
    if text.isdigit():
        return int(text), None
    if text == "auto":
        return None, None
    head, sep, tail = text.partition(":")
    if head == "auto" and sep:
        try:
            tolerance = float(tail)
        except ValueError:
            tolerance = math.nan
        if 0.0 < tolerance < 1.0:
            return None, tolerance
    raise ConfigError(
        source, "", f"expected periods (a whole number), 'auto' or 'auto:TOL', got {text!r}"
    )


def parse_settle_list(
    text: str, source: str = "--settle"
) -> tuple[tuple[int | None, float | None], ...]:
    """A comma-separated ``--settle`` list, e.g. ``"100,300,auto:1e-4"``."""
    return tuple(parse_settle(item, source) for item in text.split(","))


@dataclass(frozen=True)
class Ladder:
    """The settings to run, the reference and its Richardson partner.

    ``settings`` holds every rung once, reference last; ``notes`` says what was left out
    and why (at or below the stability limit).
    """

    settings: tuple[Setting, ...]
    reference: Setting
    partner: Setting | None
    scene_setting: Setting
    notes: tuple[str, ...] = ()


def build_ladder(
    scene: Scene,
    steps: Sequence[int] | None = None,
    settle: Sequence[int | str | tuple[int | None, float | None]] | None = None,
    quick: bool = False,
    shooting: bool = True,
    methods: Sequence[str] | None = None,
) -> Ladder:
    """The ladder of settings for a scene (see the module docstring).

    Parameters
    ----------
    scene : Scene
        The scene whose settings are varied; its own N, settling and method are the axes'
        base.
    steps : sequence of int, optional
        Steps per period of every method's steps rungs (default each method's own,
        :data:`METHOD_STEPS`; ``quick``: :data:`QUICK_METHOD_STEPS`). The reference
        method's largest is the reference's.
    settle : sequence, optional
        Settling of the settle rungs: periods, ``"auto"`` or ``"auto:TOL"`` (or parsed
        ``(periods, tolerance)`` pairs). The longest fixed one is the reference's.
    quick : bool
        Fewer rungs (:data:`QUICK_METHOD_STEPS`, :data:`QUICK_SETTLE`).
    shooting : bool
        Include the shooting rungs, one per N of each method.
    methods : sequence of str, optional
        The methods on the ladder (default every one, the scene's first); the one of
        highest order (:data:`RICHARDSON_ORDER`) gives the reference.

    Rungs at or below their method's stability limit on the scene
    (:func:`hertzsweep.core.model.stability_limit`) are left out with a note; the
    reference must be above it.
    """
    methods = _ladder_methods(scene, methods)
    raw_settle = settle if settle is not None else (QUICK_SETTLE if quick else DEFAULT_SETTLE)
    settles = [s if isinstance(s, tuple) else parse_settle(s) for s in raw_settle]
    base = Setting.of_scene(scene)
    base_settle = replace(base, steady_state="settle")
    axes = {m: _method_steps(m, steps, quick) for m in methods}
    notes: list[str] = []
    candidates: list[Setting] = []
    for method, ns in axes.items():
        candidates += [replace(base_settle, steps_per_period=n, method=method) for n in ns]
        if method == methods[0]:
            candidates += [replace(base_settle, settle_periods=p, tolerance=t) for p, t in settles]
        if shooting:
            candidates += [
                Setting(n, base.settle_periods, base.tolerance, "shooting", method) for n in ns
            ]
    if base.steady_state == "settle" or shooting:
        candidates.append(base)  # the scene's own settings, to compare with (once)
    fixed = [p for p, _ in settles if p is not None]
    if base.settle_periods is not None:
        fixed.append(base.settle_periods)
    longest = max(fixed) if fixed else FALLBACK_REFERENCE_SETTLE
    method = max(methods, key=lambda m: RICHARDSON_ORDER[m])
    finest = max(axes[method])
    reference = Setting(finest, longest, method=method)
    partner = Setting(finest // 2, longest, method=method) if finest // 2 >= 2 else None
    limits = {
        m: stability_limit(replace(scene, solver=replace(scene.solver, method=m)))
        for m in SOLVER_METHODS
    }
    if reference.steps_per_period <= limits[method]:
        reason = (
            f"the finest rung N={finest} of {method} is at or below its stability limit "
            f"{limits[method]:.1f} steps per period; give finer steps"
        )
        raise ConfigError("--steps", "", reason)
    settings: list[Setting] = []
    for setting in [*candidates, partner, reference]:
        if setting is None or setting in settings:
            continue
        limit = limits[setting.method]
        if setting.steps_per_period <= limit:
            note = f"{setting.label} skipped: at or below the stability limit {limit:.1f}"
            if note not in notes:
                notes.append(note)
            continue
        settings.append(setting)
    settings.remove(reference)
    settings.append(reference)
    if partner is not None and partner not in settings:
        partner = None
    return Ladder(tuple(settings), reference, partner, base, tuple(notes))


def _ladder_methods(scene: Scene, methods: Sequence[str] | None) -> tuple[str, ...]:
    """The ladder's methods, the scene's first (every method of its model by default)."""
    available = tuple(MODELS[scene.model.kind])
    chosen = tuple(dict.fromkeys(methods if methods is not None else available))
    unknown = [m for m in chosen if m not in available]
    if unknown or not chosen:
        of = f" of model.kind = {scene.model.kind!r}" if scene.model.kind != "single" else ""
        raise ConfigError(
            "--methods",
            "",
            f"expected some of {', '.join(available)}{of}, got {','.join(unknown)!r}",
        )
    own = scene.solver.method
    return tuple(sorted(chosen, key=lambda m: m != own))


def _method_steps(method: str, steps: Sequence[int] | None, quick: bool) -> tuple[int, ...]:
    if steps:
        return tuple(sorted(set(steps)))
    return (QUICK_METHOD_STEPS if quick else METHOD_STEPS)[method]


def parse_methods(text: str) -> tuple[str, ...]:
    """``"central-difference,rk4"`` -> the methods (checked by :func:`build_ladder`)."""
    return tuple(item.strip() for item in text.split(",") if item.strip())


# --------------------------------------------------------------------------- running
@dataclass
class Rung:
    """One run of the ladder: its setting, the sweep and what it cost."""

    setting: Setting
    result: SweepResult
    wall_time: float  # [s]

    @property
    def cost_steps(self) -> int:
        return int(self.result.steps)


def _accuracy_scene(scene: Scene) -> Scene:
    """The scene with H1 and H2 read (the errors are measured on both)."""
    harmonics = tuple(sorted(set(scene.lockin.harmonics) | {1, 2}))
    return replace(scene, lockin=replace(scene.lockin, harmonics=harmonics))


def _warm_up(scene: Scene, kinds: set[tuple[str, str]]) -> None:
    """One short dwell per (method, steady state), so that loading the compiled kernels
    is not charged to the first rung of each."""
    first = scene.sweep.start
    one_dwell = replace(
        scene.sweep,
        stop=first,
        directions=scene.sweep.directions[:1],
        settle_periods=1,
        measure_periods=2,
    )
    excitation = replace(scene.excitation, sigma=scene.excitation.sigma[:1])
    for method, steady_state in sorted(kinds):
        sweep = replace(one_dwell, steady_state=steady_state)
        solver = replace(scene.solver, method=method)
        try:
            run_sweep(replace(scene, sweep=sweep, solver=solver, excitation=excitation))
        except HertzsweepError:
            pass  # the rung itself will report it


def run_ladder(
    scene: Scene,
    ladder: Ladder,
    progress: Progress | None = None,
    clock: Callable[[], float] = time.perf_counter,
) -> tuple[list[Rung], list[str]]:
    """Run every setting of the ladder (``progress(1)`` after each).

    A rung that fails (the run reaches a compression beyond its stability limit, the
    state turns non-finite, shooting does not converge) is left out with a note; the
    reference must succeed.

    Returns
    -------
    rungs, notes
    """
    scene = _accuracy_scene(scene)
    _warm_up(scene, {(setting.method, setting.steady_state) for setting in ladder.settings})
    rungs: list[Rung] = []
    notes: list[str] = []
    for setting in ladder.settings:
        start = clock()
        try:
            result = run_sweep(setting.apply(scene))
        except HertzsweepError as exc:
            if setting == ladder.reference:
                raise
            notes.append(f"{setting.label} failed: {exc}")
        else:
            rungs.append(Rung(setting, result, clock() - start))
        if progress is not None:
            progress(1)
    return rungs, notes


# --------------------------------------------------------------------------- errors
@dataclass(frozen=True)
class Errors:
    """Errors of one sweep against another.

    Attributes
    ----------
    h1, h2 : [1] max abs error of the H1 (H2) amplitude over directions, sigma and the
        grid, relative to the largest H1 (H2) of the reference.
    force : [1] max abs error of force_max and force_min, in units of F_s.
    jump : [1] max abs difference of jump_frequency_ratio; 0 where neither jumped,
        inf where only one did.
    """

    h1: float
    h2: float
    force: float
    jump: float


def _harmonic_index(result: SweepResult, k: int) -> int | None:
    found = np.flatnonzero(result.harmonics == k)
    return int(found[0]) if found.size else None


def _amplitude_error(result: SweepResult, reference: SweepResult, k: int) -> float:
    i, j = _harmonic_index(result, k), _harmonic_index(reference, k)
    if i is None or j is None:
        return math.nan
    ref = reference.amplitude[..., j]
    scale = np.nanmax(ref)
    if not scale > 0:
        return math.nan
    return float(np.nanmax(np.abs(result.amplitude[..., i] - ref)) / scale)


def jump_error(jumps: np.ndarray, reference: np.ndarray) -> float:
    """Max abs difference of jump frequencies, NaN-aware: 0 where neither sweep jumped,
    inf where only one did."""
    a, b = np.asarray(jumps, float), np.asarray(reference, float)
    both = np.isnan(a) & np.isnan(b)
    one = np.isnan(a) ^ np.isnan(b)
    if np.any(one):
        return math.inf
    diff = np.where(both, 0.0, np.abs(a - b))
    return float(np.max(diff)) if diff.size else 0.0


def sweep_errors(result: SweepResult, reference: SweepResult) -> Errors:
    """Errors of a sweep against the reference sweep on the same grid."""
    force = max(
        float(np.nanmax(np.abs(result.force_max - reference.force_max))),
        float(np.nanmax(np.abs(result.force_min - reference.force_min))),
    )
    return Errors(
        h1=_amplitude_error(result, reference, 1),
        h2=_amplitude_error(result, reference, 2),
        force=force,
        jump=jump_error(result.jump_frequency_ratio, reference.jump_frequency_ratio),
    )


def richardson_error(fine: Rung, coarse: Rung, order: float | None = None) -> Errors:
    """Estimated error of the fine rung: ``|A_fine - A_coarse| / (r^p - 1)`` with the
    step ratio r (2 for the reference and its partner) and order p (default its method's,
    :data:`RICHARDSON_ORDER`). The jump difference is reported as is (jump frequencies
    lie on the grid)."""
    order = RICHARDSON_ORDER[fine.setting.method] if order is None else order
    r = fine.setting.steps_per_period / coarse.setting.steps_per_period
    diff = sweep_errors(coarse.result, fine.result)
    scale = r**order - 1.0
    return Errors(diff.h1 / scale, diff.h2 / scale, diff.force / scale, diff.jump)


def successive_difference(a: SweepResult, b: SweepResult) -> float:
    """``max |H1_a - H1_b| / max H1_b`` over the sweep."""
    return _amplitude_error(a, b, 1)


def observed_orders(rungs: Sequence[Rung]) -> list[float]:
    """Observed order per rung, along each axis of step halving.

    Rungs with the same settling, steady state and method form an axis; for N with 2N and 4N on it,
    ``p_N = log2(d(N, 2N) / d(2N, 4N))`` with d the max-norm successive difference of H1
    (:func:`successive_difference`). NaN for the other rungs and where a difference
    vanishes.
    """
    axes: dict[tuple[str, str, str], dict[int, int]] = {}
    for i, rung in enumerate(rungs):
        key = _axis(rung.setting)
        axes.setdefault(key, {})[rung.setting.steps_per_period] = i
    orders = [math.nan] * len(rungs)
    for axis in axes.values():
        for n, i in axis.items():
            if 2 * n in axis and 4 * n in axis:
                a, b, c = (rungs[axis[m]].result for m in (n, 2 * n, 4 * n))
                d1, d2 = successive_difference(a, b), successive_difference(b, c)
                orders[i] = math.log2(d1 / d2) if d1 > 0 and d2 > 0 else math.nan
    return orders


def _axis(setting: Setting) -> tuple[str, str, str]:
    """The steps axis a setting is on: its settling, steady state and method."""
    return (setting.settle, setting.steady_state, setting.method)


def fitted_order(steps_per_period: Sequence[int], errors: Sequence[float]) -> float:
    """Least-squares slope of ``log(error)`` against ``log(N)``, sign flipped: the order p
    of ``error ~ C h^p`` over many step sizes.

    Where the error constant itself scatters from one N to the next (a force that jumps
    between two steps, as the n = 0 contact damping at impact), successive halvings give
    erratic orders; the slope over many N is the order.
    """
    n = np.asarray(steps_per_period, float)
    e = np.asarray(errors, float)
    slope = np.polyfit(np.log(n), np.log(e), 1)[0]
    return float(-slope)


def pareto_front(cost: Sequence[float], error: Sequence[float]) -> np.ndarray:
    """True where no other point is at least as cheap and as accurate and better in one
    of the two. Points with a non-finite error are never on the front."""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    ok = np.isfinite(error)
    front = np.zeros(cost.size, dtype=bool)
    for i in np.flatnonzero(ok):
        dominated = (
            ok & (cost <= cost[i]) & (error <= error[i]) & ((cost < cost[i]) | (error < error[i]))
        )
        front[i] = not np.any(dominated)
    return front


def recommend(
    cost: Sequence[float], error: Sequence[float], target: float, reference_error: float = 0.0
) -> int | None:
    """Index of the cheapest setting whose H1 error, plus the reference's own estimated
    error, is at most ``target``; ties go to the smaller error. None if none is."""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    margin = reference_error if math.isfinite(reference_error) else 0.0
    meets = np.flatnonzero(np.isfinite(error) & (error + margin <= target))
    if meets.size == 0:
        return None
    return int(min(meets, key=lambda i: (cost[i], error[i])))


# --------------------------------------------------------------------------- report
@dataclass
class AccuracyReport:
    """Everything ``hertzsweep accuracy`` prints and stores.

    Attributes
    ----------
    rungs : the settings that ran, reference last.
    errors : per rung, against the reference.
    orders : per rung, the observed order p_N along its axis of step halving (NaN where
        N, 2N and 4N are not all on it).
    reference_error : the reference's error estimated by Richardson extrapolation.
    settle_rung : the index of the rung at the reference's N and method that best
        isolates the reference's settling error (:attr:`settle_check`), None if none ran.
    scene_setting : the scene's own settings (a rung of the ladder).
    target : the ``--target``: the H1 error to recommend the fastest setting for.
    target_margin : the reference's estimated H1 error added to each rung's error when
        checking it against the target.
    notes : what was skipped or failed, and why.
    scene_arguments : the scene file and the ``--set`` options it was run with, as a
        shell would take them (the printed reproduction starts with them).
    """

    rungs: list[Rung]
    errors: list[Errors]
    orders: list[float]
    reference_error: Errors | None
    settle_rung: int | None
    scene_setting: Setting
    target: float | None = None
    target_margin: float = 0.0
    notes: list[str] = field(default_factory=list)
    scene_arguments: str = "SCENE"

    @property
    def reference(self) -> Rung:
        return self.rungs[-1]

    @property
    def richardson_order(self) -> float:
        """The order p of the reference's Richardson estimate: its method's."""
        return RICHARDSON_ORDER[self.reference.setting.method]

    @property
    def observed_order(self) -> float:
        """p of the finest triple N, 2N, 4N on the steps axis at the scene's settling,
        steady state and method."""
        return _finest_order(self.rungs, self.orders, _axis(self.scene_setting))

    @property
    def pareto(self) -> np.ndarray:
        """Per rung, on the Pareto front of (wall time, error H1)."""
        return pareto_front([r.wall_time for r in self.rungs], [e.h1 for e in self.errors])

    @property
    def recommended(self) -> int | None:
        """The index of the fastest rung (wall time) whose H1 error, plus the
        :attr:`target_margin`, meets the target; None without one or a target."""
        if self.target is None:
            return None
        cost = [r.wall_time for r in self.rungs]
        return recommend(cost, [e.h1 for e in self.errors], self.target, self.target_margin)

    @property
    def settle_check(self) -> Errors | None:
        """The reference against the rung at the same N by shooting (its settling error)
        or, without shooting, with shorter settling (a bound on what settling longer
        still changes)."""
        return None if self.settle_rung is None else self.errors[self.settle_rung]

    @property
    def settle_check_label(self) -> str:
        """The setting of :attr:`settle_check` ("" without one)."""
        return "" if self.settle_rung is None else self.rungs[self.settle_rung].setting.label

    def index(self, setting: Setting) -> int | None:
        """Index of a setting's rung, None if it did not run."""
        for i, rung in enumerate(self.rungs):
            if rung.setting == setting:
                return i
        return None


def assess(
    rungs: list[Rung], ladder: Ladder, target: float | None = None, notes: Sequence[str] = ()
) -> AccuracyReport:
    """The report of a run ladder: errors against the reference, observed orders, the
    reference's own error and the margin it adds to the target."""
    reference = rungs[-1]
    if reference.setting != ladder.reference:
        raise HertzsweepError("the reference rung did not run")
    partner = next((r for r in rungs if r.setting == ladder.partner), None)
    report = AccuracyReport(
        rungs=rungs,
        errors=[sweep_errors(r.result, reference.result) for r in rungs],
        orders=observed_orders(rungs),  # the reference can be the 4N of a triple
        reference_error=richardson_error(reference, partner) if partner is not None else None,
        settle_rung=_settle_rung(rungs),
        scene_setting=ladder.scene_setting,
        target=target,
        notes=[*ladder.notes, *notes],
    )
    method = reference.setting.method
    base = replace(ladder.scene_setting, steady_state="settle", method=method)
    reference_order = _finest_order(rungs, report.orders, _axis(base))
    reference_error = report.reference_error
    margin = reference_error.h1 if reference_error is not None else 0.0
    order = report.richardson_order
    low = math.isfinite(reference_order) and reference_order < order - 0.5
    if reference_error is not None and low:
        factor = 2.0**order - 1.0  # the order-1 estimate over the order-p one
        margin *= factor
        report.notes.append(
            f"observed order {reference_order:.2f} of {method} is not {order:g} (a force that "
            "jumps between steps, as the n = 0 contact damping, makes the central difference "
            f"first order): the order-{order:g} Richardson estimate understates the "
            f"reference's error ({factor:.3g}x at order 1), so --target counts {factor:.3g}x "
            "that estimate"
        )
    report.target_margin = margin
    return report


def _finest_order(rungs: list[Rung], orders: list[float], axis: tuple[str, str, str]) -> float:
    """The observed order of the finest triple N, 2N, 4N on an axis (NaN if none)."""
    on_axis = [
        (r.setting.steps_per_period, p)
        for r, p in zip(rungs, orders, strict=True)
        if _axis(r.setting) == axis and math.isfinite(p)
    ]
    return max(on_axis)[1] if on_axis else math.nan


def _settle_rung(rungs: list[Rung]) -> int | None:
    """The index of the rung at the reference's N and method that best isolates its
    settling error: shooting (no settling error at all) if present, else the longest
    other settling; None if no other rung ran at that N and method."""
    reference = rungs[-1].setting
    same_n = [
        i
        for i, r in enumerate(rungs[:-1])
        if (r.setting.steps_per_period, r.setting.method)
        == (reference.steps_per_period, reference.method)
    ]
    if not same_n:
        return None
    shooting = [i for i in same_n if rungs[i].setting.steady_state == "shooting"]
    return shooting[0] if shooting else max(same_n, key=lambda i: rungs[i].cost_steps)


def measure_accuracy(
    scene: Scene,
    ladder: Ladder | None = None,
    target: float | None = None,
    progress: Progress | None = None,
) -> AccuracyReport:
    """Run a ladder of settings on the scene and assess it.

    Parameters
    ----------
    scene : Scene
        The scene whose solver settings are measured.
    ladder : Ladder, optional
        The settings to run (:func:`build_ladder`; default the scene's full ladder).
    target : float, optional
        The H1 error to recommend the cheapest setting for (:func:`assess`).
    progress : callable, optional
        Called with 1 after each rung.
    """
    ladder = ladder if ladder is not None else build_ladder(scene)
    rungs, notes = run_ladder(scene, ladder, progress)
    return assess(rungs, ladder, target, notes)
