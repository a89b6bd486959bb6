"""One scene's oscillator: the compiled kernels' parameters, the state, and readings.

This is the layer every driver (sweep, trace, shooting, study) stands on: it turns a
:class:`~hertzsweep.config.Scene` into the plain numbers the kernels take, carries the
state ``(q_prev, q)`` from one step size to the next, and turns the kernels' sums into
a :class:`Reading` (lock-in harmonics, force extremes, contact loss, periodicity).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.config import Scene
from ..core.lockin import amplitude_phase
from ..core.model import law_code
from ..errors import IntegrationError, StabilityError
from ..kernels import integrators

PERIODIC_TOLERANCE_FLOOR = 1e-3  # relative state mismatch after one period below which
# (or below 10x the scene tolerance) the steady state counts as T-periodic: well above
# the residual transient of a settled run, far below a period doubling's O(1) mismatch.


@dataclass(frozen=True)
class State:
    """Two consecutive displacements of the scheme at step ``h`` (in tau)."""

    q_prev: float
    q: float
    h: float


@dataclass(frozen=True)
class Reading:
    """What the instruments read over whole measured periods of one dwell.

    Attributes
    ----------
    amplitude, phase : float[K]
        Lock-in harmonics of N/F_s (SPEC convention, phase in degrees).
    mean_force : [1] mean N/F_s.
    force_max, force_min : [1] extremes of N/F_s.
    contact_loss_fraction : [1] share of the measured time out of contact.
    flight_tau : longest flight, in tau (dimensionless time).
    periodic : the state returned after one period (see PERIODIC_TOLERANCE_FLOOR).
    """

    amplitude: np.ndarray
    phase: np.ndarray
    mean_force: float
    force_max: float
    force_min: float
    contact_loss_fraction: float
    flight_tau: float
    periodic: bool
    coefficients: np.ndarray  # the raw sums, for convergence tests between blocks
    samples: int

    def vector(self) -> np.ndarray:
        """Normalised Fourier sums (mean and every harmonic): what 'steady' compares."""
        return np.concatenate(([self.mean_force - 1.0], self.coefficients.ravel() / self.samples))


class Oscillator:
    """The compiled model of one scene at one input level sigma.

    Parameters
    ----------
    scene : Scene
        Damping, solver and lock-in settings are read from it.
    sigma : float
        Input level F/F_s.
    """

    def __init__(self, scene: Scene, sigma: float) -> None:
        self.scene = scene
        self.sigma = float(sigma)
        self.zeta = float(scene.damping.ratio)
        self.law = law_code(scene.damping)
        self.exponent = float(scene.damping.exponent)
        self.steps_per_period = int(scene.solver.steps_per_period)
        self.sin_table, self.cos_table = integrators.period_tables(self.steps_per_period)
        self.harmonics = np.asarray(scene.lockin.harmonics, dtype=np.int64)
        self.periodic_tolerance = max(PERIODIC_TOLERANCE_FLOOR, 10.0 * scene.sweep.tolerance)
        self.steps = 0  # integration steps taken, for cost accounting

    # ------------------------------------------------------------------ state
    def step(self, frequency_ratio: float) -> float:
        return integrators.step_size(frequency_ratio, self.steps_per_period)

    def rest(self, frequency_ratio: float) -> State:
        """At rest at the static equilibrium (q = 0, q' = 0)."""
        return State(0.0, 0.0, self.step(frequency_ratio))

    def from_velocity(self, q: float, velocity: float, frequency_ratio: float) -> State:
        h = self.step(frequency_ratio)
        q_prev = integrators.start_from(q, velocity, h, self.zeta, self.law, self.exponent)
        return State(q_prev, q, h)

    def retune(self, state: State, frequency_ratio: float) -> State:
        """The same physical state at the step size of another frequency."""
        h = self.step(frequency_ratio)
        if h == state.h:
            return state
        q_prev = integrators.restart(
            state.q_prev, state.q, state.h, h, self.zeta, self.law, self.exponent
        )
        return State(q_prev, state.q, h)

    def check_status(self, status: int, frequency_ratio: float) -> None:
        """Raise the error a kernel status means (StabilityError, IntegrationError)."""
        if status == integrators.UNSTABLE:
            raise StabilityError(
                f"solver.steps_per_period: {self.steps_per_period} is beyond the stability "
                f"limit at the compression reached (sigma = {self.sigma:g}, "
                f"w = {frequency_ratio:g}); raise it"
            )
        if status == integrators.NON_FINITE:
            raise IntegrationError(
                f"the state became non-finite at sigma = {self.sigma:g}, w = {frequency_ratio:g}"
            )

    # ------------------------------------------------------------------ running
    def advance(self, state: State, frequency_ratio: float, periods: int) -> State:
        """Integrate whole periods (the state must be at this frequency's step)."""
        if periods <= 0:
            return state
        q_prev, q, status = integrators.advance(
            state.q_prev, state.q, state.h, self.sigma, self.sin_table, periods,
            self.zeta, self.law, self.exponent,
        )  # fmt: skip
        self.steps += periods * self.steps_per_period
        self.check_status(status, frequency_ratio)
        return State(q_prev, q, state.h)

    def measure(
        self,
        state: State,
        frequency_ratio: float,
        periods: int,
        record: np.ndarray | None = None,
        stride: int = 0,
    ) -> tuple[State, Reading]:
        """Integrate whole periods and read them; optionally record every ``stride``-th
        step into ``record`` (float[M, 4]: q, q', N/F_s, in contact)."""
        coefficients = np.zeros((self.harmonics.size, 2))
        if record is None:
            record = np.zeros((0, 4))
            stride = 0
        out = integrators.measure(
            state.q_prev, state.q, state.h, self.sigma, self.sin_table, self.cos_table,
            periods, self.zeta, self.law, self.exponent, self.harmonics, coefficients,
            record, stride,
        )  # fmt: skip
        (q_prev, q, status, total, fmax, fmin, loss, longest, lead, trail, qp_last, q_last) = out
        self.steps += periods * self.steps_per_period
        self.check_status(status, frequency_ratio)
        reading = self.reading(
            periods, state.h, coefficients, total, fmax, fmin, loss, longest, lead, trail,
            qp_last, q_last, q_prev, q,
        )  # fmt: skip
        return State(q_prev, q, state.h), reading

    def reading(
        self, periods, h, coefficients, total, force_max, force_min, loss, longest, lead,
        trail, q_prev_last, q_last, q_prev, q,
    ) -> Reading:  # fmt: skip
        """The :class:`Reading` of one measured block from the kernel's sums (see
        :func:`integrators.measure` for the arguments); shared by the batched kernels."""
        samples = periods * self.steps_per_period
        flight_steps = samples if lead == samples else max(longest, lead + trail)
        amplitude, phase = amplitude_phase(coefficients, samples)
        scale = max(abs(q_last), abs(q_prev_last), 0.5 * (force_max - force_min), 1e-300)
        mismatch = max(abs(q - q_last), abs(q_prev - q_prev_last)) / scale
        return Reading(
            amplitude=amplitude,
            phase=phase,
            mean_force=1.0 + total / samples,
            force_max=force_max,
            force_min=force_min,
            contact_loss_fraction=loss / samples,
            flight_tau=flight_steps * h,
            periodic=bool(mismatch < self.periodic_tolerance),
            coefficients=coefficients,
            samples=samples,
        )

    def dwell(self, state: State, frequency_ratio: float) -> tuple[State, Reading, bool]:
        """One stepped-sine dwell: retune, settle, measure. Returns ``(state, reading,
        settled)``.

        Fixed settling: ``settle_periods`` periods, then the measured periods in two
        halves whose readings must agree within ``tolerance`` for ``settled``.
        ``"auto"``: blocks of ``measure_periods`` until two consecutive readings agree
        within ``tolerance`` (relative), at most ``max_settle_periods`` of settling;
        ``settled`` is false where that cap was hit.
        """
        sweep = self.scene.sweep
        state = self.retune(state, frequency_ratio)
        if sweep.settle_periods is not None:
            state = self.advance(state, frequency_ratio, sweep.settle_periods)
            periods = sweep.measure_periods
            if periods < 2:
                state, reading = self.measure(state, frequency_ratio, periods)
                return state, reading, reading.periodic
            first = periods // 2
            state, head = self.measure(state, frequency_ratio, first)
            state, tail = self.measure(state, frequency_ratio, periods - first)
            return state, combine_readings(head, tail), readings_agree(head, tail, sweep.tolerance)
        block = sweep.measure_periods
        state, previous = self.measure(state, frequency_ratio, block)
        settled_periods = 0
        while True:
            state, reading = self.measure(state, frequency_ratio, block)
            if readings_agree(previous, reading, sweep.tolerance):
                return state, reading, True
            settled_periods += block
            if settled_periods >= sweep.max_settle_periods:
                return state, reading, False
            previous = reading


def readings_agree(a: Reading, b: Reading, tolerance: float) -> bool:
    """Two readings agree when their Fourier sums differ by at most ``tolerance`` of
    the norm of ``b``'s (relative, over the mean and every requested harmonic)."""
    va, vb = a.vector(), b.vector()
    return bool(np.linalg.norm(va - vb) <= tolerance * max(np.linalg.norm(vb), 1e-300))


def combine_readings(a: Reading, b: Reading) -> Reading:
    """The reading of two consecutive measured blocks (sums add; extremes combine)."""
    samples = a.samples + b.samples
    coefficients = a.coefficients + b.coefficients
    amplitude, phase = amplitude_phase(coefficients, samples)
    return Reading(
        amplitude=amplitude,
        phase=phase,
        mean_force=(a.mean_force * a.samples + b.mean_force * b.samples) / samples,
        force_max=max(a.force_max, b.force_max),
        force_min=min(a.force_min, b.force_min),
        contact_loss_fraction=(
            a.contact_loss_fraction * a.samples + b.contact_loss_fraction * b.samples
        )
        / samples,
        flight_tau=max(a.flight_tau, b.flight_tau),
        periodic=b.periodic,
        coefficients=coefficients,
        samples=samples,
    )


__all__ = ["Oscillator", "Reading", "State", "combine_readings", "readings_agree"]
