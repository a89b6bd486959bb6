"""One scene's oscillator: the compiled kernels' parameters, the state, and readings.

This is the layer every driver (sweep, trace, shooting, study) stands on: it turns a
:class:`~hertzsweep.config.Scene` into the plain numbers the kernels take, carries the
state ``(q_prev, q)`` from one step size to the next, and turns the kernels' sums into
a :class:`Reading` (lock-in harmonics, force extremes, contact loss, periodicity).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..core.config import Scene
from ..core.lockin import amplitude_phase
from ..kernels import integrate, scheme, tangent
from ..kernels.integrate import COUNT_FIELDS, SUM_FIELDS, Drive, Readout
from ..kernels.laws import make_law

PERIODIC_TOLERANCE_FLOOR = 1e-3  # relative state mismatch after one period below which
# (or below 10x the scene tolerance) the steady state counts as T-periodic: well above
# the residual transient of a settled run, far below a period doubling's O(1) mismatch.


@lru_cache(maxsize=8)
def _tables(steps_per_period: int) -> tuple[np.ndarray, np.ndarray]:
    return scheme.period_tables(steps_per_period)


def drive(scene: Scene, sigma: np.ndarray | float) -> Drive:
    """The kernels' :class:`~hertzsweep.kernels.integrate.Drive` of a scene at the input
    levels ``sigma`` (one per trajectory)."""
    sin_table, cos_table = _tables(int(scene.solver.steps_per_period))
    harmonics = np.asarray(scene.lockin.harmonics, dtype=np.int64)
    return Drive(np.atleast_1d(np.asarray(sigma, dtype=float)), sin_table, cos_table, harmonics)


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
        self.law = make_law(scene.damping.law, scene.damping.ratio, scene.damping.exponent)
        self.steps_per_period = int(scene.solver.steps_per_period)
        self.drive = drive(scene, self.sigma)
        self.harmonics = self.drive.harmonics
        self.periodic_tolerance = max(PERIODIC_TOLERANCE_FLOOR, 10.0 * scene.sweep.tolerance)
        self.steps = 0  # integration steps taken, for cost accounting

    # ------------------------------------------------------------------ state
    def step(self, frequency_ratio: float) -> float:
        return scheme.step_size(frequency_ratio, self.steps_per_period)

    def rest(self, frequency_ratio: float) -> State:
        """At rest at the static equilibrium (q = 0, q' = 0)."""
        return State(0.0, 0.0, self.step(frequency_ratio))

    def from_velocity(self, q: float, velocity: float, frequency_ratio: float) -> State:
        h = self.step(frequency_ratio)
        return State(integrate.start_from(q, velocity, h, self.law), q, h)

    def retune(self, state: State, frequency_ratio: float) -> State:
        """The same physical state at the step size of another frequency."""
        h = self.step(frequency_ratio)
        if h == state.h:
            return state
        return State(integrate.restart(state.q_prev, state.q, state.h, h, self.law), state.q, h)

    def check_status(self, status: int, frequency_ratio: float) -> None:
        """Raise the error a kernel status means (:data:`~hertzsweep.kernels.scheme.STATUS`)."""
        scheme.check_status(status, self.sigma, frequency_ratio, self.steps_per_period)

    # ------------------------------------------------------------------ running
    def advance(self, state: State, frequency_ratio: float, periods: int) -> State:
        """Integrate whole periods (the state must be at this frequency's step)."""
        if periods <= 0:
            return state
        q_prev, q, status = integrate.advance(
            state.q_prev, state.q, state.h, self.law, self.drive, periods
        )
        self.steps += periods * self.steps_per_period
        self.check_status(status, frequency_ratio)
        return State(q_prev, q, state.h)

    def period_map(self, state: State, derivative: np.ndarray) -> tuple[State, int]:
        """One period of the tangent-linear scheme from ``state``; ``derivative`` (float[2, 3])
        receives ``d(q[N-1], q[N]) / d(q[-1], q[0], h)``. Returns the state and the status."""
        q_prev, q, status = tangent.period_map(
            state.q_prev, state.q, state.h, self.law, self.drive, derivative
        )
        self.steps += self.steps_per_period
        return State(q_prev, q, state.h), status

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
        buffers = integrate.new_readout(
            self.harmonics.size, 1, None if record is None else record[:, :, None], stride
        )
        q_prev, q = np.array([state.q_prev]), np.array([state.q])
        status, _ = integrate.measure_one(
            q_prev, q, np.array([state.h]), self.law, self.drive, periods, buffers
        )
        self.steps += periods * self.steps_per_period
        self.check_status(status, frequency_ratio)
        return State(float(q_prev[0]), float(q[0]), state.h), self.reading(
            buffers, 0, periods, state.h
        )

    def reading(self, buffers: Readout, t: int, periods: int, h: float) -> Reading:
        """The :class:`Reading` of trajectory ``t`` of a measured block of ``periods``
        periods at step h (shared by single and batched runs)."""
        sums = dict(zip(SUM_FIELDS, buffers.sums[:, t].tolist(), strict=True))
        counts = dict(zip(COUNT_FIELDS, buffers.counts[:, t].tolist(), strict=True))
        samples = periods * self.steps_per_period
        lead, trail = counts["lead"], counts["trail"]
        flight_steps = samples if lead == samples else max(counts["longest"], lead + trail)
        coefficients = np.array(buffers.coefficients[:, :, t])
        amplitude, phase = amplitude_phase(coefficients, samples)
        fmax, fmin = sums["force_max"], sums["force_min"]
        q_prev_last, q_last = sums["q_prev_last"], sums["q_last"]
        scale = max(abs(q_last), abs(q_prev_last), 0.5 * (fmax - fmin), 1e-300)
        mismatch = max(abs(sums["q"] - q_last), abs(sums["q_prev"] - q_prev_last)) / scale
        return Reading(
            amplitude=amplitude,
            phase=phase,
            mean_force=1.0 + sums["total"] / samples,
            force_max=fmax,
            force_min=fmin,
            contact_loss_fraction=counts["loss"] / samples,
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
