"""One scene's oscillator: the compiled kernels' parameters, the state, and readings.

This is the layer every driver (sweep, trace, shooting, study) stands on: it turns a
:class:`~hertzsweep.config.Scene` into the plain numbers the kernels take, carries the
state ``(q_prev, q)`` from one step size to the next, and turns the kernels' sums into
a :class:`Reading` (lock-in harmonics, force extremes, contact loss, periodicity).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.ballmodel import BallModel
from ..core.config import Scene
from ..core.lockin import amplitude_phase
from ..kernels import ball, scheme
from ..kernels.integrate import COUNT_FIELDS, SUM_FIELDS, Readout
from ..kernels.laws import make_law
from ..kernels.methods import MODELS, Method
from .readings import BALL_FIELDS, SCALAR_FIELDS

PERIODIC_TOLERANCE_FLOOR = 1e-3  # relative state mismatch after one period below which
# (or below 10x the scene tolerance) the steady state counts as T-periodic: well above
# the residual transient of a settled run, far below a period doubling's O(1) mismatch.


def method(scene: Scene) -> Method:
    """The kernels of the scene's ``solver.method`` for its ``model.kind``."""
    return MODELS[scene.model.kind][scene.solver.method]


def model_law(scene: Scene):
    """The kernels' record of the scene's damping law (and, for the ball model, of the
    model's constants: :class:`~hertzsweep.kernels.ball.Ball`)."""
    law = make_law(scene.damping.law, scene.damping.ratio, scene.damping.exponent)
    if scene.model.kind == "ball":
        model = BallModel.of(scene)
        return ball.make_model(law, model.upper, model.lower, model.load, model.mass_ratio)
    return law


def _member(values: np.ndarray):
    """The first trajectory's member of a state (a float, or float[2] for the ball)."""
    return values[0].copy() if values.ndim > 1 else float(values[0])


def drive(scene: Scene, sigma: np.ndarray | float):
    """The kernels' input (:class:`~hertzsweep.kernels.integrate.Drive` or the method's
    own) of a scene at the input levels ``sigma`` (one per trajectory)."""
    return method(scene).drive(sigma, scene.lockin.harmonics, int(scene.solver.steps_per_period))


def measured_blocks(measure_periods: int, denominator: int = 1) -> tuple[int, ...]:
    """The measured blocks of a fixed-settle dwell (:meth:`Oscillator.dwell`): two halves,
    the first the largest whole number of response periods (``denominator`` L excitation
    periods each: orders that are not whole read exactly only over such spans) up to half;
    one block when there are fewer than two response periods."""
    if measure_periods < 2 * denominator:
        return (measure_periods,)
    first = (measure_periods // (2 * denominator)) * denominator
    return (first, measure_periods - first)


@dataclass(frozen=True)
class State:
    """The state at excitation phase 0 and step ``h`` (in tau): q and the method's other
    variable ``q_prev`` (:mod:`hertzsweep.kernels.methods`: ``q[n-1]`` for the central
    difference, ``q'`` for RK4); for the ball model each is float[2] (the moving mass's
    and the ball's)."""

    q_prev: float | np.ndarray
    q: float | np.ndarray
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
    extra : the ball model's own readings (:data:`~.readings.BALL_FIELDS`), else empty.
    """

    amplitude: np.ndarray
    phase: np.ndarray
    mean_force: float
    force_max: float
    force_min: float
    contact_loss_fraction: float
    flight_tau: float
    periodic: bool
    coefficients: np.ndarray  # the raw sums (float[K, 2])
    samples: int
    extra: dict[str, float] = field(default_factory=dict)


BLOCK_ARRAYS = SCALAR_FIELDS + ("periodic", "coefficients")  # a Block's own arrays over t


assert SUM_FIELDS == ("total", "force_max", "force_min", "q_prev_last", "q_last", "q_prev", "q")
assert COUNT_FIELDS == ("loss", "longest", "lead", "trail")  # unpacked so by Block.read


@dataclass
class Block:
    """What one measured block read, for T trajectories (or T dwells) at once: the arrays
    of :class:`Reading` with a leading axis t. The one place readings are computed from
    the kernels' sums, combined and compared, for one trajectory and many alike.

    The harmonics' ``amplitude`` and ``phase`` are formed from ``coefficients`` when first
    asked for: a dwell reads two blocks, compares their sums and combines them, and only
    the combination's harmonics are ever read (their arctangents cost as much as the rest
    of a block's reading).

    Attributes
    ----------
    mean_force, force_max, force_min, contact_loss_fraction, flight_tau : float[T]
        As :class:`Reading` (:data:`~.readings.SCALAR_FIELDS`).
    periodic : bool[T]
    coefficients : float[T, K, 2]
        The raw Fourier sums (``cos``, ``sin``), for combining blocks and comparing them.
    samples : int
        Steps in the block (whole periods times N).
    end : float[T, 2] (float[T, 2, 2] for the ball model)
        The method's state ``(q_prev, q)`` at the end of the block (of the later block
        when two are combined), from which one more period can be read.
    extra : dict of float[T]
        The ball model's own readings (:data:`~.readings.BALL_FIELDS`); empty otherwise.
    harmonics : (float[T, K], float[T, K]) or None
        ``(amplitude, phase)`` once formed: on first use, or given by :meth:`of` (its
        reading has them).
    """

    mean_force: np.ndarray
    force_max: np.ndarray
    force_min: np.ndarray
    contact_loss_fraction: np.ndarray
    flight_tau: np.ndarray
    periodic: np.ndarray
    coefficients: np.ndarray
    samples: int
    end: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    harmonics: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    @property
    def amplitude(self) -> np.ndarray:
        """float[T, K]: the lock-in's amplitudes (:data:`~.readings.HARMONIC_FIELDS`)."""
        return self._harmonics()[0]

    @property
    def phase(self) -> np.ndarray:
        """float[T, K]: the lock-in's phases [degree]."""
        return self._harmonics()[1]

    def _harmonics(self) -> tuple[np.ndarray, np.ndarray]:
        if self.harmonics is None:
            self.harmonics = amplitude_phase(self.coefficients, self.samples)
        return self.harmonics

    @classmethod
    def read(cls, buffers: Readout, samples: int, h: np.ndarray, tolerance: float) -> Block:
        """The block of the kernels' ``buffers`` (``samples`` steps of step ``h[t]``);
        ``periodic`` where the state after the last period returns to its start within
        ``tolerance`` (relative to the response's scale)."""
        total, fmax, fmin = buffers.sums[:3]  # SUM_FIELDS
        last, now = buffers.sums[3:5], buffers.sums[5:7]  # (q_prev, q) a period apart
        loss, longest, lead, trail = buffers.counts  # COUNT_FIELDS
        flight_steps = np.where(lead == samples, samples, np.maximum(longest, lead + trail))
        coefficients = buffers.coefficients.transpose(2, 0, 1).copy()
        scale = np.maximum(np.abs(last).max(axis=0), np.maximum(0.5 * (fmax - fmin), 1e-300))
        mismatch = np.abs(now - last).max(axis=0)
        end = now.T.copy()
        extra: dict[str, np.ndarray] = {}
        if buffers.extra.shape[0]:  # the ball model: its state's second member too
            extra, q2_mismatch, q2_end = _ball_readings(buffers.extra, samples, h)
            mismatch = np.maximum(mismatch, q2_mismatch)
            end = np.stack([end, q2_end], axis=-1)
        return cls(
            mean_force=1.0 + total / samples,
            force_max=fmax.copy(),
            force_min=fmin.copy(),
            contact_loss_fraction=loss / samples,
            flight_tau=flight_steps * h,
            periodic=mismatch / scale < tolerance,
            coefficients=coefficients,
            samples=samples,
            end=end,
            extra=extra,
        )

    @classmethod
    def of(cls, reading: Reading, state: State) -> Block:
        """The block of one :class:`Reading`, ending at ``state``."""
        return cls(
            **{name: np.array([getattr(reading, name)]) for name in BLOCK_ARRAYS},
            samples=reading.samples,
            end=np.array([[state.q_prev, state.q]]),
            extra={name: np.array([value]) for name, value in reading.extra.items()},
            harmonics=(np.array([reading.amplitude]), np.array([reading.phase])),
        )

    def at(self, t: int) -> Reading:
        """The :class:`Reading` of trajectory t."""
        return Reading(
            amplitude=self.amplitude[t],
            phase=self.phase[t],
            mean_force=float(self.mean_force[t]),
            force_max=float(self.force_max[t]),
            force_min=float(self.force_min[t]),
            contact_loss_fraction=float(self.contact_loss_fraction[t]),
            flight_tau=float(self.flight_tau[t]),
            periodic=bool(self.periodic[t]),
            coefficients=self.coefficients[t],
            samples=self.samples,
            extra={name: float(values[t]) for name, values in self.extra.items()},
        )

    def then(self, later: Block) -> Block:
        """The block of this one and the ``later`` one together (sums add, extremes
        combine, ``periodic`` is the later block's)."""
        samples = self.samples + later.samples
        coefficients = self.coefficients + later.coefficients

        def weighted(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            return (a * self.samples + b * later.samples) / samples

        combine = {"max": np.maximum, "min": np.minimum, "mean": weighted}
        extra = {
            name: combine[BALL_FIELDS[name]](a, later.extra[name]) for name, a in self.extra.items()
        }

        return Block(
            mean_force=weighted(self.mean_force, later.mean_force),
            force_max=np.maximum(self.force_max, later.force_max),
            force_min=np.minimum(self.force_min, later.force_min),
            contact_loss_fraction=weighted(self.contact_loss_fraction, later.contact_loss_fraction),
            flight_tau=np.maximum(self.flight_tau, later.flight_tau),
            periodic=later.periodic,
            coefficients=coefficients,
            samples=samples,
            end=later.end,
            extra=extra,
        )

    def agrees(self, later: Block, tolerance: float) -> np.ndarray:
        """Where the two blocks' normalised Fourier sums (the mean and every harmonic)
        differ by at most ``tolerance`` of the later one's norm: bool[T]."""
        va, vb = self._vector(), later._vector()
        scale = np.maximum(_norms(vb), 1e-300)
        return _norms(va - vb) <= tolerance * scale

    def _vector(self) -> np.ndarray:
        flat = self.coefficients.reshape(self.coefficients.shape[0], -1) / self.samples
        return np.concatenate(((self.mean_force - 1.0)[:, None], flat), axis=1)


def _norms(rows: np.ndarray) -> np.ndarray:
    """The Euclidean norm of each row: ``numpy.linalg.norm(rows, axis=1)``'s arithmetic
    without its dispatch (a dwell compares two blocks of one row)."""
    return np.sqrt(np.add.reduce(rows * rows, axis=1))


def _flight_steps(tallied: np.ndarray, samples: int) -> np.ndarray:
    """The longest flight in steps from ``tally``'s sums (float[7, T]: total, max, min,
    loss, longest, lead, run), a flight across the period boundary joined (lead + trail)
    as :meth:`Block.read` joins the single model's."""
    longest, lead, trail = tallied[4], tallied[5], tallied[6]
    lead = np.where(lead < 0.0, trail, lead)  # never in contact: one flight
    return np.where(lead == samples, samples, np.maximum(longest, lead + trail))


def _ball_readings(extra: np.ndarray, samples: int, h: np.ndarray):
    """The ball model's readings (:data:`~.readings.BALL_FIELDS`) from the kernels' block
    (:data:`hertzsweep.kernels.ball.BALL_FIELDS`), the mismatch of the ball's state over
    the last period and its end state (float[T, 2])."""
    rows = dict(zip(ball.BALL_FIELDS, extra, strict=True))
    upper = extra[ball.UPPER : ball.FLIGHT]
    flight = extra[ball.FLIGHT :]
    readings = {
        "upper_force_max": upper[1] + 1.0,
        "upper_force_min": upper[2] + 1.0,
        "upper_contact_loss_fraction": upper[3] / samples,
        "ball_flight_fraction": flight[3] / samples,
        "ball_flight_tau": _flight_steps(flight, samples) * h,
    }
    mismatch = np.maximum(
        np.abs(rows["q2"] - rows["q2_last"]), np.abs(rows["q2_prev"] - rows["q2_prev_last"])
    )
    return readings, mismatch, np.column_stack([rows["q2_prev"], rows["q2"]])


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
        self.law = model_law(scene)
        self.steps_per_period = int(scene.solver.steps_per_period)
        self.method = method(scene)
        self.drive = drive(scene, self.sigma)
        self.harmonics = self.drive.harmonics  # the orders k, float64[K]
        self.denominator = scene.lockin.denominator  # L: a reading spans L periods or more
        self.periodic_tolerance = max(PERIODIC_TOLERANCE_FLOOR, 10.0 * scene.sweep.tolerance)
        self.steps = 0  # integration steps taken, for cost accounting

    # ------------------------------------------------------------------ state
    def step(self, frequency_ratio: float) -> float:
        return scheme.step_size(frequency_ratio, self.steps_per_period)

    def rest(self, frequency_ratio: float) -> State:
        """At rest at the static equilibrium (q = 0, q' = 0)."""
        return State(self.method.rest(), self.method.rest(), self.step(frequency_ratio))

    def initial(self, frequency_ratio: float) -> State:
        """Where a sweep (or a trace's approach) starts at its first frequency: the scene's
        ``sweep.initial_state`` ``(q, q')`` at excitation phase 0, else at rest."""
        start = self.scene.sweep.initial_state
        if start is None:
            return self.rest(frequency_ratio)
        return self.from_velocity(start[0], start[1], frequency_ratio)

    def from_velocity(self, q: float, velocity: float, frequency_ratio: float) -> State:
        h = self.step(frequency_ratio)
        return State(self.method.start(q, velocity, h, self.law), q, h)

    def retune(self, state: State, frequency_ratio: float) -> State:
        """The same physical state at the step size of another frequency."""
        h = self.step(frequency_ratio)
        if h == state.h:
            return state
        q_prev = self.method.restart(state.q_prev, state.q, state.h, h, self.law)
        return State(q_prev, state.q, h)

    def check_status(self, status: int, frequency_ratio: float) -> None:
        """Raise the error a kernel status means (:data:`~hertzsweep.kernels.scheme.STATUS`)."""
        scheme.check_status(status, self.sigma, frequency_ratio, self.steps_per_period)

    # ------------------------------------------------------------------ running
    def advance(self, state: State, frequency_ratio: float, periods: int) -> State:
        """Integrate whole periods (the state must be at this frequency's step)."""
        if periods <= 0:
            return state
        q_prev, q, status = self.method.advance(
            state.q_prev, state.q, state.h, self.law, self.drive, periods
        )
        self.steps += periods * self.steps_per_period
        self.check_status(status, frequency_ratio)
        return State(q_prev, q, state.h)

    def period_map(self, state: State, derivative: np.ndarray) -> tuple[State, int]:
        """One period of the method's map from ``state`` with its exact derivatives;
        ``derivative`` (float[2, 3]) receives ``d(q_prev, q)[N] / d(q_prev[0], q[0], h)``
        (:mod:`hertzsweep.kernels.methods`). Returns the state and the status."""
        q_prev, q, status = self.method.period_map(
            state.q_prev, state.q, state.h, self.law, self.drive, derivative
        )
        self.steps += self.steps_per_period
        return State(q_prev, q, state.h), status

    def measure(self, *args, **kwargs) -> tuple[State, Reading]:
        """:meth:`measure_block` (the same arguments), read as one :class:`Reading`."""
        state, block = self.measure_block(*args, **kwargs)
        return state, block.at(0)

    def measure_block(
        self,
        state: State,
        frequency_ratio: float,
        periods: int,
        record: np.ndarray | None = None,
        stride: int = 0,
    ) -> tuple[State, Block]:
        """Integrate whole periods and read them (a :class:`Block` of one trajectory);
        optionally record every ``stride``-th step into ``record`` (float[M, C]: q, q',
        N/F_s, in contact; the ball model adds its columns,
        :data:`~hertzsweep.kernels.ball.BALL_RECORD_COLUMNS`)."""
        buffers = self.method.new_readout(
            self.harmonics.size, 1, None if record is None else record[:, :, None], stride
        )
        q_prev, q = np.array([state.q_prev]), np.array([state.q])
        h = np.array([state.h])
        status, _ = self.method.measure_one(q_prev, q, h, self.law, self.drive, periods, buffers)
        self.steps += periods * self.steps_per_period
        self.check_status(status, frequency_ratio)
        block = Block.read(buffers, periods * self.steps_per_period, h, self.periodic_tolerance)
        return State(_member(q_prev), _member(q), state.h), block

    def dwell(self, state: State, frequency_ratio: float) -> tuple[State, Reading, bool]:
        """One stepped-sine dwell: retune, settle, measure. Returns ``(state, reading,
        settled)``.

        Fixed settling: ``settle_periods`` periods, then the measured periods in two
        halves (:func:`measured_blocks`) whose readings must agree within ``tolerance``
        for ``settled``.
        ``"auto"``: blocks of ``measure_periods`` until two consecutive readings agree
        within ``tolerance`` (relative), at most ``max_settle_periods`` of settling;
        ``settled`` is false where that cap was hit.
        """
        sweep = self.scene.sweep
        state = self.retune(state, frequency_ratio)
        if sweep.settle_periods is not None:
            state = self.advance(state, frequency_ratio, sweep.settle_periods)
            blocks = measured_blocks(sweep.measure_periods, self.denominator)
            if len(blocks) == 1:
                state, reading = self.measure(state, frequency_ratio, blocks[0])
                return state, reading, reading.periodic
            state, head = self.measure_block(state, frequency_ratio, blocks[0])
            state, tail = self.measure_block(state, frequency_ratio, blocks[1])
            return state, head.then(tail).at(0), bool(head.agrees(tail, sweep.tolerance)[0])
        block = sweep.measure_periods
        state, previous = self.measure_block(state, frequency_ratio, block)
        settled_periods = 0
        while True:
            state, reading = self.measure_block(state, frequency_ratio, block)
            if previous.agrees(reading, sweep.tolerance)[0]:
                return state, reading.at(0), True
            settled_periods += block
            if settled_periods >= sweep.max_settle_periods:
                return state, reading.at(0), False
            previous = reading


def dwell_by_dwell(dwell, oscillator: Oscillator, state: State, frequencies):
    """A steady-state strategy's walk one ``dwell(oscillator, state, w) -> (state,
    reading, settled)`` at a time over ``frequencies``, carrying the state: ``(positions,
    block, settled)`` for each (:mod:`hertzsweep.drivers.steady`)."""
    for position, w in enumerate(frequencies):
        state, reading, settled = dwell(oscillator, state, float(w))
        yield slice(position, position + 1), Block.of(reading, state), np.array([settled])


__all__ = [
    "Block",
    "Oscillator",
    "Reading",
    "State",
    "drive",
    "dwell_by_dwell",
    "measured_blocks",
]
