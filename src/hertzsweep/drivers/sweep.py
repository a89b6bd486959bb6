"""Stepped-sine sweeps, as on the rig (sections 3.2 and 4 of the paper).

For each sigma and each direction the frequency grid is walked from rest at its first
frequency, carrying the state from one frequency to the next, so that jumps and
hysteresis appear as on the rig. Each dwell is a whole number of periods; the
excitation changes frequency at a period boundary (phase 0), so its phase is continuous.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..core.ballmode import has_ball_mode
from ..core.config import Scene
from ..core.lockin import first_harmonic_index
from ..core.model import check_stability
from ..errors import HertzsweepError, Interrupted
from ..kernels import scheme
from .ballmode import BallModeCheck
from .oscillator import Block, Oscillator, drive, measured_blocks
from .period import response_periods
from .readings import BALL_FIELDS, HARMONIC_FIELDS, READING_FIELDS, SCALAR_FIELDS, Readings
from .steady import strategy

Progress = Callable[[int], None]


@dataclass
class SweepResult(Readings):
    """Arrays on (direction, sigma, frequency_ratio[, harmonic]), grid in ascending order.

    ``flight_tau`` is the longest flight per measured window in tau; the dataset layer
    turns it into seconds with the rig's Omega. ``ball_mode_error``: the figure e of
    :mod:`hertzsweep.core.ballmode` per periodic dwell, where the sweep read it (else
    None), from one more period of each dwell's end state ``end`` (float[..., 2], the
    method's state), all read together once the sweep has run. ``response_period``: after
    how many periods each dwell's state returns (:mod:`.period`; 1 where ``periodic``, 0
    for none within 8), read as each dwell is stored.
    """

    directions: tuple[str, ...]
    sigma: np.ndarray
    frequency_ratio: np.ndarray
    harmonics: np.ndarray
    settled: np.ndarray
    periodic: np.ndarray
    jump_frequency_ratio: np.ndarray
    finished: np.ndarray  # (direction, sigma): that sweep ran to its end
    steps: int = 0
    ball_mode_error: np.ndarray | None = None
    end: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)  # the ball model's readings
    response_period: np.ndarray | None = None  # int8 (direction, sigma, frequency_ratio)
    subharmonic_onset_frequency_ratio: np.ndarray | None = None  # (direction, sigma)
    subharmonic_end_frequency_ratio: np.ndarray | None = None

    @classmethod
    def empty(cls, scene: Scene, ball_mode: bool = False) -> SweepResult:
        directions = scene.sweep.directions
        sigma = np.asarray(scene.excitation.sigma, dtype=float)
        w = scene.sweep.frequency_ratios
        harmonics = np.asarray(scene.lockin.harmonics, dtype=np.float64)
        shape = (len(directions), sigma.size, w.size)

        def nan(*extra: int) -> np.ndarray:
            return np.full(shape + extra, np.nan)

        readings = {name: nan(harmonics.size) for name in HARMONIC_FIELDS}
        readings.update({name: nan() for name in SCALAR_FIELDS})
        return cls(
            directions=directions,
            sigma=sigma,
            frequency_ratio=w,
            harmonics=harmonics,
            settled=np.zeros(shape, dtype=bool),
            periodic=np.zeros(shape, dtype=bool),
            jump_frequency_ratio=np.full(shape[:2], np.nan),
            finished=np.zeros(shape[:2], dtype=bool),
            ball_mode_error=nan() if ball_mode else None,
            end=nan(2) if ball_mode else None,
            extra={name: nan() for name in BALL_FIELDS} if scene.model.kind == "ball" else {},
            response_period=np.zeros(shape, dtype=np.int8),
            subharmonic_onset_frequency_ratio=np.full(shape[:2], np.nan),
            subharmonic_end_frequency_ratio=np.full(shape[:2], np.nan),
            **readings,
        )

    def store_block(
        self,
        dims: tuple[np.ndarray, np.ndarray],
        index: np.ndarray,
        block: Block,
        settled,
        response_period: np.ndarray | None = None,
    ) -> None:
        """Store a block of T trajectories, trajectory t at ``(dims[0][t], dims[1][t],
        index[t])``, with their response periods (:func:`.period.response_periods`; by
        default 1 where periodic, 0 elsewhere)."""
        at = (*dims, index)
        if response_period is None:
            response_period = np.asarray(block.periodic, dtype=np.int8)
        self.response_period[at] = response_period
        for name in READING_FIELDS:
            getattr(self, name)[at] = getattr(block, name)
        self.settled[at] = settled
        self.periodic[at] = block.periodic
        for name, values in self.extra.items():
            values[at] = block.extra[name]
        if self.end is not None:
            self.end[at] = block.end

    def read_subharmonics(self) -> None:
        """``subharmonic_onset_frequency_ratio`` and ``subharmonic_end_frequency_ratio`` of
        every (direction, sigma) sweep from ``response_period`` (:func:`find_subharmonic`)."""
        for d, direction in enumerate(self.directions):
            for s in range(self.sigma.size):
                onset, end = find_subharmonic(
                    self.response_period[d, s], self.frequency_ratio, direction
                )
                self.subharmonic_onset_frequency_ratio[d, s] = onset
                self.subharmonic_end_frequency_ratio[d, s] = end

    def read_ball_mode(self, ball: BallModeCheck, oscillator: Oscillator) -> int:
        """``ball_mode_error`` of every dwell whose response repeats every period (NaN
        elsewhere: one period of a response that does not repeat holds lines that are not
        its own), one more period each from its end state, all in one compiled loop;
        returns the steps taken."""
        done = np.isfinite(self.end[..., 0]) & self.periodic
        directions, levels, points = np.nonzero(done)
        if directions.size:
            before = oscillator.steps
            self.ball_mode_error[done] = ball.errors(
                oscillator, self.sigma[levels], self.frequency_ratio[points], self.end[done]
            )
            return oscillator.steps - before
        return 0


def sweep_order(frequency_ratios: np.ndarray, direction: str) -> np.ndarray:
    """Indices of the grid in the order a sweep visits them."""
    order = np.arange(frequency_ratios.size)
    return order if direction == "up" else order[::-1]


def find_jump(
    amplitude: np.ndarray, frequency_ratios: np.ndarray, direction: str, threshold: float
) -> float:
    """Where H1 jumped (``amplitude``: of the order
    :func:`~hertzsweep.core.lockin.first_harmonic_index` picks): the last frequency before
    the largest relative change of H1 between neighbouring frequencies (in sweep order), if
    that change exceeds
    ``threshold`` of the larger of the two values; NaN if none does.

    The default threshold 0.3 lies above the largest step-to-step change of a linear
    resonance with zeta >= 0.4 % at the default step 0.0025 (about 0.25) and well below
    the paper's jumps (above 0.5).
    """
    order = sweep_order(frequency_ratios, direction)
    a = amplitude[order]
    if a.size < 2 or not np.all(np.isfinite(a)):
        return float("nan")
    change = np.abs(np.diff(a)) / np.maximum(np.maximum(a[1:], a[:-1]), 1e-300)
    i = int(np.argmax(change))
    return float(frequency_ratios[order][i]) if change[i] > threshold else float("nan")


SUBHARMONIC_PERIOD = 2  # the response_period of the subharmonic a sweep falls onto


def find_subharmonic(
    response_period: np.ndarray, frequency_ratios: np.ndarray, direction: str
) -> tuple[float, float]:
    """Where a sweep jumped onto the period-2 response and where it jumped off it, in its
    sweep order and by :func:`find_jump`'s convention (the last frequency before the jump):
    ``(onset, end)``, the dwell before the first of the longest run of dwells with
    ``response_period == 2`` (the first such run if several are as long) and that run's
    last dwell. NaN for an onset where the run starts the sweep, for an end where it ends
    it, for both where the sweep has no period-2 dwell.
    """
    order = sweep_order(frequency_ratios, direction)
    on = np.asarray(response_period)[order] == SUBHARMONIC_PERIOD
    if not on.any():
        return float("nan"), float("nan")
    edges = np.diff(np.concatenate(([0], on.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)  # [start, stop)
    run = int(np.argmax(stops - starts))
    w = np.asarray(frequency_ratios, dtype=float)[order]
    onset = float(w[starts[run] - 1]) if starts[run] > 0 else float("nan")
    end = float(w[stops[run] - 1]) if stops[run] < w.size else float("nan")
    return onset, end


def run_direction(
    scene: Scene, sigma: float, direction: str, result: SweepResult, progress: Progress | None
) -> Oscillator:
    """One stepped-sine sweep at one sigma, from rest, with the scene's steady-state
    strategy, stored into ``result`` as its dwells finish. Returns the oscillator (its step
    count)."""
    w = scene.sweep.frequency_ratios
    order = sweep_order(w, direction)
    oscillator = Oscillator(scene, sigma)
    d = result.directions.index(direction)
    s = int(np.flatnonzero(result.sigma == sigma)[0])
    walk = strategy(scene).walk(oscillator, oscillator.initial(w[order[0]]), w[order])
    try:
        for positions, block, settled in walk:
            index = order[positions]
            h = np.array([oscillator.step(float(x)) for x in w[index]])
            periods = response_periods(oscillator, block, np.full(index.size, sigma), h)
            dims = (np.full(index.size, d), np.full(index.size, s))
            result.store_block(dims, index, block, settled, periods)
            if progress is not None:
                progress(index.size)
    except HertzsweepError as exc:
        raise exc.with_context(f"{scene.source}: {direction} sweep") from None
    return oscillator


def run_sweep(
    scene: Scene,
    progress: Progress | None = None,
    batched: bool = True,
    ball_mode: bool = False,
) -> SweepResult:
    """Up and/or down stepped-sine sweeps for every sigma of the scene.

    With a fixed number of settling periods and the settle steady state (:func:`lockstep`)
    every sweep (direction x sigma) advances together in one compiled loop
    (:class:`Lockstep`, many trajectories vectorised): the numbers of one sweep at a time
    bit for bit (``batched=False`` runs them one at a time). ``ball_mode``: each dwell is
    read one more period for the ball's own mode (:mod:`.ballmode`; where the rig has a
    ball), into ``ball_mode_error``; the other readings are the same either way.

    Raises
    ------
    Interrupted
        On SIGINT (or SIGTERM where the CLI maps it), with the result so far as
        ``partial``: the dwells finished are kept, the rest NaN; ``finished`` marks the
        (direction, sigma) sweeps that ran to their end (in lockstep they end together).
    StabilityError
        The time step is beyond the stability limit (before running, or when the
        compression reached during the run passes it).
    IntegrationError
        The state became non-finite.
    """
    check_stability(scene)
    ball = BallModeCheck(scene) if ball_mode and has_ball_mode(scene) else None
    if batched and lockstep(scene):
        return _run_lockstep(scene, progress, ball)
    result = SweepResult.empty(scene, ball is not None)
    try:
        for d, direction in enumerate(result.directions):
            for s, sigma in enumerate(result.sigma):
                oscillator = run_direction(scene, sigma, direction, result, progress)
                result.steps += oscillator.steps
                result.jump_frequency_ratio[d, s] = find_jump(
                    result.amplitude[d, s, :, first_harmonic_index(result.harmonics)],
                    result.frequency_ratio,
                    direction,
                    scene.sweep.jump_threshold,
                )
                result.finished[d, s] = True
    except KeyboardInterrupt as exc:
        signal_number = getattr(exc, "signal_number", 2)
        raise Interrupted(result, signal_number) from None
    if ball is not None:
        result.steps += result.read_ball_mode(ball, Oscillator(scene, result.sigma[0]))
    result.read_subharmonics()
    return result


def lockstep(scene: Scene) -> bool:
    """Whether the scene's trajectories can dwell in lockstep (fixed settling, settle
    steady state); otherwise :func:`run_sweep_batched` runs them one by one."""
    return scene.sweep.settle_periods is not None and scene.sweep.steady_state == "settle"


class Lockstep:
    """T trajectories of one scene at their own levels ``sigma`` (float[T]), from rest."""

    def __init__(self, scene: Scene, sigma: np.ndarray, h: np.ndarray) -> None:
        self.scene = scene
        self.oscillators = [Oscillator(scene, level) for level in sigma]
        self.law = self.oscillators[0].law
        self.drive = drive(scene, sigma)
        self.h = np.array(h, dtype=float)
        self.steps = 0
        self.method = self.oscillators[0].method
        self.q_prev = self.method.zeros(sigma.size)
        self.q = self.method.zeros(sigma.size)
        if scene.sweep.initial_state is not None:  # else at rest (Oscillator.initial)
            q, velocity = scene.sweep.initial_state
            for t, step in enumerate(self.h):
                self.q_prev[t] = self.method.start(q, velocity, step, self.law)
                self.q[t] = q
        # one trajectory keeps its state in registers (the same numbers, bit for bit)
        self.measure = self.method.measure_one if sigma.size == 1 else self.method.measure

    def dwell(self, h_new: np.ndarray) -> tuple[int, int, Block | None, np.ndarray | None]:
        """Retune to ``h_new``, settle, measure. Returns ``(status, trajectory, block,
        settled)``: the readings of every trajectory and where they settled."""
        sweep = self.scene.sweep
        n = self.oscillators[0].steps_per_period
        tolerance = self.oscillators[0].periodic_tolerance
        self.method.retune_batch(self.q_prev, self.q, self.h, h_new, self.law)
        status, bad = self.method.advance_batch(
            self.q_prev, self.q, self.h, self.law, self.drive, int(sweep.settle_periods)
        )
        self.steps += len(self.q) * int(sweep.settle_periods) * n
        if status != scheme.OK:
            return status, bad, None, None
        blocks = []
        for periods in measured_blocks(sweep.measure_periods, self.scene.lockin.denominator):
            buffers = self.method.new_readout(self.drive.orders.size, len(self.q))
            status, bad = self.measure(
                self.q_prev, self.q, self.h, self.law, self.drive, periods, buffers
            )
            self.steps += len(self.q) * periods * n
            if status != scheme.OK:
                return status, bad, None, None
            blocks.append(Block.read(buffers, periods * n, self.h, tolerance))
        if len(blocks) == 1:
            return scheme.OK, -1, blocks[0], blocks[0].periodic
        head, tail = blocks
        return scheme.OK, -1, head.then(tail), head.agrees(tail, sweep.tolerance)


def _run_lockstep(
    scene: Scene, progress: Progress | None = None, ball: BallModeCheck | None = None
) -> SweepResult:
    """Every (direction, sigma) sweep of the scene, advanced together in lockstep: the
    numbers of one sweep at a time, bit for bit.

    Parameters
    ----------
    scene : Scene
    progress : callable, optional
        Called with the number of dwells finished (T after each lockstep dwell).
    ball : BallModeCheck, optional
        Reads each dwell one more period for the ball's own mode.

    Raises
    ------
    StabilityError, IntegrationError
        As :func:`run_sweep` (the first trajectory, in
        (direction, sigma) order, that failed at the dwell where one failed).
    Interrupted
        On SIGINT, with the result so far (lockstep sweeps finish together, so none is
        marked finished).
    """
    result = SweepResult.empty(scene, ball is not None)
    w = result.frequency_ratio
    pairs = [(d, s) for d in range(len(result.directions)) for s in range(result.sigma.size)]
    n = int(scene.solver.steps_per_period)
    order = np.array([sweep_order(w, result.directions[d]) for d, _ in pairs], dtype=np.int64)
    steps = np.array([scheme.step_size(x, n) for x in w])
    run = Lockstep(scene, np.array([result.sigma[s] for _, s in pairs]), steps[order[:, 0]])
    dims = tuple(np.array(axis) for axis in zip(*pairs, strict=True))  # (direction, sigma)
    try:
        for i in range(w.size):
            index = order[:, i]
            status, bad, block, settled = run.dwell(steps[index])
            if status != scheme.OK:
                direction = result.directions[pairs[bad][0]]
                try:
                    run.oscillators[bad].check_status(status, w[index[bad]])
                except HertzsweepError as exc:
                    raise exc.with_context(f"{scene.source}: {direction} sweep") from None
            periods = response_periods(run.oscillators[0], block, run.drive.sigma, run.h)
            result.store_block(dims, index, block, settled, periods)
            if progress is not None:
                progress(len(pairs))
    except KeyboardInterrupt as exc:
        raise Interrupted(result, getattr(exc, "signal_number", 2)) from None
    result.steps = run.steps
    if ball is not None:
        result.steps += result.read_ball_mode(ball, run.oscillators[0])
    h1 = first_harmonic_index(result.harmonics)
    for d, s in pairs:
        result.jump_frequency_ratio[d, s] = find_jump(
            result.amplitude[d, s, :, h1], w, result.directions[d], scene.sweep.jump_threshold
        )
    result.finished[:] = True
    result.read_subharmonics()
    return result


def dwell_count(scene: Scene) -> int:
    """Number of dwells a sweep of the scene runs (for progress bars)."""
    return (
        len(scene.sweep.directions)
        * len(scene.excitation.sigma)
        * scene.sweep.frequency_ratios.size
    )
