"""A sweep's dwells and a trace's record read for the ball's own mode
(:mod:`hertzsweep.core.ballmode`).

A sweep keeps each dwell's end state; once it has run, every dwell whose response
repeats every period is integrated one period more from a copy of that state, all in
one compiled loop (the states the sweep carried are not touched, so every other reading
is the same bit for bit), N/F_s is recorded at each of the N steps, and its harmonics
1 .. N/2 - 1 give the figure ``e``. A dwell that does not repeat is left NaN: one period
of it holds lines that are not the response's. The periods are counted in the run's
integration steps (1/321 of the default dwell). A trace reads its own spectrum.
"""

from __future__ import annotations

import numpy as np

from ..core.ballmode import (
    ball_damping,
    error_of,
    has_ball_mode,
    mode_error,
    period_spectrum,
    power_sums,
)
from ..core.config import Scene
from ..core.rig import derive
from ..kernels import integrate, scheme
from .oscillator import Oscillator, drive


def checked(scene: Scene) -> bool:
    """Whether the scene's rig has a ball whose mode a sweep reads."""
    return has_ball_mode(scene.rig)


class BallModeCheck:
    """The figure ``e`` of dwells of one scene (:meth:`errors`)."""

    def __init__(self, scene: Scene) -> None:
        constants = derive(scene.rig)
        self.ball_mode = constants.ball_mode_frequency
        self.natural_frequency = constants.natural_frequency
        self.zeta_ball = ball_damping(
            scene.damping.ratio, constants.natural_frequency, constants.ball_mode_frequency
        )

    def errors(
        self,
        oscillator: Oscillator,
        sigma: np.ndarray,
        frequency_ratio: np.ndarray,
        end: np.ndarray,
    ) -> np.ndarray:
        """``e`` of T dwells at levels ``sigma`` and frequency ratios ``frequency_ratio``
        (float[T]) that ended at the method's states ``end`` (float[T, 2]), one more
        period each (NaN where its harmonics stop below the ball's mode: too few steps a
        period to see it); the steps are added to ``oscillator.steps``."""
        count = end.shape[0]
        n = oscillator.steps_per_period
        record = np.zeros((n, 4, count))
        buffers = integrate.new_readout(oscillator.harmonics.size, count, record, 1)
        q_prev, q = end[:, 0].copy(), end[:, 1].copy()
        h = np.array([oscillator.step(w) for w in frequency_ratio])
        kernel = oscillator.method.measure_one if count == 1 else oscillator.method.measure
        inputs = drive(oscillator.scene, np.asarray(sigma, dtype=float))
        status, bad = kernel(q_prev, q, h, oscillator.law, inputs, 1, buffers)
        oscillator.steps += count * n
        t = max(bad, 0)
        scheme.check_status(status, float(inputs.sigma[t]), float(frequency_ratio[t]), n)
        orders, amplitude = period_spectrum(record[:, 2, :])
        frequency = np.outer(frequency_ratio * self.natural_frequency, orders)
        errors = mode_error(amplitude, frequency, self.ball_mode, self.zeta_ball)
        # as a trace's: NaN where the lines stop below the ball's mode (coarse steps)
        return np.where(frequency[:, -1] < self.ball_mode, np.nan, errors)


LINES_PER_PART = 1 << 12  # a long trace's spectrum is read in parts of this many lines


def spectrum_errors(
    scene: Scene,
    frequency_ratio: float,
    spectrum: np.ndarray,
    periodic: np.ndarray,
    samples: int,
    periods: int,
) -> np.ndarray | None:
    """``e`` of a trace's spectra (float[S, M/2 + 1] of M = ``samples`` samples over
    ``periods`` periods, line j at order j / periods; the Nyquist line of an even M left
    out, as in a sweep's; read in parts, so that a long record's takes no memory of its
    size):
    None without a ball; NaN where the record does not repeat every period (``periodic``
    false: its leakage is not the response's) and where the spectrum stops below the
    ball's mode (coarse samples: the band that matters is not in it)."""
    if not checked(scene):
        return None
    constants = derive(scene.rig)
    step = frequency_ratio * constants.natural_frequency / periods  # Hz between lines
    lines = samples // 2 if samples % 2 == 0 else samples // 2 + 1  # below the Nyquist
    if (lines - 1) * step < constants.ball_mode_frequency:
        return np.full(spectrum.shape[0], np.nan)
    zeta_ball = ball_damping(
        scene.damping.ratio, constants.natural_frequency, constants.ball_mode_frequency
    )
    total = np.zeros(spectrum.shape[0])
    changed = np.zeros(spectrum.shape[0])
    for start in range(0, lines, LINES_PER_PART):
        stop = min(start + LINES_PER_PART, lines)
        frequency = np.arange(start, stop) * step
        parts = power_sums(
            spectrum[:, start:stop], frequency, constants.ball_mode_frequency, zeta_ball
        )
        total += parts[0]
        changed += parts[1]
    return np.where(periodic, error_of(total, changed), np.nan)


__all__ = ["BallModeCheck", "checked", "spectrum_errors"]
