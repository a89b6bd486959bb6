"""Preflight: every check a run makes on its scene, before any work.

:func:`preflight` is the one function that ``validate`` runs and reports, that every
command reading a scene runs before computing (``hertzsweep.cli.options.read_scene``) and
that a study runs on each of its cases (``hertzsweep.drivers.study.expand``). Each check
raises a :class:`~hertzsweep.errors.ConfigError` naming the file and the key:

- the rig's derived constants (k, z_s, Omega, f0, ...) are finite and positive;
- the frequency grid has at most :data:`MAX_POINTS` points, counted without building it,
  all positive and distinct at the grid's rounding (12 decimals);
- ``solver.steps_per_period`` is at most :data:`MAX_STEPS_PER_PERIOD`;
- every lock-in harmonic lies below the Nyquist order ``steps_per_period / 2``;
- ``sweep.measure_periods`` is a multiple of the lock-in's common denominator L (orders
  that are not whole are read over whole response periods of L excitation periods);
- the run's integration steps are within the budget (``solver.max_steps``, default
  :data:`DEFAULT_MAX_STEPS`);
- its result arrays are within :data:`MEMORY_BUDGET`;
- the time step is within the stability limit (:func:`hertzsweep.core.model.stability_limit`).

A random scene (``excitation.kind = "random"``, its plan in :data:`PLANS`) has no grid nor
lock-in: its band lies below the step's Nyquist frequency and holds a line of the record,
its time step is within the stability limit at the largest force the linear response
suggests, and its steps and memory (the forcing of every realisation included) are within
the same budgets.

:func:`check_record` adds the record of ``hertzsweep trace`` (its memory and steps, and its
periods a multiple of the lock-in's common denominator).

This module imports neither numba nor xarray: ``validate`` stays light.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from .ballmode import check_periods, has_ball_mode
from .ballmodel import BallModel
from .config import (
    DampingConfig,
    ExcitationConfig,
    RandomConfig,
    RigConfig,
    Scene,
    SolverConfig,
    SweepConfig,
    from_command_line,
    load_scene,
    rig_key_furthest,
)
from .excitation import forcing_phases, process_periods
from .kinds import commands_of
from .model import STABILITY, omega_max, stability_limit, stability_reason
from .rig import RigConstants, derive

# The most frequencies a grid may have. The paper's finest sweeps have a few hundred;
# 100 000 points at the default dwell (320 periods of 256 steps) are already 8e9 steps a
# trajectory, and a grid is built (and its results kept) as arrays of this length.
MAX_POINTS = 100_000
# The most steps per period: the excitation and lock-in tables hold N floats each (8 MiB
# apiece at 2**20; the lock-in's N L for orders of common denominator L <= 12), and 2**20
# steps resolve a period 4000 times finer than the default 256.
MAX_STEPS_PER_PERIOD = 2**20
# The default budget of integration steps of one run (``solver.max_steps`` raises it): at
# about 9 ns a step (the lockstep kernel's 7.1 ns plus the dwell's overheads), 1e11 steps
# take about 15 minutes on one core. The default scene takes 2e7.
DEFAULT_MAX_STEPS = 10**11
# The most memory the arrays of one run's results (or one trace's record) may take.
MEMORY_BUDGET = 2 * 2**30
# A run's results are held about three times: the driver's arrays, the dataset built on
# them, and the netCDF writer's contiguous copy of a variable.
RESULT_COPIES = 3
FLOAT = 8  # bytes of a float64
SCALAR_READINGS = 5  # per dwell: mean_force, force_max, force_min, contact_loss, flight
FLAGS = 2  # per dwell, one byte each: settled, periodic
GRID_DECIMALS = 12  # SweepConfig.frequency_ratios rounds the grid to 12 decimals
DEFAULT_SWEEP = SweepConfig()
DEFAULT_SOLVER = SolverConfig()
DEFAULT_POINTS = 61  # the default grid 0.90 .. 1.05 in steps of 0.0025
DEFAULT_TRAJECTORIES = 4  # the default scene: 2 directions x 2 sigma
DEFAULT_HARMONICS = 2  # the default lock-in: H1 and H2
# Every derived rig constant (SI) lies within this range: a product or a square of two of
# them (Omega^2 in eq. 3, k z_s^(3/2) = F_s, tau / Omega in seconds) stays a finite normal
# float. The paper's rig spans 7e-6 m (z_s) to 6e9 N m^-3/2 (k), and a rig the scheme can
# describe lies many decades inside; E = 1e-300 Pa (k = 3e-302) or R = 1e300 m
# (k = 5e160) do not.
DERIVED_RANGE = (1e-150, 1e150)
RIG_LABELS = {  # derived constant -> its name in errors
    "contact_stiffness": "contact stiffness k",
    "static_compression": "static compression z_s",
    "natural_circular_frequency": "natural circular frequency Omega",
    "natural_frequency": "natural frequency f0",
    "static_load": "static load F_s",
    "contact_pressure": "static contact pressure p0",
    "contact_radius": "static contact radius a",
    "ball_mode_frequency": "ball's own mode",
    "hertz_contact_stiffness": "Hertz contact stiffness",
    "hertz_natural_frequency": "Hertz natural frequency",
}


@dataclass(frozen=True)
class Figures:
    """What a run of the scene takes, as :func:`preflight` found it.

    A random scene (its plan in :data:`PLANS`) is one "frequency" (``points = 1``) whose
    ``trajectories`` are levels x realisations, each integrating one record of
    ``periods_per_dwell = transient_periods + duration_periods`` periods.

    Attributes
    ----------
    points : frequencies of the grid (1 for a random scene).
    trajectories : directions x sigma (levels ``rms`` x realisations for a random scene).
    periods_per_dwell : settling (``max_settle_periods`` for ``"auto"``) + measuring (the
        record, transient included, for a random scene).
    steps : integration steps of the whole run, at most (``"auto"`` may settle sooner).
    max_steps : the budget of steps (``solver.max_steps`` or :data:`DEFAULT_MAX_STEPS`).
    memory : [bytes] the estimate of the results' memory.
    memory_budget : [bytes] :data:`MEMORY_BUDGET`.
    stability_limit : the fewest steps per period the scheme is stable with.
    stability_margin : ``steps_per_period / stability_limit`` (above 1).
    """

    points: int
    trajectories: int
    periods_per_dwell: int
    steps: int
    max_steps: int
    memory: int
    memory_budget: int
    stability_limit: float
    stability_margin: float

    @classmethod
    def of(
        cls,
        scene: Scene,
        points: int,
        trajectories: int,
        periods: int,
        steps: int,
        memory: int,
        limit: float,
    ) -> Figures:
        """The figures of a checked scene; its budgets and margin follow from the scene."""
        return cls(
            points=int(points),
            trajectories=trajectories,
            periods_per_dwell=periods,
            steps=steps,
            max_steps=max_steps(scene),
            memory=memory,
            memory_budget=MEMORY_BUDGET,
            stability_limit=limit,
            stability_margin=scene.solver.steps_per_period / limit,
        )


# --------------------------------------------------------------------------- the rig
def rig_source(scene: Scene) -> str:
    """The file the scene's ``[rig]`` values came from: its rig file, else the scene."""
    return scene.inputs[1] if len(scene.inputs) > 1 else scene.source


def check_rig(rig: RigConfig, source: str) -> RigConstants:
    """The rig's derived constants (:func:`hertzsweep.core.rig.derive`), each finite,
    positive and within :data:`DERIVED_RANGE` (the ball's mode may be NaN, for a single
    sphere-plane); a ConfigError naming ``source`` and the rig key furthest from the
    paper's rig otherwise."""
    values = {f.name: getattr(rig, f.name) for f in fields(rig)}
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            constants = derive(rig)
    except (ArithmeticError, ValueError) as exc:  # OverflowError of a float power, ...
        reason = f"the derived constants cannot be computed ({exc})"
        raise ConfigError(source, rig_key_furthest(values), reason) from None
    low, high = DERIVED_RANGE
    for name, value in constants.as_dict().items():
        if name == "ball_mode_frequency" and rig.geometry == "sphere-plane":
            continue  # not defined: NaN
        if not low <= value <= high:  # NaN, inf, 0 and negative values too
            reason = (
                f"the derived {RIG_LABELS.get(name, name)} is {value:g}, outside "
                f"[{low:g}, {high:g}]: the rig's values give no usable constants"
            )
            raise ConfigError(source, rig_key_furthest(values), reason)
    return constants


# --------------------------------------------------------------------------- the grid
def grid_count(sweep: SweepConfig) -> float:
    """The number of frequencies of the grid, counted as
    :attr:`SweepConfig.frequency_ratios` counts them but without building it: a float,
    ``inf`` when the count is not finite."""
    span = (sweep.stop - sweep.start) / sweep.step + 1e-9
    return float(math.floor(span) + 1) if math.isfinite(span) else math.inf


def grid_key(sweep: SweepConfig) -> str:
    """The key that makes a grid long: ``sweep.stop`` when its span is further above the
    default's than its step is below the default's, else ``sweep.step``."""
    span_ratio = (sweep.stop - sweep.start) / (DEFAULT_SWEEP.stop - DEFAULT_SWEEP.start)
    step_ratio = DEFAULT_SWEEP.step / sweep.step
    return "sweep.stop" if span_ratio > step_ratio else "sweep.step"


def check_grid(scene: Scene) -> np.ndarray:
    """The grid of a scene: at most :data:`MAX_POINTS` points (counted first), each
    positive and distinct after the grid's rounding to 12 decimals."""
    sweep = scene.sweep
    count = grid_count(sweep)
    if count > MAX_POINTS:
        shown = f"{count:.0f}" if count < 1e15 else f"{count:.3g}"  # exact while it is
        raise ConfigError(
            scene.source,
            grid_key(sweep),
            f"the grid {sweep.start:g} .. {sweep.stop:g} in steps of {sweep.step:g} has "
            f"{shown} frequencies, more than {MAX_POINTS}",
        )
    grid = sweep.frequency_ratios
    if grid[0] <= 0.0:
        raise ConfigError(
            scene.source,
            "sweep.start",
            f"{sweep.start:g} rounds to 0 at the grid's {GRID_DECIMALS} decimals",
        )
    if grid.size > 1 and not np.all(np.diff(grid) > 0.0):
        raise ConfigError(
            scene.source,
            "sweep.step",
            f"{sweep.step:g} is below the grid's resolution 1e-{GRID_DECIMALS}: "
            "frequencies collapse into each other",
        )
    return grid


# --------------------------------------------------------------------------- the solver
def check_steps_per_period(scene: Scene) -> None:
    """``steps_per_period`` at most :data:`MAX_STEPS_PER_PERIOD`."""
    steps = scene.solver.steps_per_period
    if steps > MAX_STEPS_PER_PERIOD:
        raise ConfigError(
            scene.source,
            "solver.steps_per_period",
            f"{steps} is more than the largest {MAX_STEPS_PER_PERIOD} (2**20): a run keeps "
            "tables of steps_per_period floats",
        )


def check_harmonics(scene: Scene) -> None:
    """Every lock-in harmonic k below the Nyquist order: ``k < steps_per_period / 2``.

    The lock-in reads the sampled N/F_s with tables of ``steps_per_period`` entries: a
    harmonic at or above ``N/2`` aliases onto a lower one (``k = N/2`` reads only the
    sampled cosine) and reads the tables out of their range from ``k = N``.
    """
    steps = scene.solver.steps_per_period
    highest = max(scene.lockin.harmonics)
    if 2 * highest >= steps:
        # the key further from the default scene's (N = 256, harmonics up to 2)
        coarser = DEFAULT_SOLVER.steps_per_period / steps
        higher = highest / DEFAULT_HARMONICS
        raise ConfigError(
            scene.source,
            "solver.steps_per_period" if coarser > higher else "lockin.harmonics",
            f"harmonic {highest} is not below the Nyquist order steps_per_period / 2 = "
            f"{steps / 2:g} (raise solver.steps_per_period above {2 * highest})",
        )


def _orders(scene: Scene) -> str:
    """The lock-in's orders as the scene file writes them."""
    return "[" + ", ".join(f"{k:g}" for k in scene.lockin.harmonics) + "]"


def check_measure_periods(scene: Scene) -> None:
    """``sweep.measure_periods`` a multiple of the lock-in's common denominator L
    (:attr:`~hertzsweep.core.config.LockinConfig.denominator`): an order k that is not
    whole (1/2, 1/3, 1/4, ...) is read exactly only over whole response periods of L
    excitation periods, and a dwell's blocks (its two halves, ``"auto"``'s blocks) are
    each such a span."""
    common = scene.lockin.denominator
    periods = scene.sweep.measure_periods
    if periods % common:
        raise ConfigError(
            scene.source,
            "sweep.measure_periods",
            f"{periods} is not a multiple of {common}, the common denominator of "
            f"lockin.harmonics = {_orders(scene)}: those orders are read over whole periods "
            f"of {common} excitation periods (e.g. measure_periods = "
            f"{max(common, periods - periods % common)})",
        )


def check_stability_limit(scene: Scene) -> float:
    """The stability limit (:func:`hertzsweep.core.model.stability_limit`), which
    ``steps_per_period`` must exceed: the check the drivers make, as a ConfigError on
    ``solver.steps_per_period``. A limit beyond :data:`MAX_STEPS_PER_PERIOD` names
    ``excitation.sigma`` or ``sweep.start``, whichever factor of ``limit = 2 pi
    omega_max / (b w_min)`` (b the method's bound on h omega) lies further above the
    default scene's."""
    limit = stability_limit(scene)
    if not limit < MAX_STEPS_PER_PERIOD:
        sigma = max(scene.excitation.sigma)
        om = omega_max(sigma, scene.damping.ratio)
        w_min = float(scene.sweep.frequency_ratios[0])
        default_om = omega_max(max(ExcitationConfig().sigma), DampingConfig().ratio)
        key = "excitation.sigma" if om / default_om > DEFAULT_SWEEP.start / w_min else "sweep.start"
        raise ConfigError(
            scene.source,
            key,
            f"the stability limit {limit:.3g} steps per period (sigma = {sigma:g} at w = "
            f"{w_min:g}) is beyond the largest steps_per_period {MAX_STEPS_PER_PERIOD}",
        )
    reason = stability_reason(scene)
    if reason is not None:
        raise ConfigError(scene.source, "solver.steps_per_period", reason)
    return limit


# --------------------------------------------------------------------------- budgets
def periods_per_dwell(sweep: SweepConfig, extra: int = 0) -> int:
    """Periods integrated at one frequency, at most: settling (``max_settle_periods`` for
    ``"auto"``), measuring, and ``extra`` (a sweep's ball-mode period,
    :func:`~hertzsweep.core.ballmode.check_periods`)."""
    settle = sweep.max_settle_periods if sweep.settle_periods is None else sweep.settle_periods
    return settle + sweep.measure_periods + extra


def max_steps(scene: Scene) -> int:
    """The budget of integration steps: ``solver.max_steps``, else the default."""
    return scene.solver.max_steps or DEFAULT_MAX_STEPS


def _largest_factor(factors: dict[str, tuple[float, float]]) -> str:
    """The key whose factor ``(value, default)`` is furthest above its default."""
    return max(factors, key=lambda key: factors[key][0] / factors[key][1])


def check_steps(scene: Scene, points: int) -> int:
    """The integration steps of the run, at most: frequencies x trajectories x periods
    per dwell x ``steps_per_period`` (exact integers); refused beyond :func:`max_steps`,
    naming the factor furthest above the default scene's (its key)."""
    sweep = scene.sweep
    trajectories = len(sweep.directions) * len(scene.excitation.sigma)
    periods = periods_per_dwell(sweep, check_periods(scene))
    steps_per_period = scene.solver.steps_per_period
    total = points * trajectories * periods * steps_per_period
    budget = max_steps(scene)
    if total > budget:
        settle_key, settle, settle_default = (
            ("sweep.max_settle_periods", sweep.max_settle_periods, DEFAULT_SWEEP.max_settle_periods)
            if sweep.settle_periods is None
            else ("sweep.settle_periods", sweep.settle_periods, DEFAULT_SWEEP.settle_periods)
        )
        key = _largest_factor(
            {
                grid_key(scene.sweep): (points, DEFAULT_POINTS),
                "excitation.sigma": (trajectories, DEFAULT_TRAJECTORIES),
                settle_key: (settle, settle_default or 1),
                "sweep.measure_periods": (sweep.measure_periods, DEFAULT_SWEEP.measure_periods),
                "solver.steps_per_period": (steps_per_period, DEFAULT_SOLVER.steps_per_period),
            },
        )
        raise ConfigError(
            scene.source,
            key,
            f"the run would take {total:.3g} integration steps ({points} frequencies x "
            f"{trajectories} trajectories x {periods} periods x {steps_per_period} steps), "
            f"beyond the budget solver.max_steps = {budget:.3g} (about "
            f"{_duration(budget)} at 9 ns a step); raise solver.max_steps to allow it",
        )
    return total


def result_bytes(scene: Scene, points: int) -> int:
    """An estimate of the memory of a run's results: per dwell and trajectory, amplitude
    and phase of every harmonic, the scalar readings and the flags (and, where the rig
    has a ball, the ball-mode figure and the end state it is read from), held
    :data:`RESULT_COPIES` times; the grid's coordinates; the per-period tables."""
    trajectories = len(scene.sweep.directions) * len(scene.excitation.sigma)
    harmonics = len(scene.lockin.harmonics)
    ball = 3 if has_ball_mode(scene) else 0  # e and the state (q_prev, q) a dwell
    per_dwell = (2 * harmonics + SCALAR_READINGS + ball) * FLOAT + FLAGS
    tables = 2 * scene.solver.steps_per_period * FLOAT  # sin and cos of one period
    return RESULT_COPIES * (trajectories * points * per_dwell + 3 * points * FLOAT) + tables


def check_memory(scene: Scene, points: int) -> int:
    """:func:`result_bytes`, refused beyond :data:`MEMORY_BUDGET` (naming the factor
    furthest above the default scene's: the grid, the sigma list or the harmonics)."""
    memory = result_bytes(scene, points)
    if memory > MEMORY_BUDGET:
        trajectories = len(scene.sweep.directions) * len(scene.excitation.sigma)
        key = _largest_factor(
            {
                grid_key(scene.sweep): (points, DEFAULT_POINTS),
                "excitation.sigma": (trajectories, DEFAULT_TRAJECTORIES),
                "lockin.harmonics": (len(scene.lockin.harmonics), DEFAULT_HARMONICS),
            },
        )
        raise ConfigError(
            scene.source,
            key,
            f"the results would take {format_size(memory)} ({points} frequencies x {trajectories} "
            f"trajectories x {len(scene.lockin.harmonics)} harmonics), beyond the memory "
            f"budget {format_size(MEMORY_BUDGET)}",
        )
    return memory


def format_size(nbytes: float) -> str:
    """A memory size in B, kiB, MiB or GiB."""
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20), ("kiB", 2**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.3g} {unit}"
    return f"{nbytes:.0f} B"


def _duration(steps: float, seconds_per_step: float = 9e-9) -> str:
    seconds = steps * seconds_per_step
    if seconds < 120:
        return f"{seconds:.2g} s"
    if seconds < 3600:
        return f"{seconds / 60:.0f} minutes"
    if seconds < 86400 * 3:
        return f"{seconds / 3600:.0f} hours"
    return f"{seconds / 86400:.3g} days"


# --------------------------------------------------------------------------- random
DEFAULT_RANDOM = RandomConfig()
DEFAULT_LEVELS = 2  # the SPEC's random scene: rms = [0.005, 0.01]
# The largest N/F_s of a random run is estimated as 1 + PEAK_FACTOR x the linear response's
# RMS, the histogram range of the random run: a Gaussian passes 10 standard deviations with
# probability 1.5e-23 a sample, and the force enters the limit only as force^(1/6).
PEAK_FACTOR = 10.0
# The damping ratio the force estimate is floored at, as model.force_bound floors it: below
# it the linear resonance grows beyond what a finite record reaches.
ZETA_FLOOR = 1e-3
# Floats held per sample of one phase (hertzsweep.core.excitation.Phases) while the forcing
# is made: for each realisation of the group its complex spectrum (2 floats per 2 samples)
# and the phase's samples; for each thread the inverse FFT's work copy.
FORCING_WORKSPACE = 2
FORCING_GROUP = 16  # realisations whose forcing is made together, phase by phase, each
# phase's samples then copied into the table's rows at once (a row's group of realisations
# side by side) rather than a realisation's column at a time
FORCING_THREADS = 2  # realisations of a group whose phase is made at once, each in its own
# thread (hertzsweep.drivers.random.forcing_table; numpy's FFT releases the GIL), at most
# the cores
# Per sample of a Welch segment and trajectory: N/F_s, its windowed copy and its rFFT
# (half as many complex bins); per sample and realisation, the same for the forcing.
SEGMENT_FLOATS = 3
# Per Welch bin and trajectory: the accumulated S_NN, S_ff and S_fN (complex), and the
# per-realisation spectra formed from them (psd, excitation_psd, frf_amplitude, frf_phase,
# coherence) before the mean over realisations.
BIN_ACCUMULATORS = 4 + 5
# Per Welch bin and level in the dataset: psd, excitation_psd, frf_amplitude, frf_phase,
# coherence, each with its standard error.
BIN_RESULTS = 2 * 5
# Per trajectory: the moment sums (5), min, max, the contact-loss and flight counters (4)
# and its flight in progress (2); per level in the dataset: 13 statistics and their
# standard errors.
SCALAR_ACCUMULATORS = 13
SCALAR_RESULTS = 2 * 13
TRACE_COLUMNS = 4  # a trace sample: q, q', N/F_s and the contact flag (as hertzsweep trace)


def record_periods(scene: Scene) -> int:
    """The periods of a random scene's record: ``transient_periods + duration_periods``."""
    return scene.random.transient_periods + scene.random.duration_periods


def random_trajectories(scene: Scene) -> int:
    """The trajectories of a random run: levels (``excitation.rms``) x realisations."""
    return len(scene.excitation.rms) * scene.random.realisations


def samples_per_step(scene: Scene) -> int:
    """Forcing samples a step: 2 for rk4 (its half steps), else 1."""
    return 2 if scene.solver.method == "rk4" else 1


def check_band(scene: Scene) -> None:
    """The band lies below the step's Nyquist frequency ``w = steps_per_period / 2`` (the
    step is ``h = 2 pi / N`` in tau) and holds at least one line ``k / P`` of the record of
    P periods (:func:`hertzsweep.core.excitation.band_lines`, counted without building
    them); refused naming ``excitation.band``."""
    low, high = scene.excitation.band
    steps = scene.solver.steps_per_period
    if not high < steps / 2:
        raise ConfigError(
            scene.source,
            "excitation.band",
            f"w_high = {high:g} is at or above the step's Nyquist frequency steps_per_period "
            f"/ 2 = {steps / 2:g}: the band must lie in (0, {steps / 2:g}) (raise "
            f"solver.steps_per_period above {2 * high:g})",
        )
    periods = record_periods(scene)
    k = max(math.floor(low * periods) - 1, 1)  # the first line at or above w_low, found
    while k / periods < low:  # as band_lines's definition (k / P in floating point) says
        k += 1
    if not k / periods < high:
        raise ConfigError(
            scene.source,
            "excitation.band",
            f"{low:g} .. {high:g} holds no line k / P of the record of P = {periods} periods "
            f"(lines 1/{periods} = {1 / periods:.3g} apart): widen the band",
        )


def random_force_bound(scene: Scene) -> float:
    """An estimate of the largest N/F_s of a random run: ``1 + PEAK_FACTOR x rms x
    sqrt(V)``, rms the largest level and V the whole axis' integral of ``|H(w)|^2`` over
    ``w_high - w_low``, ``pi (1 + 4 zeta^2) / (4 zeta (w_high - w_low))`` (zeta floored
    at :data:`ZETA_FLOOR`): an upper bound of the band's variance
    (:func:`hertzsweep.core.excitation.linear_response_variance`) in closed form, so the
    preflight needs no quadrature (nor scipy). Like
    :func:`hertzsweep.core.model.force_bound`, an estimate: the kernels check the
    compression reached at every step."""
    low, high = scene.excitation.band
    zeta = max(scene.damping.ratio, ZETA_FLOOR)
    variance = math.pi * (1.0 + 4.0 * zeta * zeta) / (4.0 * zeta * (high - low))
    return 1.0 + PEAK_FACTOR * max(scene.excitation.rms) * math.sqrt(variance)


def random_stability_limit(scene: Scene) -> float:
    """The fewest steps per period that keep ``h omega_max < b`` over a random run
    (:data:`hertzsweep.core.model.STABILITY`): the sine's limit
    (:func:`hertzsweep.core.model.stability_limit`) at ``w = 1``, since a random run's
    step is ``h = 2 pi / N`` whatever the band, with ``omega_max`` at the force of
    :func:`random_force_bound` (``N^(1/6)``, or the ball's own mode for the ball model)."""
    force = random_force_bound(scene)
    if scene.model.kind == "ball":
        om = BallModel.of(scene).stability_frequency(force)
    else:
        om = force ** (1.0 / 6.0)
    return 2.0 * math.pi * om / STABILITY[scene.solver.method]


def check_random_stability(scene: Scene) -> float:
    """:func:`random_stability_limit`, which ``steps_per_period`` must exceed; a limit
    beyond :data:`MAX_STEPS_PER_PERIOD` names ``excitation.rms``, one at or above
    ``steps_per_period`` names ``solver.steps_per_period``."""
    limit = random_stability_limit(scene)
    steps = scene.solver.steps_per_period
    rms = max(scene.excitation.rms)
    if not limit < MAX_STEPS_PER_PERIOD:
        raise ConfigError(
            scene.source,
            "excitation.rms",
            f"the stability limit {limit:.3g} steps per period (rms = {rms:g}) is beyond the "
            f"largest steps_per_period {MAX_STEPS_PER_PERIOD}",
        )
    if not steps > limit:
        of = "the ball's own mode, " if scene.model.kind == "ball" else ""
        raise ConfigError(
            scene.source,
            "solver.steps_per_period",
            f"{steps} is at or below the stability limit {limit:.1f} of {of}"
            f"{scene.solver.method} (h omega_max >= {STABILITY[scene.solver.method]:.3g} at "
            f"the largest force {random_force_bound(scene):.3g} F_s the level rms = {rms:g} "
            f"is estimated to reach); use at least {math.floor(limit) + 1}",
        )
    return limit


def check_random_steps(scene: Scene) -> int:
    """The integration steps of a random run: realisations x levels x (transient +
    duration) periods x ``steps_per_period`` (exact integers); refused beyond
    :func:`max_steps`, naming the factor furthest above the SPEC's random scene's."""
    random = scene.random
    levels = len(scene.excitation.rms)
    periods = record_periods(scene)
    steps_per_period = scene.solver.steps_per_period
    total = random.realisations * levels * periods * steps_per_period
    budget = max_steps(scene)
    if total > budget:
        key = _largest_factor(
            {
                "random.realisations": (random.realisations, DEFAULT_RANDOM.realisations),
                "excitation.rms": (levels, DEFAULT_LEVELS),
                "random.duration_periods": (
                    random.duration_periods,
                    DEFAULT_RANDOM.duration_periods,
                ),
                "random.transient_periods": (
                    random.transient_periods,
                    DEFAULT_RANDOM.transient_periods,
                ),
                "solver.steps_per_period": (steps_per_period, DEFAULT_SOLVER.steps_per_period),
            },
        )
        raise ConfigError(
            scene.source,
            key,
            f"the run would take {total:.3g} integration steps ({random.realisations} "
            f"realisations x {levels} levels x {periods} periods x {steps_per_period} steps), "
            f"beyond the budget solver.max_steps = {budget:.3g} (about "
            f"{_duration(budget)} at 9 ns a step); raise solver.max_steps to allow it",
        )
    return total


def random_memory_terms(scene: Scene) -> list[tuple[int, str, dict[str, tuple[float, float]]]]:
    """The parts of :func:`random_bytes`: ``(bytes, what, {key: (value, default)})``, the
    keys that set each part with their values and the SPEC's random scene's."""
    random = scene.random
    levels = len(scene.excitation.rms)
    realisations = random.realisations
    trajectories = levels * realisations
    steps = scene.solver.steps_per_period
    per_period = samples_per_step(scene) * steps  # forcing samples a period
    record = per_period * record_periods(scene)  # samples a realisation
    segment = random.segment_periods * steps  # samples a Welch segment
    bins = segment // 2 + 1  # its rFFT's bins (and the frequency coordinates, 2 a bin)
    phases = forcing_phases(per_period, scene.excitation.band[1])
    phase = per_period // phases * process_periods(record_periods(scene))  # M, a phase's
    group = min(FORCING_GROUP, realisations)
    forcing = realisations * record + (FORCING_WORKSPACE * group + FORCING_THREADS) * phase
    buffers = SEGMENT_FLOATS * segment * (trajectories + realisations)
    spectra = (BIN_ACCUMULATORS * trajectories + RESULT_COPIES * (BIN_RESULTS * levels + 2)) * bins
    histograms = (trajectories + RESULT_COPIES * (2 * levels + 1)) * random.force_bins
    statistics = SCALAR_ACCUMULATORS * trajectories + RESULT_COPIES * SCALAR_RESULTS * levels
    trace = RESULT_COPIES * TRACE_COLUMNS * levels * random.trace_periods * steps
    default = DEFAULT_RANDOM
    by_realisations = {"random.realisations": (realisations, default.realisations)}
    by_levels = {"excitation.rms": (levels, DEFAULT_LEVELS)}
    by_steps = {"solver.steps_per_period": (steps, DEFAULT_SOLVER.steps_per_period)}
    return [
        (
            forcing * FLOAT,
            "the forcing of every realisation",
            {
                **by_realisations,
                "random.duration_periods": (random.duration_periods, default.duration_periods),
                **by_steps,
            },
        ),
        (
            (buffers + spectra) * FLOAT,
            "the Welch segments and spectra",
            {
                "random.segment_periods": (random.segment_periods, default.segment_periods),
                **by_realisations,
                **by_levels,
                **by_steps,
            },
        ),
        (
            (histograms + statistics) * FLOAT,
            "the histograms and statistics",
            {
                "random.force_bins": (random.force_bins, default.force_bins),
                **by_realisations,
                **by_levels,
            },
        ),
        (
            trace * FLOAT,
            "the trace",
            {"random.trace_periods": (random.trace_periods, 1)},  # default 0: none
        ),
    ]


def random_bytes(scene: Scene) -> int:
    """An estimate of the memory of a random run: the forcing of every realisation (``m N
    P`` floats each, m = 2 for rk4's half steps) and the workspace making a group of
    :data:`FORCING_GROUP` of them a phase at a time; per trajectory the Welch segment's
    buffers, the accumulated spectra and the histogram and moments; per level the dataset's
    spectra, histogram and statistics with their standard errors, and the trace, held
    :data:`RESULT_COPIES` times."""
    return sum(nbytes for nbytes, _, _ in random_memory_terms(scene))


def check_random_memory(scene: Scene) -> int:
    """:func:`random_bytes`, refused beyond :data:`MEMORY_BUDGET` naming, in its largest
    part, the key furthest above the SPEC's random scene's."""
    terms = random_memory_terms(scene)
    memory = sum(nbytes for nbytes, _, _ in terms)
    if memory > MEMORY_BUDGET:
        nbytes, what, factors = max(terms, key=lambda term: term[0])
        raise ConfigError(
            scene.source,
            _largest_factor(factors),
            f"the run would hold {format_size(memory)} ({format_size(nbytes)} of it "
            f"{what}: {scene.random.realisations} realisations x "
            f"{len(scene.excitation.rms)} levels), beyond the memory budget "
            f"{format_size(MEMORY_BUDGET)}",
        )
    return memory


# --------------------------------------------------------------------------- preflight
def _sine_plan(scene: Scene) -> Figures:
    """A stepped sine's part of the plan: the grid (:func:`check_grid`), the steps per
    period, the stability limit over the grid, the lock-in's harmonics and measuring
    periods, the steps and memory of every dwell of every direction and sigma."""
    grid = check_grid(scene)
    check_steps_per_period(scene)
    limit = check_stability_limit(scene)
    check_harmonics(scene)
    check_measure_periods(scene)
    steps = check_steps(scene, grid.size)
    memory = check_memory(scene, grid.size)
    trajectories = len(scene.sweep.directions) * len(scene.excitation.sigma)
    periods = periods_per_dwell(scene.sweep, check_periods(scene))
    return Figures.of(scene, grid.size, trajectories, periods, steps, memory, limit)


def _random_plan(scene: Scene) -> Figures:
    """A random run's part of the plan: one "frequency" (``points = 1``) whose
    trajectories are levels x realisations, each a record of transient + duration
    periods; the steps per period, the band (:func:`check_band`), the stability limit at
    the largest force the linear response suggests (:func:`check_random_stability`), the
    steps and the memory (the forcing of every realisation included). The sweep's grid
    and the lock-in are not used and not checked."""
    check_steps_per_period(scene)
    check_band(scene)
    limit = check_random_stability(scene)
    steps = check_random_steps(scene)
    memory = check_random_memory(scene)
    trajectories = random_trajectories(scene)
    return Figures.of(scene, 1, trajectories, record_periods(scene), steps, memory, limit)


PLANS = {"sine": _sine_plan, "random": _random_plan}
"""Each ``excitation.kind``'s part of the preflight plan: its grid, trajectories, steps
and bytes (:class:`Figures`), checked against the budgets."""


def preflight(scene: Scene) -> Figures:
    """Every check a run of the scene makes, before any work (the module docstring): the
    rig's constants for every scene, then the plan of its excitation (:data:`PLANS`).

    Returns
    -------
    Figures
        The grid, the trajectories, the steps and memory against their budgets, the
        stability limit and margin.

    Raises
    ------
    ConfigError
        The first check that fails, naming the file (the rig's file for the rig's
        constants) and the key.
    """
    check_rig(scene.rig, rig_source(scene))
    return PLANS[scene.excitation.kind](scene)


def load_checked_scene(
    path: str | Path, overrides: Iterable[str] | Mapping[str, Any] = ()
) -> tuple[Scene, Figures]:
    """Read a scene with its overrides (:func:`hertzsweep.core.config.load_scene`: ``--set``
    texts or a ``{key: value}`` mapping) and run :func:`check_scene` on it."""
    scene = load_scene(path, overrides)
    return scene, check_scene(scene)


def require_excitation(scene: Scene, kind: str, command: str) -> None:
    """Refuse a scene whose excitation is not ``kind`` for ``command`` (a random scene
    runs with ``hertzsweep random``, a sine scene with the others).

    Raises
    ------
    ConfigError
        Naming ``excitation.kind``.
    """
    given = scene.excitation.kind
    if given != kind:
        runs = commands_of(given)
        reason = f"{command} runs a {kind} excitation; a {given} scene runs with {runs}"
        raise ConfigError(scene.source, "excitation.kind", reason)


def check_scene(scene: Scene) -> Figures:
    """:func:`preflight`, a failing check whose key an override gave reported under
    ``--set`` (:attr:`Scene.overridden <hertzsweep.core.config.Scene>`)."""
    try:
        return preflight(scene)
    except ConfigError as exc:
        raise from_command_line(exc, scene.overridden) from None


# --------------------------------------------------------------------------- trace
STREAM_RECORD_BYTES = 2**24  # a trace record beyond 16 MiB (2048 periods x 256 samples
# of one sigma) is streamed to its file as it is integrated instead of held: the
# in-memory file image and the writer's copies would cost several times the record


def streams_record(scene: Scene, samples: int) -> bool:
    """Whether ``hertzsweep trace`` streams a record of ``samples`` samples per sigma to
    its file (:class:`hertzsweep.output.dataset.RecordStream`) rather than holding it."""
    return len(scene.excitation.sigma) * samples * 4 * FLOAT > STREAM_RECORD_BYTES  # 4 columns


def record_bytes(scene: Scene, samples: int) -> int:
    """An estimate of the memory of a trace of ``samples`` samples per sigma.

    Held: the record (q, q', N/F_s, contact: 4 floats a sample), the dataset's contact
    flags (1 byte) and the writer's contiguous copy of one column (1 float) per sigma
    and sample; the time coordinates (2 floats), the spectrum's transform buffer (1
    float) and, per sigma, the spectrum (half a float) per sample. Streamed
    (:func:`streams_record`): per sample only one sigma's N/F_s in the transform's input
    (1 float), the spectrum's orders and frequencies (1 float), the writer's buffers (1
    float) and, per sigma, the spectrum; per sigma and sample, the in-file record costs
    no memory (measured: 17.9-18.4 bytes per sample and sigma with 2 sigma).
    """
    sigma = len(scene.excitation.sigma)
    if streams_record(scene, samples):
        per_sample = 3 * FLOAT + sigma * (FLOAT // 2)
    else:
        per_sample = sigma * (4 * FLOAT + 1 + FLOAT + FLOAT // 2) + 3 * FLOAT
    return samples * per_sample + sigma * FLOAT


def check_record_periods(scene: Scene, periods: int, source: str = "trace") -> None:
    """A trace's recorded ``periods`` (``--periods``) a multiple of the lock-in's common
    denominator, as :func:`check_measure_periods` asks of ``sweep.measure_periods``."""
    common = scene.lockin.denominator
    if periods % common:
        raise ConfigError(
            source,
            "--periods",
            f"{periods} is not a multiple of {common}, the common denominator of "
            f"lockin.harmonics = {_orders(scene)}: those orders are read over whole periods "
            f"of {common} excitation periods",
        )


def check_record(
    scene: Scene,
    periods: int,
    samples_per_period: int | None = None,
    source: str = "trace",
) -> bool:
    """The memory of ``hertzsweep trace``'s record of ``periods`` periods
    (:func:`record_bytes`), refused beyond :data:`MEMORY_BUDGET`, and its integration
    steps, refused beyond :func:`max_steps`; before anything is allocated. ``periods``
    must be a multiple of the lock-in's common denominator (:func:`check_measure_periods`).

    The trace reaches its frequency through at most every grid point, then dwells there
    and records: at most ``sigma x ((points + 1) x periods_per_dwell + periods) x
    steps_per_period`` steps. A ``periods`` or ``samples_per_period`` the trace refuses
    anyway (not a whole number >= 1, not a divisor) is left to it.

    Returns whether the record is streamed to the file (:func:`streams_record`).
    """
    if isinstance(periods, bool) or not isinstance(periods, int | np.integer) or periods < 1:
        return False
    check_record_periods(scene, periods, source)
    steps_per_period = scene.solver.steps_per_period
    samples = steps_per_period
    if (
        isinstance(samples_per_period, int | np.integer)
        and not isinstance(samples_per_period, bool)
        and 1 <= samples_per_period <= steps_per_period
        and steps_per_period % samples_per_period == 0
    ):
        samples = int(samples_per_period)
    memory = record_bytes(scene, int(periods) * samples)
    if memory > MEMORY_BUDGET:
        raise ConfigError(
            source,
            "--periods",
            f"a record of {periods} periods x {samples} samples x "
            f"{len(scene.excitation.sigma)} sigma would take {format_size(memory)}, beyond the "
            f"memory budget {format_size(MEMORY_BUDGET)}",
        )
    sigma = len(scene.excitation.sigma)
    points = int(grid_count(scene.sweep))
    dwells = sigma * (points + 1) * periods_per_dwell(scene.sweep) * steps_per_period
    recorded = sigma * int(periods) * steps_per_period
    budget = max_steps(scene)
    if dwells + recorded > budget:
        where, key = (
            (source, "--periods") if recorded > dwells else (scene.source, "solver.max_steps")
        )
        raise ConfigError(
            where,
            key,
            f"the trace would take {dwells + recorded:.3g} integration steps ({recorded:.3g} "
            f"of them recording), beyond the budget solver.max_steps = {budget:.3g} (about "
            f"{_duration(budget)} at 9 ns a step)",
        )
    return streams_record(scene, int(periods) * samples)


__all__ = [
    "DEFAULT_MAX_STEPS",
    "MAX_POINTS",
    "MAX_STEPS_PER_PERIOD",
    "MEMORY_BUDGET",
    "STREAM_RECORD_BYTES",
    "Figures",
    "check_grid",
    "check_record",
    "check_record_periods",
    "streams_record",
    "check_rig",
    "check_harmonics",
    "check_measure_periods",
    "check_steps_per_period",
    "check_stability_limit",
    "check_steps",
    "check_band",
    "check_random_memory",
    "check_random_stability",
    "check_random_steps",
    "random_bytes",
    "random_force_bound",
    "random_stability_limit",
    "format_size",
    "grid_count",
    "check_scene",
    "require_excitation",
    "load_checked_scene",
    "preflight",
    "rig_source",
]
