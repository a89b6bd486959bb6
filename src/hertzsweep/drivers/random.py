"""Random excitation (the paper's Part 2): spectra and statistics of N/F_s.

Every (rms level, realisation) pair is a trajectory; all of them advance together in one
compiled loop (:mod:`hertzsweep.kernels.random`, trajectory index innermost, the level
outer and the realisation inner), from rest at the static equilibrium, under their
realisation's forcing ``f = rms g`` (:func:`~hertzsweep.core.excitation.unit_forcing`). The
kernel is the scene's model's and method's (:data:`~hertzsweep.kernels.random.KERNELS`):
the single model with the central difference or rk4 (its crossings located and
corrected), the ball model with the central difference (N/F_s the lower contact's force,
and the share of time both its contacts are open, ``ball_flight_fraction``). The
record is integrated segment by segment of ``segment_periods`` periods: the transient's
segments are discarded; each measured one adds to the running tallies (moments, extremes,
contact loss, flights, histogram) and, when whole, to the Welch sums of its trajectory, so
that neither the buffers nor the statistics grow with ``duration_periods``; the forcing
table does (a float a sample and realisation, at the steps and for rk4 the half steps
too: each realisation's process made phase by phase, an inverse FFT a phase,
:data:`~hertzsweep.core.checks.FORCING_GROUP` realisations together, in
:data:`~hertzsweep.core.checks.FORCING_THREADS` threads, :func:`forcing_table`). The
first ``trace_periods`` measured periods of realisation 0 of every level are kept as they
were recorded (N/F_s and f at the steps).

Welch: each whole measured segment of N/F_s and of f, its mean removed, times a periodic
Hann window, one real FFT each (:class:`Welch`: FFTW when pyfftw is installed, else numpy;
a trajectory's alone, so that its spectra do not depend on how many trajectories run; f's
once a realisation, shared by the levels); the segments are contiguous (no overlap). The
one-sided PSD per unit w is ``h |X_k|^2 / (pi sum w_n^2)`` at ``w_k = k / segment_periods``
(h = 2 pi / N in tau, in which w is the circular frequency), so that the PSD summed over
every bin times ``1 / segment_periods`` is the windowed segment's mean square
(Parseval). The FRF is the H1 estimate ``S_fN / S_ff``, the coherence
``|S_fN|^2 / (S_ff S_NN)`` (1 identically for a realisation of one segment).

Every statistic is formed per realisation, then averaged over the realisations, with the
standard error ``std(ddof=1) / sqrt(R)`` (NaN for R = 1, or where fewer than two
realisations have a value, e.g. the mean flight of realisations without flights).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.checks import FORCING_GROUP, FORCING_THREADS
from ..core.config import Scene
from ..core.excitation import Phases, linear_response_variance, transmissibility
from ..core.rig import derive
from ..errors import HertzsweepError, Interrupted
from ..kernels import random as kernels
from ..kernels import scheme
from ..kernels import welch as welch_kernels
from ..kernels.stop import REQUEST
from . import spectrum
from .oscillator import model_law

Progress = Callable[[int], None]

PDF_SPAN = 10.0  # the histogram of N/F_s reaches 1 + this many linear RMS of the largest
# level: beyond the largest peaks of the Gaussian linear response (10 sigma: 1.5e-23 a
# sample) and of the softened, impacting response at frequent loss of contact (about 4
# linear RMS at rms 0.15 and 0.3 on the paper's rig).
SCALARS = (  # per level: the statistics of N/F_s and of the flights
    "force_mean",
    "force_rms",
    "force_skewness",
    "force_kurtosis",
    "force_max",
    "force_min",
    "contact_loss_fraction",
    "flight_rate",
    "flight_time_mean",
    "flight_time_max",
    "peak_frequency_ratio",
)
SPECTRA = ("psd", "excitation_psd", "frf_amplitude", "frf_phase", "coherence")  # per bin
STATISTICS = SPECTRA + ("force_pdf",) + SCALARS  # every statistic, each with its stderr
BALL_STATISTICS = ("ball_flight_fraction",)  # the ball model's own, per level
WELCH_BLOCK = 32  # trajectories windowed, transformed and summed at a time: their rows
# (S + 2 floats each, 4 MiB in all at S = 16384) are written by one pass over the
# segment's columns (fewer passes over a wide segment than with blocks of 8, measured)


@dataclass(frozen=True)
class RandomResult:
    """The statistics of a random run, per rms level.

    Attributes
    ----------
    rms : float[L]
        The levels (RMS of f = F/F_s).
    band : (float, float)
        The forcing's band of frequency ratios.
    frequency_ratio : float[K]
        The Welch bins inside (0, Nyquist): ``k / segment_periods``, k = 1 .. S/2 - 1.
    force_bin : float[B]
        The centres of the histogram's bins of N/F_s (``force_pdf``).
    mean, stderr : dict of str to array
        Each of :data:`STATISTICS`: its mean over the realisations and the standard error
        of that mean; float[L] for :data:`SCALARS`, float[L, K] for :data:`SPECTRA`,
        float[L, B] for ``force_pdf``. Flights in seconds (``flight_rate`` per second).
    per_realisation : dict of str to array
        The same per realisation (a realisation axis R after the level's).
    realisations : int
        R.
    segments : int
        Whole measured Welch segments averaged in every realisation's spectra.
    measured_periods : int
        Periods tallied in every realisation's statistics (short of ``duration_periods``
        when the run was interrupted).
    complete : bool
        The whole record was integrated (False: interrupted, the statistics are those of
        the measured segments finished).
    steps : int
        Integration steps of all the trajectories.
    trace_force, trace_forcing : float[L, M]
        The first ``M = trace_periods N`` measured steps of realisation 0 of every level:
        N/F_s as recorded (``1 + N/F_s - 1``) and the input f = F/F_s at those steps (NaN
        past an interrupted run's last step); M = 0 without a trace.
    trace_tau : float[M]
        Their tau from the first measured step (``j h``).
    sums : Sums, optional
        What the statistics were formed from (every trajectory's tallies and Welch sums):
        :func:`merge` joins those of runs of consecutive realisations into one run's.
    """

    rms: np.ndarray
    band: tuple[float, float]
    frequency_ratio: np.ndarray
    force_bin: np.ndarray
    mean: dict[str, np.ndarray]
    stderr: dict[str, np.ndarray]
    per_realisation: dict[str, np.ndarray]
    realisations: int
    segments: int
    measured_periods: int
    complete: bool
    steps: int
    trace_force: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    trace_forcing: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    trace_tau: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sums: Sums | None = field(default=None, repr=False, compare=False)


# --------------------------------------------------------------------------- the plan
@dataclass(frozen=True)
class Plan:
    """The numbers of a random run (from its scene): the trajectories, the step, the
    segments, the histogram, the forcing's samples a step (2 for rk4's half steps) and
    the trace's steps."""

    rms: np.ndarray
    band: tuple[float, float]
    realisations: int
    steps_per_period: int
    segment_steps: int
    transient_steps: int
    measured_steps: int
    bins: int
    pdf_high: float
    seed: int
    per_step: int = 1
    trace_steps: int = 0
    first_realisation: int = 0

    @classmethod
    def of(cls, scene: Scene) -> Plan:
        n = int(scene.solver.steps_per_period)
        rms = np.asarray(scene.excitation.rms, dtype=float)
        band = (float(scene.excitation.band[0]), float(scene.excitation.band[1]))
        linear = float(rms.max()) * math.sqrt(linear_response_variance(band, scene.damping.ratio))
        run = scene.random
        return cls(
            rms=rms,
            band=band,
            realisations=int(run.realisations),
            steps_per_period=n,
            segment_steps=int(run.segment_periods) * n,
            transient_steps=int(run.transient_periods) * n,
            measured_steps=int(run.duration_periods) * n,
            bins=int(run.force_bins),
            pdf_high=1.0 + PDF_SPAN * linear,
            seed=int(scene.excitation.seed),
            per_step=kernel(scene).per_step,
            trace_steps=int(run.trace_periods) * n,
            first_realisation=int(run.first_realisation),
        )

    def drive(self) -> kernels.RandomDrive:
        """The :class:`~hertzsweep.kernels.random.RandomDrive` of the run's trajectories:
        the levels outer, the realisations inner (the kernels' order)."""
        level = np.repeat(self.rms, self.realisations)
        realisation = np.tile(np.arange(self.realisations), self.rms.size)
        return kernels.inputs(level, realisation, self.steps_per_period)

    @property
    def trajectories(self) -> int:
        return self.rms.size * self.realisations

    @property
    def h(self) -> float:
        return 2.0 * math.pi / self.steps_per_period

    @property
    def periods(self) -> int:
        """The record's periods P (transient and measured)."""
        return (self.transient_steps + self.measured_steps) // self.steps_per_period

    def chunks(self) -> list[tuple[int, int, bool]]:
        """``(first step, steps, measured)`` of every segment in order: the transient's
        (its last one shorter when it is no whole number of segments), then the measured
        ones (the last, shorter, is tallied but not in the Welch sums)."""
        out = []
        for start, length, measured in (
            (0, self.transient_steps, False),
            (self.transient_steps, self.measured_steps, True),
        ):
            for first in range(0, length, self.segment_steps):
                out.append((start + first, min(self.segment_steps, length - first), measured))
        return out


def step_count(scene: Scene) -> int:
    """The integration steps of a random run, every trajectory's (transient and
    measured): the length of a progress bar (:func:`run_random` reports each segment's)."""
    plan = Plan.of(scene)
    return plan.trajectories * (plan.transient_steps + plan.measured_steps)


def kernel(scene: Scene) -> kernels.Kernel:
    """The random kernels of the scene's ``model.kind`` and ``solver.method``
    (:data:`~hertzsweep.kernels.random.KERNELS`).

    Raises
    ------
    HertzsweepError
        A model and method with no random kernel (the ball model with rk4, which a
        scene refuses when loaded).
    """
    found = kernels.KERNELS.get((scene.model.kind, scene.solver.method))
    if found is None:
        raise HertzsweepError(
            f"{scene.source}: random excitation has no kernel for model.kind = "
            f"{scene.model.kind!r} with solver.method = {scene.solver.method!r}"
        )
    return found


def forcing_table(plan: Plan) -> np.ndarray:
    """The unit forcing of every realisation at every sample of the record:
    float[m L (+1), R] for L steps and m = ``plan.per_step`` samples a step (C order: a
    sample's row holds every realisation). With m > 1 a last row repeats the first: the
    process's period is the record, so the end of the last step is its start again.

    The run's realisation r is the process's realisation ``first_realisation + r``
    (``random.first_realisation``), each that of
    :func:`~hertzsweep.core.excitation.unit_forcing`. The realisations are made
    :data:`~hertzsweep.core.checks.FORCING_GROUP` at a time, phase by phase
    (:class:`~hertzsweep.core.excitation.Phases`): a phase of every realisation of the
    group, :data:`~hertzsweep.core.checks.FORCING_THREADS` at once in threads (numpy's FFT
    releases the GIL), then copied into its rows, the group's realisations side by side.
    Each realisation's samples are those of one made alone, bit for bit."""
    m = plan.per_step
    length = m * plan.periods * plan.steps_per_period
    table = np.empty((length + (m > 1), plan.realisations))
    workers = min(FORCING_THREADS, os.cpu_count() or 1, plan.realisations)
    pool = ThreadPoolExecutor(workers, thread_name_prefix="hertzsweep-forcing")

    def each(task: Callable[[int], Any], count: int) -> list[Any]:
        """``task(0 .. count - 1)`` in the threads, in order."""
        return list(pool.map(task, range(count)))

    try:
        for first in range(0, plan.realisations, FORCING_GROUP):
            group = table[:length, first : first + FORCING_GROUP]
            _forcing_group(plan, first, group, each, workers)
    finally:  # on an interrupt, the phases not begun are not made
        pool.shutdown(wait=True, cancel_futures=True)
    if m > 1:
        table[length] = table[0]
    return table


def _forcing_group(
    plan: Plan,
    first: int,
    group: np.ndarray,
    each: Callable[[Callable[[int], Any], int], list[Any]],
    parts: int,
) -> None:
    """The forcing of the run's realisations ``first ..`` into ``group`` (the table's
    columns of them, float[m L, count]), phase by phase: each phase's samples of every
    realisation by ``each`` (in threads), then copied into the phase's rows in ``parts``
    slices, also by ``each``."""
    count = group.shape[1]
    made = each(
        lambda j: Phases(
            plan.seed,
            plan.first_realisation + first + j,  # the run's realisation first + j
            plan.band,
            plan.periods,
            plan.steps_per_period,
            plan.per_step,
        ),
        count,
    )
    phases = made[0].phases
    rows = np.empty((count, made[0].size))
    cuts = np.linspace(0, made[0].count, parts + 1).astype(int)
    for phase in range(phases):
        into = group[phase::phases]
        each(lambda j, phase=phase: made[j].samples(phase, rows[j]), count)
        each(lambda p, into=into: _copy_rows(into, rows, cuts[p], cuts[p + 1]), parts)


def _copy_rows(into: np.ndarray, rows: np.ndarray, start: int, stop: int) -> None:
    """``into[start:stop] = rows[:, start:stop].T``: a phase's samples of a group of
    realisations (a row each) into its rows of the table (a column each)."""
    into[start:stop] = rows[:, start:stop].T


# --------------------------------------------------------------------------- the run
class Welch:
    """The Welch sums of T trajectories over whole segments of S steps: ``S_NN``,
    ``S_ff``, ``S_fN`` on the bins k = 1 .. S/2 - 1, unscaled, float[T, K] (complex for
    ``fn``).

    Each column of a segment (a trajectory's N/F_s - 1, a realisation's g) is windowed
    into a row of one buffer (:func:`~hertzsweep.kernels.welch.windowed`) and transformed
    alone (:class:`~.spectrum.RealRows`: FFTW when pyfftw is installed, else numpy.fft),
    so that a trajectory's spectrum is the same bit for bit whatever the number of
    trajectories. The forcing's spectrum is formed once a realisation and segment, in the
    buffer's first R rows, and shared by every level; the trajectories follow,
    :data:`WELCH_BLOCK` at a time, in the rows after them
    (:func:`~hertzsweep.kernels.welch.add_spectra`)."""

    def __init__(self, plan: Plan, backend: str | None = None) -> None:
        s = plan.segment_steps
        self.window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(s) / s)  # periodic Hann
        self.bins = slice(1, s // 2)  # inside (0, Nyquist)
        shape = (plan.trajectories, s // 2 - 1)
        self.nn = np.zeros(shape)
        self.ff = np.zeros(shape)
        self.fn = np.zeros(shape, dtype=complex)
        self.segments = 0
        # one-sided, per unit w: 2 (one side) h / (2 pi sum w^2) times |X|^2
        self.scale = plan.h / (math.pi * float(np.sum(self.window**2)))
        self._realisations = plan.realisations
        self._block = min(WELCH_BLOCK, plan.trajectories)
        self._rows = spectrum.RealRows(plan.realisations + self._block, s, backend)
        self._means = np.zeros(max(plan.trajectories, plan.realisations))

    def add(self, excess: np.ndarray, g: np.ndarray, drive: kernels.RandomDrive) -> None:
        """One segment: ``excess`` float[S, T] (N/F_s - 1), ``g`` float[S, R]."""
        rows, window, realisations = self._rows, self.window, self._realisations
        steps, trajectories = self.window.size, self.nn.shape[0]
        if excess.shape != (steps, trajectories) or g.shape != (steps, realisations):
            raise ValueError(
                f"expected excess float[{steps}, {trajectories}] and g float[{steps}, "
                f"{realisations}], got {list(excess.shape)} and {list(g.shape)}"
            )
        welch_kernels.column_means(g, self._means[:realisations])
        for first in range(0, realisations, self._block):
            width = min(self._block, realisations - first)
            welch_kernels.windowed(g, (first, width), self._means, window, rows.samples[first:])
        rows.transform(0, realisations)
        force, response = rows.spectra[:realisations], rows.spectra[realisations:]
        sums = (self.nn, self.ff, self.fn)
        welch_kernels.column_means(excess, self._means[:trajectories])
        for first in range(0, trajectories, self._block):
            width = min(self._block, trajectories - first)
            welch_kernels.windowed(
                excess, (first, width), self._means, window, rows.samples[realisations:]
            )
            rows.transform(realisations, realisations + width)
            welch_kernels.add_spectra(response, force, drive, (first, width), sums)
        self.segments += 1


class Trace:
    """The first ``plan.trace_steps`` measured steps of realisation 0 of every level:
    N/F_s and f, float[L, M] each (NaN until recorded)."""

    def __init__(self, plan: Plan) -> None:
        shape = (plan.rms.size, plan.trace_steps)
        self.force = np.full(shape, np.nan)
        self.forcing = np.full(shape, np.nan)
        self.columns = np.arange(plan.rms.size) * plan.realisations  # realisation 0's
        self.filled = 0

    def add(self, excess: np.ndarray, g: np.ndarray, drive: kernels.RandomDrive) -> None:
        """A measured segment's first steps while the trace is not full: ``excess``
        float[S, T] (N/F_s - 1), ``g`` float[S, R] at the steps."""
        count = min(excess.shape[0], self.force.shape[1] - self.filled)
        if count <= 0:
            return
        part = slice(self.filled, self.filled + count)
        self.force[:, part] = 1.0 + excess[:count, self.columns].T
        level = drive.level[self.columns]
        self.forcing[:, part] = level[:, None] * g[:count, 0][None, :]
        self.filled += count


@dataclass
class Sums:
    """What a run accumulates: the kernels' tallies, the Welch sums, the trace, the
    integration steps taken (every trajectory's) and, for the ball model, the measured
    steps with both contacts open (float[T]); kept when the run is interrupted. A result
    keeps them as plain arrays (:class:`WelchSums`, :class:`TraceRows`)."""

    tally: kernels.Tally
    welch: Welch | WelchSums
    trace: Trace | TraceRows
    steps: int = 0
    ball_flight: np.ndarray | None = None


def run_random(scene: Scene, progress: Progress | None = None) -> RandomResult:
    """The random run of a scene (``excitation.kind = "random"``): the single model with
    the central difference or rk4, or the ball model with the central difference.

    Parameters
    ----------
    scene : Scene
    progress : callable, optional
        Called after each segment with the integration steps it took, every trajectory's
        (:func:`step_count` in all).

    Returns
    -------
    RandomResult

    Raises
    ------
    Interrupted
        On SIGINT (or SIGTERM where the CLI maps it) between segments, or a stop request
        inside one, with the statistics of the measured segments finished as ``partial``
        (``complete`` False).
    StabilityError
        The compression reached passes the step's stability limit.
    IntegrationError
        The state became non-finite.
    HertzsweepError
        A model and method with no random kernel (:func:`kernel`).
    """
    plan = Plan.of(scene)
    sums = Sums(
        kernels.new_tally(plan.trajectories, plan.bins, 0.0, plan.pdf_high / plan.bins),
        Welch(plan),
        Trace(plan),
        ball_flight=np.zeros(plan.trajectories) if scene.model.kind == "ball" else None,
    )
    try:
        _integrate(plan, model_law(scene), sums, progress, scene)
    except KeyboardInterrupt as exc:
        partial = _result(plan, scene, sums, complete=False)
        raise Interrupted(partial, getattr(exc, "signal_number", 2)) from None
    return _result(plan, scene, sums, complete=True)


def _integrate(plan: Plan, law: Any, sums: Sums, progress: Progress | None, scene: Scene) -> None:
    """Every segment of the record (:meth:`Plan.chunks`), the measured ones into ``sums``;
    the forcing table and the segment's buffers are freed on return, before the
    statistics are formed."""
    scheme_of = kernel(scene)
    m = plan.per_step
    table = forcing_table(plan)
    at_steps = table[::m]  # the samples at the steps (a view)
    drive = plan.drive()
    state = scheme_of.at_rest(drive, table, plan.h, law)
    record = scheme_of.new_record(plan.segment_steps, plan.trajectories)
    for first, length, measured in plan.chunks():
        part = type(record)(*(buffer[:length] for buffer in record))
        tally = sums.tally if measured else None
        status, bad = step_segment(
            scheme_of, law, plan.h, (state, drive), table[m * first :], part, tally
        )
        if status != scheme.OK:
            _raise(status, bad, plan, scene)
        sums.steps += length * plan.trajectories
        if measured:
            forcing = at_steps[first : first + length]
            sums.trace.add(part.excess, forcing, drive)
            if sums.ball_flight is not None:
                sums.ball_flight += np.count_nonzero(part.flight, axis=0)
            if length == plan.segment_steps:
                sums.welch.add(part.excess, forcing, drive)
        if progress is not None:
            progress(length * plan.trajectories)


def step_segment(
    scheme_of: kernels.Kernel,
    law: Any,
    h: float,
    trajectories: tuple[np.ndarray, kernels.RandomDrive],
    g: np.ndarray,
    part: Any,
    tally: kernels.Tally | None,
) -> tuple[int, int]:
    """One segment of the record with the scene's kernels (``trajectories = (state,
    drive)``, ``part`` the segment's record): measured (``tally`` given) it is stepped,
    recorded and tallied, in one pass where the kernels have ``measure``, else by
    ``advance`` then :func:`~hertzsweep.kernels.random.accumulate`; a transient (None) is
    stepped, unrecorded where the kernels have ``settle``. Returns the kernel's
    ``(status, trajectory)`` (the tallies unchanged unless OK)."""
    state, drive = trajectories
    if tally is not None and scheme_of.measure is not None:
        return scheme_of.measure(law, h, state, drive, g, part, tally)
    if tally is None and scheme_of.settle is not None:
        return scheme_of.settle(law, h, state, drive, g, part.excess.shape[0])
    status, bad = scheme_of.advance(law, h, state, drive, g, part)
    if tally is not None and status == scheme.OK:
        kernels.accumulate(part, tally)
    return status, bad


def _raise(status: int, bad: int, plan: Plan, scene: Scene) -> None:
    """The error a kernel status means for trajectory ``bad`` (a KeyboardInterrupt for a
    stop request, which :func:`run_random` turns into Interrupted)."""
    if status == scheme.STOPPED:
        interrupt = KeyboardInterrupt()
        interrupt.signal_number = int(REQUEST[0]) or 2  # SIGINT when not known
        raise interrupt
    level, realisation = divmod(bad, plan.realisations)
    where = f"rms = {plan.rms[level]:g}, realisation {plan.first_realisation + realisation}"
    error, _ = scheme.STATUS[status]
    if status == scheme.UNSTABLE:
        raise error(
            f"{scene.source}: solver.steps_per_period: {plan.steps_per_period} is beyond the "
            f"stability limit at the compression reached ({where}); raise it"
        )
    raise error(f"{scene.source}: the state became non-finite at {where}")


# --------------------------------------------------------------------------- statistics
def _moments(sums: np.ndarray) -> dict[str, np.ndarray]:
    """Mean, RMS about the mean, skewness and kurtosis (3 for a Gaussian) of N/F_s from
    the sums of ``x = N/F_s - 1`` and its powers (float[FIELDS, T])."""
    f = kernels.TALLY_FIELDS
    count = sums[f.index("count")]
    m1, m2, m3, m4 = (sums[f.index(f"sum{p}")] / count for p in (1, 2, 3, 4))
    variance = m2 - m1 * m1
    third = m3 - 3.0 * m1 * m2 + 2.0 * m1**3
    fourth = m4 - 4.0 * m1 * m3 + 6.0 * m1 * m1 * m2 - 3.0 * m1**4
    return {
        "force_mean": 1.0 + m1,
        "force_rms": np.sqrt(variance),
        "force_skewness": third / variance**1.5,
        "force_kurtosis": fourth / (variance * variance),
    }


def _flights(sums: np.ndarray, seconds_per_step: float) -> dict[str, np.ndarray]:
    """Contact loss and flights (seconds) from the tallies; a flight in progress at the
    record's end counts for the longest, not for the mean (its end is unknown)."""
    row = dict(zip(kernels.TALLY_FIELDS, sums, strict=True))
    count = row["count"]
    longest = np.maximum(row["flight_longest"], row["run"])
    return {
        "force_max": 1.0 + row["maximum"],
        "force_min": 1.0 + row["minimum"],
        "contact_loss_fraction": row["loss"] / count,
        "flight_rate": row["lift_offs"] / (count * seconds_per_step),
        "flight_time_mean": row["flight_total"] / row["landings"] * seconds_per_step,
        "flight_time_max": longest * seconds_per_step,
    }


def _spectra(welch: Welch, plan: Plan, w: np.ndarray) -> dict[str, np.ndarray]:
    """PSDs, FRF and coherence, float[K, T], and the peak of each PSD on the band,
    float[T] (all NaN before a whole measured segment). The FRF's lag [degree] of each
    realisation lies within 180 degrees of the lag in [0, 360) of its level's FRF pooled
    over the realisations, so that the lags average across the wrap."""
    if welch.segments == 0:
        nothing = np.full(welch.nn.T.shape, np.nan)
        out = {name: nothing for name in SPECTRA}
        out["peak_frequency_ratio"] = np.full(plan.trajectories, np.nan)
        return out
    nn, ff, fn = (welch.scale * s.T / welch.segments for s in (welch.nn, welch.ff, welch.fn))
    frf = fn / ff
    pooled = _by_level(fn, plan).sum(axis=-1) / _by_level(ff, plan).sum(axis=-1)  # [K, L]
    reference = np.repeat(np.degrees(-np.angle(pooled)) % 360.0, plan.realisations, axis=1)
    lag = reference + np.degrees(np.angle(np.exp(-1j * (np.angle(frf) + np.radians(reference)))))
    inside = (w >= plan.band[0]) & (w < plan.band[1])
    peak = w[inside][np.argmax(nn[inside], axis=0)] if inside.any() else np.nan
    return {
        "psd": nn,
        "excitation_psd": ff,
        "frf_amplitude": np.abs(frf),
        "frf_phase": lag,
        "coherence": (fn.real**2 + fn.imag**2) / (ff * nn),
        "peak_frequency_ratio": np.broadcast_to(peak, (plan.trajectories,)),
    }


def _by_level(values: np.ndarray, plan: Plan) -> np.ndarray:
    """float[..., T] as float[..., L, R]."""
    return values.reshape(values.shape[:-1] + (plan.rms.size, plan.realisations))


def ensemble(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mean over the realisation axis (1) of the finite values and its standard
    error ``std(ddof=1) / sqrt(n)``; NaN where fewer than one (mean) or two (error) of
    them are finite."""
    finite = np.isfinite(values)
    n = finite.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(finite, values, 0.0).sum(axis=1) / n
        deviation = np.where(finite, values - np.expand_dims(mean, 1), 0.0)
        variance = (deviation**2).sum(axis=1) / (n - 1)
        stderr = np.where(n > 1, np.sqrt(variance / n), np.nan)
    return np.where(n > 0, mean, np.nan), stderr


def _result(plan: Plan, scene: Scene, sums: Sums, complete: bool) -> RandomResult:
    """The :class:`RandomResult` of the sums so far."""
    tally, welch = sums.tally, sums.welch
    omega = derive(scene.rig).natural_circular_frequency
    s = plan.segment_steps
    w = np.arange(1, s // 2) / (s // plan.steps_per_period)  # k / segment_periods
    width = plan.pdf_high / plan.bins
    names = STATISTICS
    with np.errstate(invalid="ignore", divide="ignore"):
        per_trajectory = _moments(tally.sums)
        per_trajectory.update(_flights(tally.sums, plan.h / omega))
        per_trajectory.update(_spectra(welch, plan, w))
        count = tally.sums[kernels.TALLY_FIELDS.index("count")]
        per_trajectory["force_pdf"] = tally.histogram / (count * width)
        if sums.ball_flight is not None:
            per_trajectory["ball_flight_fraction"] = sums.ball_flight / count
            names = STATISTICS + BALL_STATISTICS
    per_realisation: dict[str, np.ndarray] = {}
    mean: dict[str, np.ndarray] = {}
    stderr: dict[str, np.ndarray] = {}
    for name in names:
        values = _by_level(np.asarray(per_trajectory[name], dtype=float), plan)
        values = np.moveaxis(values, 0, -1) if values.ndim == 3 else values  # [L, R, ...]
        per_realisation[name] = values
        mean[name], stderr[name] = ensemble(values)
    counted = int(tally.sums[kernels.TALLY_FIELDS.index("count"), 0])
    return RandomResult(
        rms=plan.rms,
        band=plan.band,
        frequency_ratio=w,
        force_bin=(np.arange(plan.bins) + 0.5) * width,
        mean=mean,
        stderr=stderr,
        per_realisation=per_realisation,
        realisations=plan.realisations,
        segments=welch.segments,
        measured_periods=counted // plan.steps_per_period,
        complete=complete,
        steps=sums.steps,
        trace_force=sums.trace.force,
        trace_forcing=sums.trace.forcing,
        trace_tau=np.arange(plan.trace_steps) * plan.h,
        sums=Sums(  # plain arrays (a Welch's transforms stay behind)
            tally,
            WelchSums(welch.nn, welch.ff, welch.fn, welch.segments, welch.scale),
            TraceRows(sums.trace.force, sums.trace.forcing),
            sums.steps,
            sums.ball_flight,
        ),
    )


@dataclass
class WelchSums:
    """The Welch sums of T trajectories, unscaled (:class:`Welch`'s ``nn``, ``ff``, ``fn``,
    float[T, K], complex for ``fn``), over ``segments`` whole segments, and their scale."""

    nn: np.ndarray
    ff: np.ndarray
    fn: np.ndarray
    segments: int
    scale: float


@dataclass
class TraceRows:
    """A trace's rows (:class:`Trace`'s ``force`` and ``forcing``, float[L, M])."""

    force: np.ndarray
    forcing: np.ndarray


def merge(scene: Scene, groups: Sequence[Sums], complete: bool = True) -> RandomResult:
    """The result of ``scene``'s run from the sums of runs of groups of its realisations:
    those of ``scene`` with ``random.first_realisation`` and ``random.realisations`` set to
    each group's, the groups consecutive and in order from realisation 0 (the scene's
    ``first_realisation``). A realisation's trajectories are their own (its stream, its
    steps, its tallies, its Welch sums alone), so the sums joined trajectory by trajectory
    are those of one run of every realisation, and the statistics are formed from them as
    that run forms them (:func:`_result`): the same numbers, bit for bit. The trace is the
    first group's (realisation 0), the steps add up.

    Raises
    ------
    ValueError
        The groups' realisations are not the scene's, or their levels, bins or measured
        segments differ.
    """
    plan = Plan.of(scene)
    levels = plan.rms.size
    if not groups or levels == 0:
        raise ValueError("no group of realisations to merge")
    counts = [g.tally.sums.shape[-1] // levels for g in groups]
    if sum(counts) != plan.realisations:
        raise ValueError(f"groups of {counts} realisations, not {plan.realisations}")
    if len({g.welch.segments for g in groups}) != 1:
        raise ValueError("groups of realisations of different measured segments")

    def joined(arrays: list[np.ndarray]) -> np.ndarray:
        """[..., T] of each group (level outer) as [..., T] of the whole run."""
        parts = [a.reshape(a.shape[:-1] + (levels, n)) for a, n in zip(arrays, counts, strict=True)]
        whole = np.concatenate(parts, axis=-1)
        return np.ascontiguousarray(whole.reshape(whole.shape[:-2] + (-1,)))

    def rows(arrays: list[np.ndarray]) -> np.ndarray:
        """[T, K] of each group as [T, K] of the whole run."""
        return np.ascontiguousarray(joined([a.T for a in arrays]).T)

    first = groups[0]
    tally = kernels.Tally(
        joined([g.tally.sums for g in groups]),
        joined([g.tally.histogram for g in groups]),
        joined([g.tally.low for g in groups]),
        joined([g.tally.width for g in groups]),
    )
    welch = WelchSums(
        rows([g.welch.nn for g in groups]),
        rows([g.welch.ff for g in groups]),
        rows([g.welch.fn for g in groups]),
        first.welch.segments,
        first.welch.scale,
    )
    flights = [g.ball_flight for g in groups]
    ball_flight = None if any(f is None for f in flights) else joined(flights)
    whole = Sums(tally, welch, first.trace, sum(g.steps for g in groups), ball_flight)
    return _result(plan, scene, whole, complete)


def linear_psd(result: RandomResult, zeta: float) -> np.ndarray:
    """The linear model's PSD of N/F_s at the result's bins, float[L, K]:
    ``|H(w)|^2 S_f`` on the band (``S_f = rms^2 / (w_high - w_low)``), 0 outside it."""
    w = result.frequency_ratio
    low, high = result.band
    flat = np.where((w >= low) & (w < high), 1.0 / (high - low), 0.0)
    power = np.abs(transmissibility(w, zeta)) ** 2 * flat
    return result.rms[:, None] ** 2 * power[None, :]


__all__ = [
    "RandomResult",
    "Sums",
    "kernel",
    "linear_psd",
    "merge",
    "run_random",
    "step_count",
    "step_segment",
]
