"""The emulated lock-in amplifier: harmonics of N/F_s from whole-period sums.

A synchronous (whole-period) filter over M samples of P whole periods is the exact
Fourier coefficient of the sampled signal: for harmonic k below the Nyquist order,
``a_k = 2/M sum x_j cos(k theta_j)``, ``b_k = 2/M sum x_j sin(k theta_j)``.

Convention (SPEC): harmonic k is ``A_k sin(k w tau - phi_k)``, so ``b_k = A_k cos phi_k``
and ``a_k = -A_k sin phi_k``; ``phi_k`` is in degrees in [0, 360), the lag behind the
excitation's k-th reference. A lock-in's RMS outputs are ``X = b_k / sqrt 2``,
``Y = a_k / sqrt 2``.
"""

from __future__ import annotations

import numpy as np


def amplitude_phase(coefficients: np.ndarray, samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude and phase [degree] from the kernel's sums.

    Parameters
    ----------
    coefficients : float[..., 2]
        ``sum x cos(k theta)``, ``sum x sin(k theta)`` over ``samples`` samples.
    samples : int
        Number of samples M (whole periods).
    """
    a = 2.0 * coefficients[..., 0] / samples
    b = 2.0 * coefficients[..., 1] / samples
    amplitude = np.hypot(a, b)
    phase = np.degrees(np.arctan2(-a, b)) % 360.0
    phase = np.where(phase >= 360.0, 0.0, phase)  # -0.0 % 360 can round to 360
    return amplitude, phase


def complex_amplitude(amplitude: np.ndarray, phase_degree: np.ndarray) -> np.ndarray:
    """``A exp(-i phi)``: the complex amplitude of ``A sin(k w tau - phi)``."""
    return amplitude * np.exp(-1j * np.radians(phase_degree))


def lockin_xy(amplitude: np.ndarray, phase_degree: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RMS in-phase and quadrature outputs ``X, Y`` of a lock-in amplifier."""
    phi = np.radians(phase_degree)
    return amplitude * np.cos(phi) / np.sqrt(2.0), -amplitude * np.sin(phi) / np.sqrt(2.0)


def demodulate(signal: np.ndarray, harmonics: np.ndarray | list[int], samples_per_period: int):
    """Lock-in reading of a sampled signal over whole periods (pure numpy).

    The signal's first sample is at phase 0 of the reference. Returns ``(mean,
    amplitude, phase)``. Used for records and tests; the sweep reads harmonics inside
    the compiled loop with the same formula.
    """
    signal = np.asarray(signal, dtype=float)
    periods, rest = divmod(signal.size, samples_per_period)
    if periods < 1 or rest:
        raise ValueError(
            f"signal of {signal.size} samples is not a whole number of periods "
            f"of {samples_per_period} samples"
        )
    harmonics = np.asarray(harmonics, dtype=np.int64)
    theta = 2.0 * np.pi * np.arange(signal.size) / samples_per_period
    mean = signal.mean()
    x = signal - mean
    sums = np.stack(
        [np.cos(np.outer(harmonics, theta)) @ x, np.sin(np.outer(harmonics, theta)) @ x], axis=-1
    )
    amplitude, phase = amplitude_phase(sums, signal.size)
    return mean, amplitude, phase
