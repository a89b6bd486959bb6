"""Steady-state strategies: how a dwell reaches the response it reads.

A strategy has a ``dwell``, ``(oscillator, state, frequency_ratio) -> (state, reading,
settled)`` like :meth:`~hertzsweep.drivers.oscillator.Oscillator.dwell`, and a ``walk``
over a sequence of frequencies (a sweep), ``(oscillator, state, frequencies) -> iterator of
(positions, block, settled)``: consecutive positions in the sequence, their readings as one
:class:`~hertzsweep.drivers.oscillator.Block` and where they settled. By default one dwell
after another; a strategy may walk faster (shooting walks in one compiled loop while every
orbit converges). Sweeps and
traces look the scene's ``[sweep] steady_state`` up in :data:`STRATEGIES`; a new strategy
is one entry here (and its name in ``hertzsweep.core.config.STEADY_STATE_METHODS``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from ..core.config import Scene
from .oscillator import Block, Oscillator, Reading, State
from .shooting import shooting_dwell, shooting_walk

Dwell = Callable[[Oscillator, State, float], tuple[State, Reading, bool]]
Step = tuple[slice, Block, np.ndarray]  # positions in the walk, their readings, settled
Walk = Callable[[Oscillator, State, Sequence[float]], Iterator[Step]]


def settle_dwell(oscillator: Oscillator, state: State, frequency_ratio: float):
    """Integrate ``settle_periods`` (or until steady, ``"auto"``), then measure."""
    return oscillator.dwell(state, frequency_ratio)


@dataclass(frozen=True)
class Strategy:
    """A steady-state strategy: its dwell, and its walk over a sequence of frequencies."""

    dwell: Dwell
    fast_walk: Walk | None = None

    def walk(self, oscillator: Oscillator, state: State, frequencies: Sequence[float]):
        """Dwell at each frequency in turn, carrying the state: ``(positions, block,
        settled)`` for each run of dwells."""
        if self.fast_walk is not None:
            yield from self.fast_walk(oscillator, state, frequencies)
            return
        for position, w in enumerate(frequencies):
            state, reading, settled = self.dwell(oscillator, state, w)
            yield slice(position, position + 1), Block.of(reading, state), np.array([settled])


STRATEGIES: dict[str, Strategy] = {
    "settle": Strategy(settle_dwell),  # the rig's way: wait, then read
    "shooting": Strategy(shooting_dwell, shooting_walk),  # Newton on the period map, read
}


def strategy(scene: Scene) -> Strategy:
    """The strategy of the scene's ``[sweep] steady_state``."""
    return STRATEGIES[scene.sweep.steady_state]


__all__ = ["STRATEGIES", "Dwell", "Strategy", "settle_dwell", "strategy"]
