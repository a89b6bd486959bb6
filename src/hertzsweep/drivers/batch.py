"""Many sweeps in lockstep: the trajectories of a scene dwell together in one loop.

A scene's stepped-sine sweeps (every direction x sigma) are independent trajectories of
the same scheme with the same steps per period N and damping law; they differ only in the
input level sigma and, at a given dwell, in the frequency (up and down walk the grid in
opposite orders), hence in the step h. With a fixed number of settling periods every dwell
has the same number of steps, so all trajectories dwell together in
:func:`hertzsweep.kernels.integrate.advance_batch` / :func:`~hertzsweep.kernels.integrate.measure`
(trajectory index innermost, vectorised). Each trajectory performs exactly the operations of
a single run (one step function), so :func:`run_sweep_batched` gives the numbers of
:func:`hertzsweep.drivers.sweep.run_sweep` bit for bit.

``settle_periods = "auto"`` (every trajectory settles in its own number of blocks) and
``steady_state = "shooting"`` do not fit lockstep: :func:`run_sweep_batched` then runs the
trajectories one after another with :func:`~hertzsweep.drivers.sweep.run_sweep`.
"""

from __future__ import annotations

import numpy as np

from ..core.config import Scene
from ..core.model import check_stability
from ..errors import HertzsweepError, Interrupted
from ..kernels import integrate, scheme
from .oscillator import Oscillator, combine_readings, drive, readings_agree
from .sweep import Progress, SweepResult, find_jump, run_sweep, sweep_order


def lockstep(scene: Scene) -> bool:
    """Whether the scene's trajectories can dwell in lockstep (fixed settling, settle
    steady state); otherwise :func:`run_sweep_batched` runs them one by one."""
    return scene.sweep.settle_periods is not None and scene.sweep.steady_state == "settle"


def measured_blocks(measure_periods: int) -> tuple[int, ...]:
    """The measured blocks of a fixed-settle dwell, as ``Oscillator.dwell`` reads them."""
    if measure_periods < 2:
        return (measure_periods,)
    first = measure_periods // 2
    return (first, measure_periods - first)


class Lockstep:
    """T trajectories of one scene at their own levels ``sigma`` (float[T]), from rest."""

    def __init__(self, scene: Scene, sigma: np.ndarray, h: np.ndarray) -> None:
        self.scene = scene
        self.oscillators = [Oscillator(scene, level) for level in sigma]
        self.law = self.oscillators[0].law
        self.drive = drive(scene, sigma)
        self.h = np.array(h, dtype=float)
        self.q_prev = np.zeros(sigma.size)
        self.q = np.zeros(sigma.size)
        self.steps = 0

    def dwell(self, h_new: np.ndarray) -> tuple[int, int, list]:
        """Retune to ``h_new``, settle, measure. Returns ``(status, trajectory, readings)``
        with ``readings[t] = (reading, settled)``."""
        sweep = self.scene.sweep
        n = self.oscillators[0].steps_per_period
        integrate.retune_batch(self.q_prev, self.q, self.h, h_new, self.law)
        status, bad = integrate.advance_batch(
            self.q_prev, self.q, self.h, self.law, self.drive, int(sweep.settle_periods)
        )
        self.steps += self.q.size * int(sweep.settle_periods) * n
        if status != scheme.OK:
            return status, bad, []
        blocks = []
        for periods in measured_blocks(sweep.measure_periods):
            buffers = integrate.new_readout(self.drive.harmonics.size, self.q.size)
            status, bad = integrate.measure(
                self.q_prev, self.q, self.h, self.law, self.drive, periods, buffers
            )
            self.steps += self.q.size * periods * n
            if status != scheme.OK:
                return status, bad, []
            blocks.append(
                [o.reading(buffers, t, periods, self.h[t]) for t, o in enumerate(self.oscillators)]
            )
        if len(blocks) == 1:
            return scheme.OK, -1, [(r, r.periodic) for r in blocks[0]]
        return (
            scheme.OK,
            -1,
            [
                (combine_readings(head, tail), readings_agree(head, tail, sweep.tolerance))
                for head, tail in zip(*blocks, strict=True)
            ],
        )


def run_sweep_batched(scene: Scene, progress: Progress | None = None) -> SweepResult:
    """Every (direction, sigma) sweep of the scene, advanced together in lockstep.

    The same numbers as :func:`hertzsweep.drivers.sweep.run_sweep` (bit for bit); for
    ``settle_periods = "auto"`` or ``steady_state = "shooting"`` it is ``run_sweep`` itself.

    Parameters
    ----------
    scene : Scene
    progress : callable, optional
        Called with the number of dwells finished (T after each lockstep dwell).

    Raises
    ------
    StabilityError, IntegrationError
        As :func:`~hertzsweep.drivers.sweep.run_sweep` (the first trajectory, in
        (direction, sigma) order, that failed at the dwell where one failed).
    Interrupted
        On SIGINT, with the result so far (lockstep sweeps finish together, so none is
        marked finished).
    """
    if not lockstep(scene):
        return run_sweep(scene, progress)
    check_stability(scene)
    result = SweepResult.empty(scene)
    w = result.frequency_ratio
    pairs = [(d, s) for d in range(len(result.directions)) for s in range(result.sigma.size)]
    n = int(scene.solver.steps_per_period)
    order = np.array([sweep_order(w, result.directions[d]) for d, _ in pairs], dtype=np.int64)
    steps = np.array([scheme.step_size(x, n) for x in w])
    run = Lockstep(scene, np.array([result.sigma[s] for _, s in pairs]), steps[order[:, 0]])
    try:
        for i in range(w.size):
            index = order[:, i]
            status, bad, readings = run.dwell(steps[index])
            if status != scheme.OK:
                direction = result.directions[pairs[bad][0]]
                try:
                    run.oscillators[bad].check_status(status, w[index[bad]])
                except HertzsweepError as exc:
                    raise exc.with_context(f"{scene.source}: {direction} sweep") from None
            for t, (d, s) in enumerate(pairs):
                result.store(d, s, int(index[t]), *readings[t])
            if progress is not None:
                progress(len(pairs))
    except KeyboardInterrupt as exc:
        raise Interrupted(result, getattr(exc, "signal_number", 2)) from None
    result.steps = run.steps
    for d, s in pairs:
        result.jump_frequency_ratio[d, s] = find_jump(
            result.amplitude[d, s, :, 0], w, result.directions[d], scene.sweep.jump_threshold
        )
    result.finished[:] = True
    return result


__all__ = ["Lockstep", "lockstep", "measured_blocks", "run_sweep_batched"]
