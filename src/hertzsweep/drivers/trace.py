"""Time histories at one frequency: reach it on a branch, settle, record, analyse.

The rig's view of one operating point (the paper's Figures 7, 8, 12, 16, 17): the
steady normal force N/F_s over a few periods, its spectrum, and its flights (loss of
contact, ``q < -3/2``, eq. 9).

A stepped-sine sweep lands on the upper branch of a softening resonance when it comes
down from above and on the lower one when it comes up from below, so the frequency is
reached the same way: for ``branch = "upper"`` the scene's grid is walked down from
``sweep.stop`` through every grid frequency above W (one :meth:`Oscillator.dwell`
each, as the down sweep would), for ``"lower"`` up from ``sweep.start`` through every
grid frequency below W; where no grid frequency lies on that side, the walk starts from
rest at W. At W the oscillator dwells as the sweep does (``settle_periods`` or
``"auto"``), then P whole periods are recorded by the same compiled loop that reads the
lock-in, every ``stride``-th step (``stride = steps_per_period / samples_per_period``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..core.ballmodel import BallModel
from ..core.checks import check_record_periods
from ..core.config import Scene
from ..core.model import check_stability
from ..errors import ConfigError, HertzsweepError
from ..kernels import scheme
from ..kernels.ball import BALL_RECORD_COLUMNS
from ..kernels.flights import IN_CONTACT, NORMAL_FORCE, RECORD_COLUMNS, flight_intervals
from .ballmode import spectrum_errors
from .oscillator import Block, Oscillator, Reading, State
from .period import response_periods
from .readings import SCALAR_FIELDS, Readings
from .spectrum import AmplitudeSpectrum, harmonic_orders
from .steady import Dwell, settle_dwell, strategy

Progress = Callable[[int], None]

BRANCHES = ("upper", "lower")
DEFAULT_PERIODS = 8
BALL_DISPLACEMENT = 4  # the ball's q2 and q2' in its model's record (kernels.ball)
GRID_MATCH = 1e-9  # grid frequencies within this of W count as W (the grid is rounded
# to 1e-12; a user's --frequency 0.975 must not dwell at a grid point 0.975 + 1e-13 first)


@dataclass(frozen=True)
class Flights:
    """The flights of every sigma's record, padded to the most flights F of one record.

    Attributes
    ----------
    start, end : float[S, F]
        Every flight's bounds in tau, NaN padded.
    complete : int8[S, F]
        1 for a flight inside the record, 0 for one cut by its start or end, -1 pad.
    """

    start: np.ndarray
    end: np.ndarray
    complete: np.ndarray

    @classmethod
    def padded(cls, intervals: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> Flights:
        """One row per record from its flights' ``start, end, complete``
        (:meth:`FlightLog.intervals`)."""
        shape = (len(intervals), max((start.size for start, _, _ in intervals), default=0))
        flights = cls(
            np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, -1, dtype=np.int8)
        )
        columns = (flights.start, flights.end, flights.complete)
        for s, row in enumerate(intervals):
            for padded, values in zip(columns, row, strict=True):
                padded[s, : values.size] = values
        return flights

    @property
    def count(self) -> np.ndarray:
        """Flights in each sigma's record (complete or cut), int[S]."""
        return np.sum(self.complete >= 0, axis=-1)


@dataclass
class TraceResult(Readings):
    """Records and their analysis for every sigma at one frequency ratio.

    Times are in tau from the first recorded sample (excitation phase 0, so the input
    is ``sigma sin(w tau)``); the dataset layer adds seconds with the rig's Omega.

    Attributes
    ----------
    record : float[S, M, 4] or None
        ``q, q', N/F_s, in contact`` (1.0/0.0) every ``sample_step`` in tau; None when
        it was streamed to a :class:`RecordSink`.
    spectrum : float[S, M/2 + 1]
        Single-sided amplitude spectrum of N/F_s on :attr:`harmonic_order`.
    amplitude, phase : float[S, K]
        The lock-in's harmonics over the recorded periods (every step).
    force_max, force_min, contact_loss_fraction, mean_force : float[S]
        Over every integration step of the recorded periods.
    flight_tau : float[S]
        Longest flight (see :func:`longest_flight`).
    flights : Flights
        Every flight of each record.
    settled : bool[S]
        The dwell at W met the scene's settling criterion.
    periodic : bool[S]
        The recorded state repeats after one period.
    response_period : int8[S]
        After how many periods the state at the end of the record returns (1 where
        ``periodic``, 0 for none within 8: :func:`.period.response_periods`).
    approach : float[A]
        The grid frequencies dwelt at before W, in order (empty: from rest at W).
    ball_mode_error : float[S] or None
        The figure e of :mod:`hertzsweep.core.ballmode` from each spectrum (None where the
        rig has no ball; NaN where the record does not repeat every period).
    """

    frequency_ratio: float
    branch: str
    periods: int
    samples_per_period: int
    stride: int
    sample_step: float
    sigma: np.ndarray
    harmonics: np.ndarray
    record: np.ndarray | None
    spectrum: np.ndarray
    flights: Flights
    settled: np.ndarray
    periodic: np.ndarray
    approach: np.ndarray
    spectrum_backend: str
    steps: int = 0
    ball_mode_error: np.ndarray | None = None
    record_columns: int = RECORD_COLUMNS  # the ball model's record has more
    extra: dict[str, np.ndarray] = field(default_factory=dict)  # the ball model's readings
    response_period: np.ndarray | None = None

    @property
    def samples(self) -> int:
        """Samples M of each sigma's record."""
        return self.periods * self.samples_per_period

    @property
    def tau(self) -> np.ndarray:
        """tau of each sample, from 0."""
        return np.arange(self.samples) * self.sample_step

    @property
    def harmonic_order(self) -> np.ndarray:
        """The frequency of each line of :attr:`spectrum` over the excitation's,
        float[M/2 + 1]."""
        return harmonic_orders(self.samples, self.periods)


# --------------------------------------------------------------------------- checks
def resolve_samples_per_period(scene: Scene, samples_per_period: int | None) -> int:
    """The samples per period to record: default every step; otherwise a divisor of
    ``solver.steps_per_period`` (a ConfigError naming ``--samples-per-period``)."""
    steps = scene.solver.steps_per_period
    if samples_per_period is None:
        return steps
    if (
        isinstance(samples_per_period, bool)
        or not isinstance(samples_per_period, int | np.integer)
        or samples_per_period < 1
        or steps % samples_per_period
    ):
        raise ConfigError(
            "trace",
            "--samples-per-period",
            f"must be a divisor of solver.steps_per_period = {steps} "
            f"(e.g. {steps}, {steps // 2}), got {samples_per_period!r}",
        )
    return int(samples_per_period)


MAX_FREQUENCY_RATIO = 1e3  # a thousand times f0: far above the ball's own mode (about
# 25 f0), where this model means nothing, and far below where the step 2 pi / (w N)
# would underflow the scheme's constants (h^2 below the smallest float near w = 1e150)


def check_trace(frequency_ratio: float, periods: int, branch: str) -> None:
    """Refuse a frequency that is not a positive ratio up to :data:`MAX_FREQUENCY_RATIO`,
    fewer than one period or an unknown branch."""
    w = float(frequency_ratio)
    if not np.isfinite(w) or w <= 0.0 or w > MAX_FREQUENCY_RATIO:
        raise ConfigError(
            "trace",
            "--frequency",
            f"must be a frequency ratio w = f/f0 in (0, {MAX_FREQUENCY_RATIO:g}], got {w:g}",
        )
    if isinstance(periods, bool) or not isinstance(periods, int | np.integer) or periods < 1:
        raise ConfigError("trace", "--periods", f"must be a whole number >= 1, got {periods!r}")
    if branch not in BRANCHES:
        raise ConfigError("trace", "--branch", f"expected 'upper' or 'lower', got {branch!r}")


# --------------------------------------------------------------------------- reaching W
def approach_path(frequency_ratios: np.ndarray, frequency_ratio: float, branch: str) -> np.ndarray:
    """The grid frequencies a sweep visits before W on the given branch, in order:
    down from the top through those above W (``"upper"``), or up from the bottom
    through those below W (``"lower"``). Empty where W lies beyond the starting end."""
    grid = np.sort(np.asarray(frequency_ratios, dtype=float))
    if branch == "upper":
        return grid[grid > frequency_ratio + GRID_MATCH][::-1]
    return grid[grid < frequency_ratio - GRID_MATCH]


def reach(
    oscillator: Oscillator,
    frequency_ratio: float,
    path: np.ndarray,
    dwell: Dwell = settle_dwell,
    progress: Progress | None = None,
) -> tuple[State, bool]:
    """Walk ``path`` dwell by dwell, then dwell at W. Returns the state at W (at a
    period boundary, excitation phase 0) and whether the dwell at W settled."""
    state = oscillator.initial(path[0] if path.size else frequency_ratio)
    for w in path:
        state, _, _ = dwell(oscillator, state, float(w))
        if progress is not None:
            progress(1)
    state, _, settled = dwell(oscillator, state, frequency_ratio)
    if progress is not None:
        progress(1)
    return state, bool(settled)


# --------------------------------------------------------------------------- flights
def longest_flight(start: np.ndarray, end: np.ndarray, complete: np.ndarray, span: float) -> float:
    """The longest flight of a record, in tau.

    The longest complete flight; a record with none uses the sweep's convention for a
    periodic state: the pieces cut by its start and end joined as one flight (the whole
    ``span`` if never in contact), else the longest cut piece; 0 without flights.
    """
    duration = end - start
    if np.any(complete == 1):
        return float(np.max(duration[complete == 1]))
    if duration.size == 0:
        return 0.0
    if duration.size >= 2 and start[0] == 0.0 and end[-1] == span:
        return float(min(duration[0] + duration[-1], span))
    return float(np.max(duration))


# --------------------------------------------------------------------------- recording
CHUNK_SAMPLES = 1 << 16  # samples per sigma recorded per call of the kernel (2 MB of
# record): whole response periods, at least one. The readings of the chunks combine
# (:meth:`~.oscillator.Block.then`), the flights join across them (:class:`FlightLog`).


def chunk_periods(samples_per_period: int, denominator: int = 1) -> int:
    """Whole periods per recorded chunk (:data:`CHUNK_SAMPLES`, at least one): a multiple
    of the lock-in's common denominator L, so that each chunk's reading of an order that
    is not whole is one over whole response periods and the chunks' sums add."""
    periods = max(1, CHUNK_SAMPLES // int(samples_per_period))
    return max(denominator, periods - periods % denominator)


class RecordSink(Protocol):
    """Where a streamed record goes (the output layer's netCDF file): :meth:`open` once
    with the record's shape and spacing, then every chunk in order."""

    def open(
        self, sigma: int, samples: int, chunk: int, sample_step: float, columns: int = 4
    ) -> None:
        """``sigma`` x ``samples`` samples to come, in chunks of ``chunk`` samples (the
        last one may be shorter), ``sample_step`` apart in tau, of ``columns`` columns."""

    def write(self, s: int, first: int, rows: np.ndarray) -> None:
        """Samples ``first .. first + len(rows)`` of sigma ``s`` (float[n, 4])."""


class FlightLog:
    """The flights of a record read chunk by chunk, each chunk with the sample before it
    (:func:`~hertzsweep.kernels.flights.flight_intervals` at its index in the record): the
    bounds and flags of the whole record at once, bit for bit. A flight that runs into
    the next chunk is held until its end is read."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.open: tuple[float, bool] | None = None  # (start, cut by the record's start)
        # of a flight running on into the next chunk

    def add(self, window: np.ndarray, first: int, last: bool) -> None:
        """``window`` = samples ``first ..`` of the record: a chunk, after the first one
        preceded by the previous chunk's last sample; ``last``: the record ends with it."""
        start, end, _ = flight_intervals(window, self.dt, first)
        if start.size == 0:
            return
        start_cut = np.zeros(start.size, dtype=bool)
        end_cut = np.zeros(start.size, dtype=bool)
        start_cut[0] = window[0, IN_CONTACT] == 0.0
        end_cut[-1] = window[-1, IN_CONTACT] == 0.0
        if self.open is not None:  # flight 0 is the one the previous chunk left running
            start[0], start_cut[0] = self.open
            self.open = None
        kept = start.size
        if end_cut[-1] and not last:  # runs into the next chunk
            self.open = (float(start[-1]), bool(start_cut[-1]))
            kept -= 1
        complete = np.where(start_cut | end_cut, 0, 1).astype(np.int8)
        self.pieces.append((start[:kept], end[:kept], complete[:kept]))

    def intervals(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``start, end, complete`` of every flight read (as :func:`flight_intervals`)."""
        if not self.pieces:
            return np.empty(0), np.empty(0), np.empty(0, dtype=np.int8)
        start, end, complete = zip(*self.pieces, strict=True)
        return np.concatenate(start), np.concatenate(end), np.concatenate(complete)


class _Recorder:
    """Records one trace chunk by chunk (:func:`chunk_periods`): into the result's record
    (in memory), or into a chunk buffer handed to a :class:`RecordSink`, with the normal
    force kept for the spectrum. Either way the kernels run the same chunks, so the
    numbers are the same, and each chunk is read by the flights with the sample before
    it."""

    def __init__(
        self,
        sink: RecordSink | None,
        sigma: int,
        analyser: AmplitudeSpectrum,
        per_period: int,
        stride: int,
        columns: tuple[int, Callable[[np.ndarray], np.ndarray]],
        denominator: int = 1,
    ) -> None:
        self.sink = sink
        width, self.flight_view = columns
        self.per_period = per_period
        self.periods = analyser.samples // per_period
        self.stride = stride
        self.chunk = chunk_periods(per_period, denominator)
        self.chunk_samples = min(self.chunk, self.periods) * per_period  # the longest chunk
        self.record = self.force = None
        if sink is None:
            self.record = np.empty((sigma, analyser.samples, width))
        else:  # N/F_s straight into the transform's input: no copy of the record's length
            self.buffer = np.empty((self.chunk_samples + 1, width))
            self.force = analyser.buffer()

    def run(
        self, oscillator: Oscillator, state: State, frequency_ratio: float, s: int, dt: float
    ) -> tuple[State, Reading, FlightLog]:
        """Measure and record sigma ``s``'s periods; the chunks' readings combined as one
        (:meth:`~.oscillator.Block.then`) and their flights (``dt``: sample spacing)."""
        flights = FlightLog(dt)
        block = None
        for p in range(0, self.periods, self.chunk):
            count = min(self.chunk, self.periods - p)
            first = p * self.per_period
            lead = 1 if first > 0 else 0  # the sample before the chunk, after the first
            rows, window = self._rows(s, first, count * self.per_period, lead)
            state, part = oscillator.measure_block(state, frequency_ratio, count, rows, self.stride)
            block = part if block is None else block.then(part)
            flights.add(self.flight_view(window), first - lead, last=p + count == self.periods)
            if self.sink is not None:
                self.sink.write(s, first, rows)
                self.force[first : first + rows.shape[0]] = rows[:, NORMAL_FORCE]
                self.buffer[0] = rows[-1]
        return state, block.at(0), flights

    def _rows(self, s: int, first: int, count: int, lead: int) -> tuple[np.ndarray, np.ndarray]:
        """Where the kernel writes samples ``first .. first + count`` of sigma ``s``, and
        those rows preceded by the ``lead`` (0 or 1) samples before them."""
        if self.record is not None:
            return (
                self.record[s, first : first + count],
                self.record[s, first - lead : first + count],
            )
        return self.buffer[1 : count + 1], self.buffer[1 - lead : count + 1]

    def normal_force(self, s: int) -> np.ndarray:
        """N/F_s of sigma ``s`` over the whole record."""
        return self.force if self.record is None else self.record[s, :, NORMAL_FORCE]


def record_layout(scene: Scene) -> tuple[int, Callable[[np.ndarray], np.ndarray]]:
    """The columns of the scene's record and the view of a chunk its flights are read
    from (:func:`~hertzsweep.kernels.flights.flight_intervals`: ``q, q', N/F_s, in
    contact`` with loss of contact at ``q = -3/2``). The ball model's flights are the
    lower contact's, which the transducer sits under: its compression ``l = 1 + 2 q2 /
    (3 a_l)`` vanishes where ``q2 / a_l = -3/2``, so the view scales the ball's columns."""
    if scene.model.kind == "single":
        return RECORD_COLUMNS, lambda window: window
    lower = BallModel.of(scene).lower

    def lower_contact(window: np.ndarray) -> np.ndarray:
        ball = window[:, BALL_DISPLACEMENT : BALL_DISPLACEMENT + 2] / lower
        return np.column_stack([ball, window[:, NORMAL_FORCE : IN_CONTACT + 1]])

    return BALL_RECORD_COLUMNS, lower_contact


# --------------------------------------------------------------------------- driver
def _settings(
    scene: Scene, frequency_ratio: float, periods: int, branch: str, samples_per_period: int | None
) -> tuple[float, int, int, int, float]:
    """A trace's arguments checked: ``(w, periods, samples_per_period, stride,
    sample_step)``, the stride in steps and the sample step in excitation phase."""
    check_trace(frequency_ratio, periods, branch)
    check_record_periods(scene, periods)
    samples_per_period = resolve_samples_per_period(scene, samples_per_period)
    w = float(frequency_ratio)
    check_stability(scene, lowest=min(w, float(scene.sweep.frequency_ratios.min())))
    stride = scene.solver.steps_per_period // samples_per_period
    sample_step = scheme.step_size(w, scene.solver.steps_per_period) * stride
    return w, int(periods), samples_per_period, stride, sample_step


def run_trace(
    scene: Scene,
    frequency_ratio: float,
    periods: int = DEFAULT_PERIODS,
    branch: str = "upper",
    samples_per_period: int | None = None,
    progress: Progress | None = None,
    sink: RecordSink | None = None,
) -> TraceResult:
    """Settled time histories at one frequency ratio for every sigma of the scene.

    Parameters
    ----------
    scene : Scene
        Rig, damping, sigma levels, the sweep grid and dwell (for reaching W), solver,
        lock-in harmonics.
    frequency_ratio : float
        W = f/f0 [1].
    periods : int
        Whole excitation periods P to record, a multiple of the lock-in's common
        denominator L (whole response periods for orders that are not whole).
    branch : {"upper", "lower"}
        Reach W as a down sweep from ``sweep.stop`` or an up sweep from ``sweep.start``.
    samples_per_period : int, optional
        Samples kept per period, a divisor of ``solver.steps_per_period`` (default: every
        step, so that the spectrum's lines equal the lock-in's).
    progress : callable, optional
        Called with 1 after each dwell.
    sink : RecordSink, optional
        Where the record goes as it is integrated, chunk by chunk (the result then holds
        none); default: in the result.

    Returns
    -------
    TraceResult
        Only the records (``S x P x samples_per_period x 4``, unless streamed to
        ``sink``) and the spectra (``S x (M/2 + 1)``) grow with the record; the
        integration keeps no history. Recorded in chunks of :data:`CHUNK_SAMPLES`, in
        memory or streamed alike: the same numbers either way.

    Raises
    ------
    ConfigError
        Bad frequency, periods (or not a multiple of L), branch or samples per period.
    StabilityError, IntegrationError
        As for a sweep.
    """
    settings = _settings(scene, frequency_ratio, periods, branch, samples_per_period)
    w, periods, samples_per_period, stride, sample_step = settings
    sigma = np.asarray(scene.excitation.sigma, dtype=float)
    harmonics = np.asarray(scene.lockin.harmonics, dtype=np.float64)
    samples = periods * samples_per_period
    path = approach_path(scene.sweep.frequency_ratios, w, branch)
    dwell = strategy(scene).dwell

    analyser = AmplitudeSpectrum(samples)
    columns = record_layout(scene)
    recorder = _Recorder(
        sink, sigma.size, analyser, samples_per_period, stride, columns, scene.lockin.denominator
    )
    if sink is not None:
        sink.open(sigma.size, samples, recorder.chunk_samples, sample_step, columns[0])
    spectrum = np.empty((sigma.size, analyser.bins))
    amplitude = np.empty((sigma.size, harmonics.size))
    phase = np.empty_like(amplitude)
    scalars = {name: np.empty(sigma.size) for name in SCALAR_FIELDS}
    settled = np.zeros(sigma.size, dtype=bool)
    periodic = np.zeros(sigma.size, dtype=bool)
    period = np.zeros(sigma.size, dtype=np.int8)
    intervals = []
    extra: dict[str, np.ndarray] = {}
    steps = 0
    for s, level in enumerate(sigma):
        oscillator = Oscillator(scene, level)
        try:
            state, settled[s] = reach(oscillator, w, path, dwell, progress)
            state, reading, log = recorder.run(oscillator, state, w, s, sample_step)
        except HertzsweepError as exc:
            raise exc.with_context(f"{scene.source}: trace at w = {w:g}") from None
        steps += oscillator.steps
        analyser.amplitude(recorder.normal_force(s), offset=1.0, out=spectrum[s])
        amplitude[s], phase[s] = reading.amplitude, reading.phase
        for name in SCALAR_FIELDS:  # flight_tau: from the interpolated flights, below
            scalars[name][s] = getattr(reading, name)
        periodic[s] = reading.periodic
        block = Block.of(reading, state)
        period[s] = response_periods(oscillator, block, np.array([level]), np.array([state.h]))[0]
        for name, value in reading.extra.items():
            extra.setdefault(name, np.full(sigma.size, np.nan))[s] = value
        intervals.append(log.intervals())
        scalars["flight_tau"][s] = longest_flight(*intervals[-1], samples * sample_step)

    return TraceResult(
        ball_mode_error=spectrum_errors(scene, w, spectrum, periodic, samples, periods),
        frequency_ratio=w,
        branch=branch,
        periods=periods,
        samples_per_period=samples_per_period,
        stride=stride,
        sample_step=sample_step,
        sigma=sigma,
        harmonics=harmonics,
        record=recorder.record,
        spectrum=spectrum,
        amplitude=amplitude,
        phase=phase,
        flights=Flights.padded(intervals),
        settled=settled,
        periodic=periodic,
        response_period=period,
        approach=path,
        spectrum_backend=analyser.backend,
        steps=steps,
        record_columns=columns[0],
        extra=extra,
        **scalars,
    )


def trace_count(scene: Scene, frequency_ratio: float, branch: str) -> int:
    """Number of dwells a trace runs (for progress bars)."""
    path = approach_path(scene.sweep.frequency_ratios, frequency_ratio, branch)
    return len(scene.excitation.sigma) * (path.size + 1)


__all__ = [
    "BRANCHES",
    "CHUNK_SAMPLES",
    "FlightLog",
    "Flights",
    "RecordSink",
    "TraceResult",
    "approach_path",
    "flight_intervals",
    "longest_flight",
    "reach",
    "run_trace",
    "trace_count",
]
