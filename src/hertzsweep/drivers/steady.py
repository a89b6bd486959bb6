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
from functools import partial

import numpy as np

from ..core.config import Scene
from .oscillator import Block, Oscillator, Reading, State, dwell_by_dwell
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
        walk = self.fast_walk or partial(dwell_by_dwell, self.dwell)
        yield from walk(oscillator, state, frequencies)


STRATEGIES: dict[str, Strategy] = {
    "settle": Strategy(settle_dwell),  # the rig's way: wait, then read
    "shooting": Strategy(shooting_dwell, shooting_walk),  # Newton on the period map, read
}


def strategy(scene: Scene) -> Strategy:
    """The strategy of the scene's ``[sweep] steady_state``."""
    return STRATEGIES[scene.sweep.steady_state]


__all__ = ["STRATEGIES", "Dwell", "Strategy", "settle_dwell", "strategy"]
