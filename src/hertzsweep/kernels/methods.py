"""The integration methods as data: each ``solver.method`` is one set of kernels with one
contract, which the drivers look up in :data:`METHODS` (no method is named anywhere
else).

The state crossing the boundary is a pair ``(a, q)`` at excitation phase 0 whose first
member is the method's own: ``q[n-1]`` for the central difference (it depends on the step
h, so a change of frequency restarts it: ``restart``), ``q'`` for RK4 (it does not).

``advance(a, q, h, law, drive, periods) -> (a, q, status)``, ``advance_batch`` and
``measure``/``measure_one`` (in place on arrays, ``-> (status, trajectory)``) are the
compiled loops; ``drive(sigma, harmonics, steps_per_period)`` builds their input;
``start(q, q', h, law)`` gives ``a``; ``restart(a, q, h_old, h_new, law)`` carries ``a`` to
another step; ``tangent`` names whether the method has the one-period map with its
Jacobian (:mod:`.tangent`) that shooting and continuation use.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import integrate, rk

KERNELS = (
    "advance",
    "advance_batch",
    "measure",
    "measure_one",
    "tables",
    "inputs",
    "start",
    "restart",
    "retune_batch",
)
"""What every method's kernel module defines, under these names (the module docstring)."""


@dataclass(frozen=True)
class Method:
    """One integration method's kernels (see the module docstring); ``inputs(sigma,
    sin_table, cos_table, harmonics)`` builds the kernels' drive."""

    name: str
    order: str  # for the reader: the order of the readings in h
    tangent: bool
    advance: Callable
    advance_batch: Callable
    measure: Callable
    measure_one: Callable
    tables: Callable[[int], tuple[np.ndarray, np.ndarray]]
    inputs: Callable
    start: Callable
    restart: Callable
    retune_batch: Callable

    @classmethod
    def of(cls, name: str, order: str, module, tangent: bool) -> Method:
        """The method whose kernels are ``module``'s :data:`KERNELS`."""
        return cls(name, order, tangent, **{kernel: getattr(module, kernel) for kernel in KERNELS})

    def drive(self, sigma, harmonics, steps_per_period: int):
        """The kernels' input at the levels ``sigma`` (one per trajectory)."""
        sin_table, cos_table = _tables(self.name, steps_per_period)
        levels = np.atleast_1d(np.asarray(sigma, dtype=float))
        return self.inputs(levels, sin_table, cos_table, np.asarray(harmonics, dtype=np.int64))


@lru_cache(maxsize=16)
def _tables(name: str, steps_per_period: int) -> tuple[np.ndarray, np.ndarray]:
    return METHODS[name].tables(steps_per_period)


METHODS = {
    "central-difference": Method.of("central-difference", "2", integrate, tangent=True),
    "rk4": Method.of("rk4", "4 in contact, 3.5 through impacts", rk, tangent=False),
}

__all__ = ["KERNELS", "METHODS", "Method"]
