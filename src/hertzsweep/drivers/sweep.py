"""Stepped-sine sweeps, as on the rig (sections 3.2 and 4 of the paper).

For each sigma and each direction the frequency grid is walked from rest at its first
frequency, carrying the state from one frequency to the next, so that jumps and
hysteresis appear as on the rig. Each dwell is a whole number of periods; the
excitation changes frequency at a period boundary (phase 0), so its phase is continuous.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.config import Scene
from ..core.model import check_stability
from ..errors import HertzsweepError, Interrupted
from .oscillator import Oscillator, Reading, State
from .readings import HARMONIC_FIELDS, READING_FIELDS, SCALAR_FIELDS, Readings
from .steady import Dwell, settle_dwell, strategy

Progress = Callable[[int], None]


@dataclass
class SweepResult(Readings):
    """Arrays on (direction, sigma, frequency_ratio[, harmonic]), grid in ascending order.

    ``flight_tau`` is the longest flight per measured window in tau; the dataset layer
    turns it into seconds with the rig's Omega.
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

    @classmethod
    def empty(cls, scene: Scene) -> SweepResult:
        directions = scene.sweep.directions
        sigma = np.asarray(scene.excitation.sigma, dtype=float)
        w = scene.sweep.frequency_ratios
        harmonics = np.asarray(scene.lockin.harmonics, dtype=np.int64)
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
            **readings,
        )

    def store(self, d: int, s: int, i: int, reading: Reading, settled: bool) -> None:
        for name in READING_FIELDS:
            getattr(self, name)[d, s, i] = getattr(reading, name)
        self.settled[d, s, i] = settled
        self.periodic[d, s, i] = reading.periodic


def sweep_order(frequency_ratios: np.ndarray, direction: str) -> np.ndarray:
    """Indices of the grid in the order a sweep visits them."""
    order = np.arange(frequency_ratios.size)
    return order if direction == "up" else order[::-1]


def find_jump(
    amplitude: np.ndarray, frequency_ratios: np.ndarray, direction: str, threshold: float
) -> float:
    """Where H1 jumped: the last frequency before the largest relative change of H1
    between neighbouring frequencies (in sweep order), if that change exceeds
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


def run_direction(
    scene: Scene,
    sigma: float,
    direction: str,
    progress: Progress | None = None,
    store: Callable[[int, Reading, bool], None] | None = None,
    dwell: Dwell = settle_dwell,
) -> Oscillator:
    """One stepped-sine sweep at one sigma, from rest. ``store(i, reading, settled)`` is
    called for each grid index i as it finishes. Returns the oscillator (its step count).
    """
    w = scene.sweep.frequency_ratios
    oscillator = Oscillator(scene, sigma)
    state: State | None = None
    for i in sweep_order(w, direction):
        if state is None:
            state = oscillator.rest(w[i])
        try:
            state, reading, settled = dwell(oscillator, state, w[i])
        except HertzsweepError as exc:
            raise exc.with_context(f"{scene.source}: {direction} sweep") from None
        if store is not None:
            store(int(i), reading, settled)
        if progress is not None:
            progress(1)
    return oscillator


def run_sweep(scene: Scene, progress: Progress | None = None) -> SweepResult:
    """Up and/or down stepped-sine sweeps for every sigma of the scene.

    Raises
    ------
    Interrupted
        On SIGINT (or SIGTERM where the CLI maps it), with the result so far as
        ``partial``: finished (direction, sigma) sweeps are complete, the rest NaN.
    StabilityError
        The time step is beyond the stability limit (before running, or when the
        compression reached during the run passes it).
    IntegrationError
        The state became non-finite.
    """
    check_stability(scene)
    result = SweepResult.empty(scene)
    dwell = strategy(scene)
    try:
        for d, direction in enumerate(result.directions):
            for s, sigma in enumerate(result.sigma):

                def store(i: int, reading: Reading, settled: bool, d=d, s=s) -> None:
                    result.store(d, s, i, reading, settled)

                oscillator = run_direction(scene, sigma, direction, progress, store, dwell)
                result.steps += oscillator.steps
                result.jump_frequency_ratio[d, s] = find_jump(
                    result.amplitude[d, s, :, 0],
                    result.frequency_ratio,
                    direction,
                    scene.sweep.jump_threshold,
                )
                result.finished[d, s] = True
    except KeyboardInterrupt as exc:
        signal_number = getattr(exc, "signal_number", 2)
        raise Interrupted(result, signal_number) from None
    return result


def dwell_count(scene: Scene) -> int:
    """Number of dwells a sweep of the scene runs (for progress bars)."""
    return (
        len(scene.sweep.directions)
        * len(scene.excitation.sigma)
        * scene.sweep.frequency_ratios.size
    )
