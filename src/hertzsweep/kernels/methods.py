"""The integration methods as data: each ``solver.method`` is one set of kernels with one
contract, which the drivers look up in :data:`METHODS` (no driver names a method; the
compiled side's one other table, :data:`.tangent.MODULES`, maps each method's drive type
to its kernel module for the compiled Newton).

The state crossing the boundary is a pair ``(a, q)`` at excitation phase 0 whose first
member is the method's own: ``q[n-1]`` for the central difference (it depends on the step
h, so a change of frequency restarts it: ``restart``), ``q'`` for RK4 (it does not).

``advance(a, q, h, law, drive, periods) -> (a, q, status)``, ``advance_batch`` and
``measure``/``measure_one`` (in place on arrays, ``-> (status, trajectory)``) are the
compiled loops; ``drive(sigma, harmonics, steps_per_period)`` builds their input (the
lock-in's reference tables of N L entries for orders of common denominator L:
:func:`common_denominator`);
``start(q, q', h, law)`` gives ``a``; ``restart(a, q, h_old, h_new, law)`` carries ``a`` to
another step. Every method has its one-period map with the exact Jacobian,
``period_map(a, q, h, law, drive, derivative) -> (a, q, status)`` (``derivative``
float64[2, 3]: ``d(a, q)[N] / d(a[0], q[0], h)``), which shooting and continuation use
(the compiled Newton picks it by the drive's type: :mod:`.tangent`), and its ``basis``:
the state ``x = (a, q) = Q basis z`` in the scaled coordinates ``z`` of Newton and the
continuation, both of the order of the response amplitude over the orbit scale Q
(displacement and velocity, or velocity over w, at phase 0). Every basis has the second
row ``(1, 0)`` (``z0 = q / Q``), which the compiled Newton relies on.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import ball, integrate, rk, tangent

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
    "new_readout",
)
"""What every method's kernel module defines, under these names (the module docstring)."""


@dataclass(frozen=True)
class Method:
    """One integration method's kernels (see the module docstring); ``inputs(sigma,
    sin_table, cos_table, harmonics, lockin)`` builds the kernels' drive (``lockin``: the
    lock-in's reference tables and the orders ``k L`` as whole numbers)."""

    name: str
    order: str  # for the reader: the order of the readings in h
    period_map: Callable
    basis: Callable[[int], np.ndarray]  # of steps_per_period
    advance: Callable
    advance_batch: Callable
    measure: Callable
    measure_one: Callable
    tables: Callable[[int], tuple[np.ndarray, np.ndarray]]
    inputs: Callable
    start: Callable
    restart: Callable
    retune_batch: Callable
    new_readout: Callable  # (harmonics, trajectories, record, stride) -> Readout
    state_shape: tuple[int, ...] = ()  # of one trajectory's q (the ball model's: (2,))
    record_columns: int = 4  # of a sample of the record

    @classmethod
    def of(
        cls, name: str, order: str, module, period_map: Callable, basis: Callable, **shape
    ) -> Method:
        """The method whose kernels are ``module``'s :data:`KERNELS` (``shape``: its
        ``state_shape`` and ``record_columns`` where they are not the single model's)."""
        kernels = {kernel: getattr(module, kernel) for kernel in KERNELS}
        return cls(name, order, period_map, basis, **kernels, **shape)

    def zeros(self, trajectories: int) -> np.ndarray:
        """One member of the state of T trajectories at rest (float[T] or float[T, 2])."""
        return np.zeros((trajectories, *self.state_shape))

    def rest(self):
        """One member of one trajectory's state at rest (0.0, or float[2])."""
        return np.zeros(self.state_shape) if self.state_shape else 0.0

    def drive(self, sigma, harmonics, steps_per_period: int):
        """The kernels' input at the levels ``sigma`` (one per trajectory), reading the
        orders ``harmonics`` (whole, or multiples of 1/2, 1/3, 1/4 of the excitation
        frequency)."""
        sin_table, cos_table = _tables(self.name, steps_per_period)
        levels = np.atleast_1d(np.asarray(sigma, dtype=float))
        orders = np.asarray(harmonics, dtype=np.float64).reshape(-1)
        denominator = common_denominator(orders)
        lockin_sin, lockin_cos = _lockin_tables(self.name, steps_per_period, denominator)
        whole = np.rint(orders * denominator).astype(np.int64)
        lockin = (lockin_sin, lockin_cos, whole)
        return self.inputs(levels, sin_table, cos_table, orders, lockin)


@lru_cache(maxsize=16)
def _tables(name: str, steps_per_period: int) -> tuple[np.ndarray, np.ndarray]:
    return METHODS[name].tables(steps_per_period)  # every model's method shares them


COMMON_DENOMINATORS = (1, 2, 3, 4, 6, 12)  # of orders that are multiples of 1/2, 1/3, 1/4
ORDER_TOLERANCE = 1e-9  # k D within this (relative) of a whole number counts as whole


def common_denominator(orders) -> int:
    """L: the least of :data:`COMMON_DENOMINATORS` that makes every order ``k L`` whole
    (the scene's orders are checked by ``hertzsweep.core.config``)."""
    orders = np.asarray(orders, dtype=np.float64)
    for denominator in COMMON_DENOMINATORS:
        scaled = orders * denominator
        if np.all(np.abs(scaled - np.rint(scaled)) <= ORDER_TOLERANCE * np.maximum(1.0, scaled)):
            return denominator
    raise ValueError(f"orders {orders.tolist()} are not multiples of 1/2, 1/3 or 1/4")


@lru_cache(maxsize=16)
def _lockin_tables(name: str, steps_per_period: int, denominator: int):
    """The lock-in's reference tables of a method: its excitation tables of ``N L``
    steps, entry ``j L`` set to entry j of the excitation's own (the very same arrays when
    L = 1), so that a whole order reads the same references whatever L is."""
    sin_table, cos_table = _tables(name, steps_per_period)
    if denominator == 1:
        return sin_table, cos_table
    fine_sin, fine_cos = (np.array(t) for t in METHODS[name].tables(steps_per_period * denominator))
    fine_sin[::denominator] = sin_table
    fine_cos[::denominator] = cos_table
    return fine_sin, fine_cos


def difference_basis(steps_per_period: int) -> np.ndarray:
    """``(q[-1], q[0]) = Q B z`` with ``z = (q[0], (q[0] - q[-1]) / theta) / Q``, ``theta =
    w h = 2 pi / N``: displacement and velocity over w."""
    theta = 2.0 * np.pi / steps_per_period
    return np.array([[1.0, -theta], [1.0, 0.0]])


def velocity_basis(steps_per_period: int) -> np.ndarray:
    """``(q'[0], q[0]) = Q B z`` with ``z = (q[0], q'[0]) / Q``."""
    return np.array([[0.0, 1.0], [1.0, 0.0]])


METHODS = {
    "central-difference": Method.of(
        "central-difference", "2", integrate, tangent.period_map, difference_basis
    ),
    "rk4": Method.of("rk4", "4 in contact, 3.5 through impacts", rk, rk.period_map, velocity_basis),
}


def ball_difference_basis(steps_per_period: int) -> np.ndarray:
    """The ball model's :func:`difference_basis`, one per body: ``x = (q1[-1], q2[-1],
    q1[0], q2[0]) = Q B z`` with ``z = (q1[0], v1, q2[0], v2) / Q``, ``v = (q[0] - q[-1]) /
    theta``: each body's displacement and velocity over w."""
    theta = 2.0 * np.pi / steps_per_period
    return np.array(
        [
            [1.0, -theta, 0.0, 0.0],
            [0.0, 0.0, 1.0, -theta],
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ]
    )


BALL_METHODS = {
    "central-difference": Method.of(
        "central-difference",
        "2",
        ball,
        ball.period_map,
        ball_difference_basis,
        state_shape=(2,),
        record_columns=ball.BALL_RECORD_COLUMNS,
    ),
}
"""The two-degree-of-freedom model's methods (:mod:`.ball`): the central difference, its
one-period map with the exact 4 x 5 Jacobian for shooting and continuation (Newton in
numpy: :func:`hertzsweep.drivers.shooting.newton`)."""

MODELS = {"single": METHODS, "ball": BALL_METHODS}
"""Each ``model.kind``'s methods."""

__all__ = ["BALL_METHODS", "KERNELS", "METHODS", "MODELS", "Method", "common_denominator"]
