"""The emulated lock-in amplifier: harmonics of N/F_s from whole-period sums.

A synchronous (whole-period) filter over M samples of P whole periods is the exact
Fourier coefficient of the sampled signal: for harmonic k below the Nyquist order,
``a_k = 2/M sum x_j cos(k theta_j)``, ``b_k = 2/M sum x_j sin(k theta_j)``.

Convention (SPEC): harmonic k is ``A_k sin(k w tau - phi_k)``, so ``b_k = A_k cos phi_k``
and ``a_k = -A_k sin phi_k``; ``phi_k`` is in degrees in [0, 360), the lag behind the
excitation's k-th reference. A lock-in's RMS outputs are ``X = b_k / sqrt 2``,
``Y = a_k / sqrt 2``.

Orders that are not whole: k may be a multiple of 1/2, 1/3 or 1/4 (a subharmonic
response, a period doubling's H1/2). Their common denominator L (the least common multiple
of the orders' reduced denominators: 1, 2, 3, 4, 6 or 12) makes every ``k L`` whole, and
the filter is exact over whole *response periods* of L excitation periods: P must be a
multiple of L. The phase convention is the same, ``tau = 0`` at the first sample read (a
phase-0 point of the excitation), but for an order that is not whole it depends on which
excitation period the record starts at: a record started one excitation period later
reads ``phi_k`` larger by ``360 k`` degrees (mod 360), so the H1/2 phase of a period-2
orbit is defined modulo 180 degrees across records started a period apart.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

ORDER_DENOMINATORS = (1, 2, 3, 4)  # an order is a multiple of 1/D for one of these
ORDER_TOLERANCE = 1e-9  # k D within this (relative to max(1, k D)) of a whole number is one


def order_fraction(order: float) -> Fraction | None:
    """The order k as a fraction of denominator 1, 2, 3 or 4 (reduced), within
    :data:`ORDER_TOLERANCE`; None when it is not one (or not finite)."""
    k = float(order)
    if not math.isfinite(k):
        return None
    for denominator in ORDER_DENOMINATORS:
        scaled = k * denominator
        whole = round(scaled)
        if abs(scaled - whole) <= ORDER_TOLERANCE * max(1.0, abs(scaled)):
            return Fraction(int(whole), denominator)
    return None


def common_denominator(orders) -> int:
    """L: the least common multiple of the orders' denominators (1 for whole orders).

    Raises
    ------
    ValueError
        An order that is not a multiple of 1/2, 1/3 or 1/4.
    """
    denominator = 1
    for order in np.asarray(orders, dtype=float).reshape(-1):
        fraction = order_fraction(order)
        if fraction is None:
            raise ValueError(f"order {order!r} is not a multiple of 1/2, 1/3 or 1/4")
        denominator = math.lcm(denominator, fraction.denominator)
    return denominator


def order_label(order: float) -> str:
    """An order as text: ``2`` for a whole one, ``1/2``, ``3/2``, ``1/3`` for the others
    (``%g`` of it when it is neither)."""
    fraction = order_fraction(order)
    if fraction is None:
        return f"{float(order):g}"
    if fraction.denominator == 1:
        return str(fraction.numerator)
    return f"{fraction.numerator}/{fraction.denominator}"


def parse_order(value: float | str) -> float:
    """An order given as a number or as text (``"2"``, ``"0.5"``, ``"1/2"``, ``"3/2"``)
    as the float a scene stores (1/3 as ``1 / 3.0``).

    Raises
    ------
    ValueError
        Not a number or a fraction, or not an order > 0 that is whole or a multiple of
        1/2, 1/3, 1/4.
    """
    try:
        number = Fraction(value.strip()) if isinstance(value, str) else float(value)
    except (ValueError, ZeroDivisionError):
        raise ValueError(f"{value!r} is not an order (e.g. 2, 0.5 or 1/2)") from None
    fraction = order_fraction(number) if number > 0 else None
    if fraction is None:
        raise ValueError(f"{value!r} is not an order > 0, whole or a multiple of 1/2, 1/3, 1/4")
    return fraction.numerator / float(fraction.denominator)


def first_harmonic_index(orders) -> int:
    """The index among ``orders`` of the one a sweep's jumps, peaks and summaries go by:
    order 1 where it is read, else the lowest whole order, else the first (the first
    order of a scene of whole orders without H1, as before orders that are not whole)."""
    values = [float(k) for k in np.asarray(orders, dtype=float).reshape(-1)]
    if 1.0 in values:
        return values.index(1.0)
    return next((i for i, k in enumerate(values) if k.is_integer()), 0)


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


def demodulate(
    signal: np.ndarray,
    harmonics: np.ndarray | list[float],
    samples_per_period: int,
    response_periods: int | None = None,
):
    """Lock-in reading of a sampled signal over whole response periods (pure numpy).

    Parameters
    ----------
    signal : float[M]
        Samples of N/F_s (or any signal), ``samples_per_period`` per excitation period;
        the first at phase 0 of the excitation (``tau = 0``).
    harmonics : orders k
        Whole, or multiples of 1/2, 1/3, 1/4 of the excitation frequency.
    samples_per_period : int
        Samples of one excitation period.
    response_periods : int, optional
        The excitation periods of one response period, a multiple of the orders' common
        denominator L (default L): the signal must span a whole number of them.

    Returns
    -------
    tuple
        ``(mean, amplitude, phase)``: harmonic k is ``A_k sin(k w tau - phi_k)``, phase in
        degrees in [0, 360). For an order k that is not whole the phase depends on the
        excitation period the record starts at: one period later adds ``360 k`` degrees.

    Raises
    ------
    ValueError
        The signal is not a whole number of response periods, an order is not a
        multiple of 1/2, 1/3 or 1/4, or ``response_periods`` is not a multiple of L.

    Used for records and tests; the sweep reads harmonics inside the compiled loop with
    the same formula (the references' phases ``2 pi (m i mod N L) / (N L)``, ``m = k L``).
    """
    signal = np.asarray(signal, dtype=float)
    orders = np.asarray(harmonics, dtype=float).reshape(-1)
    denominator = common_denominator(orders)
    if response_periods is None:
        response_periods = denominator
    if response_periods < 1 or response_periods % denominator:
        raise ValueError(
            f"a response period of {response_periods} excitation periods is not a multiple "
            f"of the orders' common denominator {denominator}"
        )
    span = response_periods * samples_per_period
    periods, rest = divmod(signal.size, span)
    if periods < 1 or rest:
        raise ValueError(
            f"signal of {signal.size} samples is not a whole number of periods of {span} "
            f"samples ({response_periods} excitation period(s) of {samples_per_period})"
        )
    references = denominator * samples_per_period  # the reference's samples in a cycle
    whole = np.rint(orders * denominator).astype(np.int64)  # m = k L
    position = np.outer(whole, np.arange(signal.size, dtype=np.int64)) % references
    theta = 2.0 * np.pi * position / references  # k w tau, reduced to [0, 2 pi)
    mean = signal.mean()
    x = signal - mean
    sums = np.stack([np.cos(theta) @ x, np.sin(theta) @ x], axis=-1)
    amplitude, phase = amplitude_phase(sums, signal.size)
    return mean, amplitude, phase
