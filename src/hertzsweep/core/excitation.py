"""The random excitation: a unit-variance, band-limited Gaussian process of tau.

A random scene (``excitation.kind = "random"``) drives the load ``1 + rms g(tau)`` in the
place of the sine's ``1 + sigma sin(w tau)`` (eq. 8 and 11 of Part 1; the Gaussian input of
Part 2). The process is a sum of discrete lines over one record of ``P`` periods
(``P = transient_periods + duration_periods``, a period being ``2 pi`` in tau)::

    g(tau) = sum_k a_k cos(w_k tau) + b_k sin(w_k tau),   w_k = k / P,
    a_k, b_k ~ N(0, 1) sqrt(dw / (w_high - w_low)),         dw = 1 / P,

over the integers k with ``w_low <= k / P < w_high``. Its one-sided PSD per unit w is
``S_f = 1 / (w_high - w_low)`` on the band (mean power ``dw S_f`` a line) and nothing
outside it; its variance is ``K dw / (w_high - w_low)``, 1 when the band's ends are whole
multiples of ``dw`` (K lines) and within ``dw / (w_high - w_low)`` of 1 otherwise. Its
period is ``2 pi P``: the record is one period, with no repeat inside it.

The coefficients of realisation r come from their own stream,
``numpy.random.default_rng(numpy.random.SeedSequence(seed, spawn_key=(r,)))`` (the r-th
child of ``SeedSequence(seed).spawn(R)`` for any R > r, so a realisation does not depend on
how many a scene runs), drawn for k in increasing order, ``a_k`` then ``b_k`` for each k
(interleaved). They depend on (seed, realisation, band, P) alone: not on the method nor
the step. :func:`unit_forcing` samples g at ``tau_j = j h / m`` (``h = 2 pi / N``; m = 1:
the steps, m = 2: the steps and the half steps of rk4) by inverse real FFTs, one for each
phase of the samples (:func:`forcing_phases`), so a finer step samples the same function.

:func:`linear_response_variance` and :func:`transmissibility` give the linear model's
response to it (eq. 8 linearised about the static equilibrium ``q = 0``).

This module needs numpy only (scipy is imported by :func:`linear_response_variance` when
called).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

# The quadrature of |H|^2 is given breakpoints where it changes scale: at the resonance
# w = 1, at 1 +- zeta RESONANCE_RATIO^j (j = 0, 1, ...: the peak's half-power half width
# zeta, then widths growing by this ratio until they pass w = 1 or 0), and at the octaves
# 2^j across the band, so that a band of many decades (up to 2^19, the largest Nyquist
# frequency) does not hide a peak of width 2 zeta from the adaptive rule.
RESONANCE_RATIO = 4.0
# The subintervals quad may use: a few per breakpoint (at most about 50 of them: 19 octaves
# either side of 1 and 10 resonance widths at zeta = 1e-6).
QUAD_LIMIT = 500
# Relative accuracy asked of quad: far below the 3 standard errors (a few percent) the
# variance is compared with in the tests of the random run.
QUAD_RELATIVE_TOLERANCE = 1e-10
# The fewest samples a period of one phase of the forcing (hertzsweep.core.excitation.
# forcing_phases): at 256 samples a period, 8, 16 and 32 a phase all took 8 ns a sample
# (numpy's inverse FFT), against 16 ns for one FFT over every sample.
FORCING_PHASE_LEAST = 32
# numpy.fft.irfft writes into a given array from numpy 2.0 on
IRFFT_OUT = int(np.__version__.split(".")[0]) >= 2


def band_lines(band: tuple[float, float], periods: int) -> np.ndarray:
    """The line numbers k of a record of ``periods`` periods: the integers with
    ``w_low <= k / periods < w_high`` (``k / periods`` evaluated in floating point, the
    definition the coefficients' stream follows), in increasing order.

    Parameters
    ----------
    band : (float, float)
        ``(w_low, w_high)``, frequency ratios, ``0 < w_low < w_high``.
    periods : int
        The record's length P in periods (``2 pi`` in tau each), at least 1.

    Returns
    -------
    numpy.ndarray
        int64, possibly empty (a band narrower than ``1 / periods``).
    """
    low, high = _check_band(band)
    periods = _whole(periods, "periods")
    # candidates a line either side of the exact range, then the definition applied as is
    first = max(int(math.floor(low * periods)) - 1, 1)
    last = int(math.ceil(high * periods)) + 1
    k = np.arange(first, last + 1, dtype=np.int64)
    w = k / periods
    return k[(w >= low) & (w < high)]


def coefficients(
    seed: int, realisation: int, band: tuple[float, float], periods: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The lines of realisation ``realisation``: ``(k, a_k, b_k)``.

    Parameters
    ----------
    seed : int
        ``excitation.seed``, >= 0.
    realisation : int
        The realisation r, >= 0: its stream is ``SeedSequence(seed, spawn_key=(r,))``.
    band : (float, float)
        ``(w_low, w_high)``.
    periods : int
        The record's length P in periods.

    Returns
    -------
    k : numpy.ndarray
        The line numbers (:func:`band_lines`), ``w_k = k / P``.
    a, b : numpy.ndarray
        The cosine and sine coefficients, ``N(0, 1) sqrt(dw / (w_high - w_low))``, drawn
        ``a_k`` then ``b_k`` for each k in increasing order.
    """
    low, high = _check_band(band)
    seed = _whole(seed, "seed", 0)
    realisation = _whole(realisation, "realisation", 0)
    k = band_lines(band, periods)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(realisation,)))
    scale = math.sqrt((1.0 / periods) / (high - low))  # sqrt(dw / (w_high - w_low))
    draws = rng.standard_normal(2 * k.size).reshape(k.size, 2) * scale
    return k, draws[:, 0].copy(), draws[:, 1].copy()


def unit_forcing(
    seed: int,
    realisation: int,
    band: tuple[float, float],
    periods: int,
    steps_per_period: int,
    per_step: int = 1,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """The unit-variance process g of realisation ``realisation``, sampled over its record.

    Parameters
    ----------
    seed : int
        ``excitation.seed``, >= 0.
    realisation : int
        The realisation r, >= 0 (its own stream, :func:`coefficients`).
    band : (float, float)
        ``(w_low, w_high)``: ``w_high`` below the step's Nyquist ``steps_per_period / 2``.
    periods : int
        The record's length P in periods: ``transient_periods + duration_periods``.
    steps_per_period : int
        N, the steps of ``h = 2 pi / N`` a period.
    per_step : int
        m, samples a step: 1 (the steps) or 2 (the steps and the half steps of rk4); any
        whole number >= 1.
    out : numpy.ndarray, optional
        float64[m N P], possibly strided (a column of a table of realisations), which the
        samples are written into and which is returned. The same numbers either way.

    Returns
    -------
    numpy.ndarray
        float64 of length ``m N P``: ``g(j h / m)`` for ``j = 0 .. m N P - 1``; the force
        on the contact is ``F/F_s = rms g``. The process's lines are ``w_k = k / P'``
        (``P' = process_periods(P)`` >= P). With ``S = m N`` samples a period taken as
        ``L`` phases of ``C = S / L`` (:func:`forcing_phases`), the samples
        ``j = i L + l`` of phase l are one inverse real FFT of length ``M = C P'``,
        ``X[k] = (M / 2) (a_k - i b_k) exp(2 pi i k l / (L M))`` on the band's lines and 0
        elsewhere, since ``w_k tau_j = 2 pi k (i L + l) / (L M)``; ``C >= 2 w_high`` keeps
        every line below the phase's Nyquist bin ``M / 2``. The samples at every m-th index
        are those of ``per_step = 1``, and so are those of a step halved, to rounding
        (1e-15).

    Raises
    ------
    ValueError
        A band not within ``(0, steps_per_period / 2)``, a length not a whole number
        >= 1, or an ``out`` of another shape or type.
    """
    phases = Phases(seed, realisation, band, periods, steps_per_period, per_step)
    if out is None:
        out = np.empty(phases.record)
    elif out.shape != (phases.record,) or out.dtype != np.float64:
        raise ValueError(f"out must be float64[{phases.record}], got {out.dtype}{list(out.shape)}")
    samples = np.empty(phases.size)
    for phase in range(phases.phases):
        phases.samples(phase, samples)
        out[phase :: phases.phases] = samples[: phases.count]
    return out


class Phases:
    """The samples of one realisation of the process over its record, phase by phase
    (:func:`unit_forcing`): phase l holds the samples ``j = i L + l`` (``i = 0 ..
    count - 1``), each phase one inverse real FFT of ``size`` (M) samples.

    Parameters
    ----------
    seed, realisation, band, periods, steps_per_period, per_step
        Those of :func:`unit_forcing`, in its order.

    Raises
    ------
    ValueError
        A band not within ``(0, steps_per_period / 2)``, or a length not a whole number
        >= 1.
    """

    def __init__(self, *process: Any) -> None:
        if not 5 <= len(process) <= 6:
            raise TypeError(f"Phases takes 5 or 6 arguments (unit_forcing's), got {len(process)}")
        seed, realisation, band, periods, steps_per_period, *rest = process
        low, high = _check_band(band)
        periods = _whole(periods, "periods")
        steps_per_period = _whole(steps_per_period, "steps_per_period")
        per_step = _whole(rest[0] if rest else 1, "per_step")
        if not high < steps_per_period / 2:
            raise ValueError(
                f"band {low:g} .. {high:g} reaches the step's Nyquist frequency "
                f"steps_per_period / 2 = {steps_per_period / 2:g}"
            )
        per_period = per_step * steps_per_period
        period = process_periods(periods)
        self.phases = forcing_phases(per_period, high)  # L
        self.record = per_period * periods  # the samples of the record
        self.count = self.record // self.phases  # a phase's samples of the record
        self.size = per_period // self.phases * period  # M: a phase's over the process
        self._k, a, b = coefficients(seed, realisation, band, period)
        self._lines = (self.size / 2.0) * (a - 1j * b)
        # the line k turned by exp(2 pi i k l / (L M)) at phase l: k < M / 2 and l < L, so
        # k l < L M, an angle below 2 pi, exact in its float
        self._turn = (2.0 * math.pi / (self.phases * self.size)) * self._k
        self._spectrum = np.zeros(self.size // 2 + 1, dtype=np.complex128)

    def samples(self, phase: int, out: np.ndarray) -> np.ndarray:
        """Phase ``phase``'s samples over the process's period, written into ``out``
        (float64[M], contiguous); its first :attr:`count` are the record's."""
        lines = self._lines
        self._spectrum[self._k] = lines * np.exp(1j * phase * self._turn) if phase else lines
        if IRFFT_OUT:
            np.fft.irfft(self._spectrum, self.size, out=out)
        else:
            out[:] = np.fft.irfft(self._spectrum, self.size)
        return out


def forcing_phases(per_period: int, high: float) -> int:
    """L, the phases :func:`unit_forcing` samples a period of ``per_period`` samples in:
    the largest divisor of ``per_period`` that leaves each phase ``C = per_period / L``
    samples a period, with ``C >= 2 w_high`` (the band's lines below the phase's Nyquist
    frequency) and ``C >= FORCING_PHASE_LEAST`` (an FFT long enough to pay its way). 1 (one
    FFT over every sample) when no other divisor does. L inverse FFTs of length ``M = C P'``
    cost ``S P' log M`` against ``S P' log(S P')`` for one over every sample, and each
    works in a cache M floats long: at 256 samples a period and a band to w = 3, L = 8
    halves the forcing's time."""
    per_period = _whole(per_period, "per_period")
    least = max(FORCING_PHASE_LEAST, 2.0 * float(high))
    for phases in range(per_period, 0, -1):
        if per_period % phases == 0 and per_period // phases >= least:
            return phases
    return 1


def process_periods(periods: int) -> int:
    """The process's period P' in periods: the smallest whole number >= the record's
    ``periods`` with no prime factor above 5, so that the inverse FFT of length m N P'
    (N a power of two, or 5-smooth) runs at full speed (a record of 2200 periods, 2^3 5^2
    11, takes a process of 2250 = 2 3^2 5^3: its lines 2 % closer, the record one stretch
    of it, no repeat inside). It depends on ``periods`` alone, so every step samples the
    same process."""
    period = int(periods)
    while True:
        rest = period
        for prime in (2, 3, 5):
            while rest % prime == 0:
                rest //= prime
        if rest == 1:
            return period
        period += 1


def transmissibility(w: float | np.ndarray, zeta: float) -> complex | np.ndarray:
    """The linear model's force transmissibility ``H(w) = (1 + 2 i zeta w) / (1 - w^2 +
    2 i zeta w)``: N/F_s - 1 over f = F/F_s at small levels (eq. 8 linearised about
    ``q = 0``, where the Hertz stiffness is 1 and the viscous and contact laws both damp
    with ``2 zeta q'``).

    Parameters
    ----------
    w : float or array
        Frequency ratios.
    zeta : float
        ``damping.ratio``.

    Returns
    -------
    complex or numpy.ndarray
        H, complex: ``|H|`` the amplitude, ``-angle(H)`` the lag of N behind f.
    """
    w = np.asarray(w, dtype=np.float64)
    damping = 2j * zeta * w
    out = (1.0 + damping) / (1.0 - w * w + damping)
    return complex(out) if out.ndim == 0 else out


def linear_response_variance(band: tuple[float, float], zeta: float) -> float:
    """The variance of N/F_s of the linear model under the unit-variance process:
    ``integral over the band of |H(w)|^2 S_f dw`` with ``S_f = 1 / (w_high - w_low)``
    (:func:`transmissibility`); multiply by ``rms^2`` for a level.

    By ``scipy.integrate.quad`` with breakpoints at the resonance ``w = 1``, at widths
    ``zeta``, ``4 zeta``, ``16 zeta``, ... either side of it and at the octaves ``2^j``
    inside the band (:data:`RESONANCE_RATIO`). Undamped (``zeta = 0``), a band holding
    ``w = 1`` gives ``inf``.

    Parameters
    ----------
    band : (float, float)
        ``(w_low, w_high)``, ``0 < w_low < w_high``.
    zeta : float
        ``damping.ratio``, >= 0.

    Returns
    -------
    float
        The variance (dimensionless): about ``pi / (4 zeta (w_high - w_low))`` for a
        lightly damped resonance inside the band, plus the band's off-resonance share.
    """
    from scipy import integrate

    low, high = _check_band(band)
    if not zeta >= 0.0:
        raise ValueError(f"zeta must be >= 0, got {zeta!r}")
    if zeta == 0.0 and low <= 1.0 <= high:
        return math.inf

    def power(w: float) -> float:  # |H(w)|^2, in floats (quad calls it thousands of times)
        damping = (2.0 * zeta * w) ** 2
        return (1.0 + damping) / ((1.0 - w * w) ** 2 + damping)

    marks = {1.0}
    width = zeta
    while 0.0 < width < 1.0:
        marks |= {1.0 - width, 1.0 + width}
        width *= RESONANCE_RATIO
    octaves = range(math.floor(math.log2(low)) + 1, math.ceil(math.log2(high)))
    marks |= {2.0**j for j in octaves}
    points = sorted(p for p in marks if low < p < high)
    value, _ = integrate.quad(
        power,
        low,
        high,
        points=points or None,
        limit=QUAD_LIMIT,
        epsrel=QUAD_RELATIVE_TOLERANCE,
    )
    return value / (high - low)


def _check_band(band: tuple[float, float]) -> tuple[float, float]:
    low, high = (float(v) for v in band)
    if not (math.isfinite(high) and 0.0 < low < high):
        raise ValueError(f"band must satisfy 0 < w_low < w_high (finite), got {band!r}")
    return low, high


def _whole(value: int, name: str, least: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < least:
        raise ValueError(f"{name} must be a whole number >= {least}, got {value!r}")
    return int(value)


__all__ = [
    "band_lines",
    "coefficients",
    "forcing_phases",
    "linear_response_variance",
    "Phases",
    "transmissibility",
    "unit_forcing",
]
