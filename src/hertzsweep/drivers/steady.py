"""Steady-state strategies: how a dwell reaches the response it reads.

A strategy takes ``(oscillator, state, frequency_ratio)`` and returns ``(state, reading,
settled)`` like :meth:`~hertzsweep.drivers.oscillator.Oscillator.dwell`. Sweeps and traces
look the scene's ``[sweep] steady_state`` up in :data:`STRATEGIES`; a new strategy is one
entry here (and its name in ``hertzsweep.core.config.STEADY_STATE_METHODS``).
"""

from __future__ import annotations

from collections.abc import Callable

from ..core.config import Scene
from .oscillator import Oscillator, Reading, State
from .shooting import shooting_dwell

Dwell = Callable[[Oscillator, State, float], tuple[State, Reading, bool]]


def settle_dwell(oscillator: Oscillator, state: State, frequency_ratio: float):
    """Integrate ``settle_periods`` (or until steady, ``"auto"``), then measure."""
    return oscillator.dwell(state, frequency_ratio)


STRATEGIES: dict[str, Dwell] = {
    "settle": settle_dwell,  # the rig's way: wait, then read
    "shooting": shooting_dwell,  # Newton on the one-period map, then read
}


def strategy(scene: Scene) -> Dwell:
    """The dwell of the scene's ``[sweep] steady_state``."""
    return STRATEGIES[scene.sweep.steady_state]


__all__ = ["STRATEGIES", "Dwell", "settle_dwell", "strategy"]
