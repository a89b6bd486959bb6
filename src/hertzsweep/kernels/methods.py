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

from . import integrate, rk, scheme, stop


@dataclass(frozen=True)
class Method:
    """One integration method's kernels (see the module docstring)."""

    name: str
    order: str  # for the reader: the order of the readings in h
    advance: Callable
    advance_batch: Callable
    measure: Callable
    measure_one: Callable
    tables: Callable[[int], tuple[np.ndarray, np.ndarray]]
    inputs: Callable  # (sigma, sin_table, cos_table, harmonics) -> the kernels' drive
    start: Callable
    restart: Callable
    retune_batch: Callable
    tangent: bool

    def drive(self, sigma, harmonics, steps_per_period: int):
        """The kernels' input at the levels ``sigma`` (one per trajectory)."""
        sin_table, cos_table = _tables(self.name, steps_per_period)
        levels = np.atleast_1d(np.asarray(sigma, dtype=float))
        return self.inputs(levels, sin_table, cos_table, np.asarray(harmonics, dtype=np.int64))


@lru_cache(maxsize=16)
def _tables(name: str, steps_per_period: int) -> tuple[np.ndarray, np.ndarray]:
    return METHODS[name].tables(steps_per_period)


def _same(a, q, h_old, h_new, law):
    """``q'`` is the same at any step."""
    return a


def _retune_steps(a, q, h, h_new, law):
    """Every trajectory's step becomes ``h_new`` (the state is unchanged)."""
    h[:] = h_new


def _velocity(q, velocity, h, law):
    return velocity


def _central_inputs(sigma, sin_table, cos_table, harmonics):
    return integrate.Drive(sigma, sin_table, cos_table, harmonics, stop.REQUEST)


def _rk_inputs(sigma, sin_table, cos_table, harmonics):
    return rk.Drive(sigma, sin_table, cos_table, harmonics, stop.REQUEST, True)


METHODS = {
    "central-difference": Method(
        name="central-difference",
        order="2",
        advance=integrate.advance,
        advance_batch=integrate.advance_batch,
        measure=integrate.measure,
        measure_one=integrate.measure_one,
        tables=scheme.period_tables,
        inputs=_central_inputs,
        start=integrate.start_from,
        restart=integrate.restart,
        retune_batch=integrate.retune_batch,
        tangent=True,
    ),
    "rk4": Method(
        name="rk4",
        order="4 in contact, 3.5 through impacts (rk.py)",
        advance=rk.advance,
        advance_batch=rk.advance_batch,
        measure=rk.measure,
        measure_one=rk.measure,
        tables=rk.tables,
        inputs=_rk_inputs,
        start=_velocity,
        restart=_same,
        retune_batch=_retune_steps,
        tangent=False,
    ),
}

__all__ = ["METHODS", "Method"]
