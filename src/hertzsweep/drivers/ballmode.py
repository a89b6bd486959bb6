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

from ..core.ballmode import ball_damping, error_of, has_ball_mode, power_sums
from ..core.config import Scene
from ..core.rig import derive
from ..kernels import integrate, scheme
from .oscillator import Oscillator, drive
from .spectrum import AmplitudeSpectrum

LINES_PER_PART = 1 << 12  # a long trace's spectrum is read in parts of this many lines


class BallModeCheck:
    """The figure ``e`` of a scene's spectra (:meth:`of_spectra`), of a sweep's dwells
    (:meth:`errors`)."""

    def __init__(self, scene: Scene) -> None:
        constants = derive(scene.rig)
        self.ball_mode = constants.ball_mode_frequency
        self.natural_frequency = constants.natural_frequency
        self.zeta_ball = ball_damping(
            scene.damping.ratio, constants.natural_frequency, constants.ball_mode_frequency
        )

    def of_spectra(
        self, spectrum: np.ndarray, line_step: np.ndarray, samples: int, periodic: np.ndarray
    ) -> np.ndarray:
        """``e`` of amplitude spectra (float[S, M/2 + 1] of M = ``samples`` samples,
        :class:`~.spectrum.AmplitudeSpectrum`'s convention), line j of spectrum s at
        ``j line_step[s]`` Hz; the Nyquist line of an even M is left out, and the lines are
        read in parts, so that a long record's take no memory of its size. NaN where the
        record does not repeat every period (``periodic`` false: its leakage is not the
        response's) and where the lines stop below the ball's mode (too few samples a
        period: the band that matters is not in them)."""
        lines = (samples + 1) // 2  # the bins below the Nyquist frequency
        total = np.zeros(spectrum.shape[0])
        changed = np.zeros(spectrum.shape[0])
        for start in range(0, lines, LINES_PER_PART):
            stop = min(start + LINES_PER_PART, lines)
            frequency = np.outer(line_step, np.arange(start, stop))
            part = power_sums(spectrum[:, start:stop], frequency, self.ball_mode, self.zeta_ball)
            total += part[0]
            changed += part[1]
        seen = (lines - 1) * np.asarray(line_step) >= self.ball_mode
        return np.where(periodic & seen, error_of(total, changed), np.nan)

    def errors(
        self,
        oscillator: Oscillator,
        sigma: np.ndarray,
        frequency_ratio: np.ndarray,
        end: np.ndarray,
    ) -> np.ndarray:
        """``e`` of T dwells at levels ``sigma`` and frequency ratios ``frequency_ratio``
        (float[T]) that ended at the method's states ``end`` (float[T, 2]), one more
        period each (:meth:`of_spectra`); the steps are added to ``oscillator.steps``."""
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
        analyser = AmplitudeSpectrum(n, backend="numpy")  # a sweep does not load FFTW
        spectrum = np.array([analyser.amplitude(record[:, 2, t]) for t in range(count)])
        line_step = np.asarray(frequency_ratio) * self.natural_frequency
        return self.of_spectra(spectrum, line_step, n, np.ones(count, dtype=bool))


def spectrum_errors(
    scene: Scene,
    frequency_ratio: float,
    spectrum: np.ndarray,
    periodic: np.ndarray,
    samples: int,
    periods: int,
) -> np.ndarray | None:
    """``e`` of a trace's spectra (float[S, M/2 + 1] of M = ``samples`` samples over
    ``periods`` periods, line j at order j / periods; :meth:`BallModeCheck.of_spectra`),
    None where the rig has no ball."""
    if not has_ball_mode(scene):
        return None
    check = BallModeCheck(scene)
    step = frequency_ratio * check.natural_frequency / periods  # Hz between lines
    return check.of_spectra(spectrum, np.full(spectrum.shape[0], step), samples, periodic)


__all__ = ["BallModeCheck", "spectrum_errors"]
