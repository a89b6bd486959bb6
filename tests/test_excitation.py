"""The random excitation (hertzsweep.core.excitation): a unit-variance, band-limited
Gaussian process defined by the seed alone, the same function of tau at any step.

The statistical tests run R = 64 realisations of a record of P = 200 periods on the band
0.2 < w < 3 (K = 560 lines k / P, k = 40 .. 599: the band's ends are whole multiples of
dw = 1 / P, so the expected variance is exactly 1). Their tolerances are 3 standard errors
of the estimators, each stated where it is used. A record holds 2K independent Gaussian
coefficients: its n_eff = 2K = 1120 is the number of independent samples of one record.
With rho_j the process's correlation at lag j (over the L samples of a record, circular),
``(1/L) sum_j rho_j^2 = 1 / (2K)`` exactly, and since ``|rho| <= 1``, ``sum_j rho_j^3`` and
``sum_j rho_j^4`` are at most ``sum_j rho_j^2``: the variances ``(6/L^2) sum rho^3`` and
``(24/L^2) sum rho^4`` of the sample skewness and kurtosis (their He3 and He4 parts; the
record's mean is exactly 0 and the normalisation by its variance removes the He2 part) are
at most 6 / n_eff and 24 / n_eff.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hertzsweep.core.excitation import (
    band_lines,
    coefficients,
    forcing_phases,
    linear_response_variance,
    transmissibility,
    unit_forcing,
)

SEED = 7
BAND = (0.2, 3.0)
PERIODS = 200  # P: 0.2 P = 40 and 3.0 P = 600 are whole, so K dw / (w_high - w_low) = 1
STEPS = 16  # N: Nyquist w = 8, above the band; L = N P = 3200 samples a record
REALISATIONS = 64  # R
LINES = 560  # K = (3.0 - 0.2) x 200
N_EFF = 2 * LINES  # independent samples of one record (module docstring)
WIDTH = BAND[1] - BAND[0]


@pytest.fixture(scope="module")
def records() -> np.ndarray:
    """[R, L]: the R realisations' unit forcing."""
    return np.stack([unit_forcing(SEED, r, BAND, PERIODS, STEPS) for r in range(REALISATIONS)])


def test_the_band_holds_its_lines():
    k = band_lines(BAND, PERIODS)
    assert k.size == LINES and (k[0], k[-1]) == (40, 599)
    # k / P in floating point decides: 0.1 * 30 is 3.0000000000000004 in floating point,
    # so a line at exactly w_high = 0.3 x 10 stays out, one at w_low = 0.1 x 10 stays in
    assert band_lines((0.1, 0.3), 10).tolist() == [1, 2]


@pytest.mark.parametrize(
    ("steps", "per_step", "phases"),
    [(STEPS, 1, 1), (256, 1, 8), (96, 2, 6), (64, 1, 2)],
)
def test_the_samples_are_the_sum_of_its_lines(steps, per_step, phases):
    # the definition: g(tau) = sum_k a_k cos(k tau / P) + b_k sin(k tau / P) at tau_j =
    # j h / m (h = 2 pi / N), evaluated directly at samples of every phase (one inverse FFT
    # over every sample at 16 a period, 8, 6 and 2 phases of 32 a period otherwise); the
    # FFTs' rounding on O(1) values is ~1e-15
    assert forcing_phases(per_step * steps, BAND[1]) == phases
    g = unit_forcing(SEED, 3, BAND, PERIODS, steps, per_step=per_step)
    k, a, b = coefficients(SEED, 3, BAND, PERIODS)
    j = np.unique(np.r_[0:17, 1600:1613, np.random.default_rng(1).integers(0, g.size, 40)])
    j = np.r_[j, g.size - 1]
    tau = j * 2.0 * np.pi / (per_step * steps)
    phase = np.outer(tau, k / PERIODS)
    direct = np.cos(phase) @ a + np.sin(phase) @ b
    assert np.max(np.abs(g[j] - direct)) < 1e-12


def test_the_phases_keep_the_band_below_their_nyquist_frequency():
    # C = S / L samples a period a phase: at least 32 and at least 2 w_high, the largest L
    assert forcing_phases(256, 3.0) == 8  # C = 32
    assert forcing_phases(128, 20.0) == 2  # C = 64 >= 40
    assert forcing_phases(128, 40.0) == 1  # C = 128: no divisor from 80 to 127
    assert forcing_phases(16, 3.0) == 1  # fewer than 32 a period: one FFT
    assert forcing_phases(100, 3.0) == 2  # C = 50: the divisors of 100 from 32 up
    assert forcing_phases(97, 3.0) == 1  # a prime


def test_a_strided_out_is_filled_as_a_new_array():
    table = np.zeros((PERIODS * 64, 3))
    got = unit_forcing(SEED, 2, BAND, PERIODS, 64, out=table[:, 1])
    assert got is not None and np.shares_memory(got, table)
    assert np.array_equal(table[:, 1], unit_forcing(SEED, 2, BAND, PERIODS, 64))
    assert not table[:, 0].any() and not table[:, 2].any()
    with pytest.raises(ValueError, match="out must be float64"):
        unit_forcing(SEED, 2, BAND, PERIODS, 64, out=np.zeros(10))


def test_the_variance_is_one(records):
    # each record's variance (the record's mean is 0: every line completes whole periods);
    # its mean over R realisations has the standard error std(ddof=1) / sqrt(R), about
    # 1 / sqrt(K R) = 0.0053 (a record's variance is s^2 sum (a_k^2 + b_k^2) / 2, sd
    # 1 / sqrt(K))
    variance = records.var(axis=1)
    stderr = variance.std(ddof=1) / math.sqrt(REALISATIONS)
    assert abs(variance.mean() - 1.0) < 3.0 * stderr
    assert stderr == pytest.approx(1.0 / math.sqrt(LINES * REALISATIONS), rel=0.3)  # sd of sd
    assert np.max(np.abs(records.mean(axis=1))) < 1e-15


def test_the_psd_is_flat_on_the_band_and_zero_outside(records):
    # the periodogram of each whole record, averaged over the realisations (Welch's average
    # with one segment a record): a record is one period of g, so it needs no window and
    # leaks nothing; one-sided per unit w, bins dw = 1 / P apart, S = 2 |G_m|^2 P / L^2,
    # in units of the flat S_f = 1 / (w_high - w_low)
    length = records.shape[1]
    spectrum = np.fft.rfft(records, axis=1)
    psd = 2.0 * np.abs(spectrum) ** 2 * PERIODS / length**2 * WIDTH
    inside = np.zeros(psd.shape[1], dtype=bool)
    inside[band_lines(BAND, PERIODS)] = True
    # on the band each bin of each record is (a_k^2 + b_k^2) / (2 s^2): exponential, mean 1
    # and sd 1, independent across bins and records. Averaged over the R records and over
    # groups of 20 adjacent bins (Welch's frequency averaging), each group's mean has the
    # standard error std(ddof=1) / sqrt(20 R) (about 0.028): every one of the 28 groups
    # within 3 of them
    groups = psd[:, inside].reshape(REALISATIONS, -1, 20).transpose(1, 0, 2).reshape(28, -1)
    stderr = groups.std(axis=1, ddof=1) / math.sqrt(groups.shape[1])
    assert np.all(np.abs(groups.mean(axis=1) - 1.0) < 3.0 * stderr)
    # and the whole band's level: standard error about 1 / sqrt(K R) = 0.0053
    band = psd[:, inside].mean(axis=1)
    assert abs(band.mean() - 1.0) < 3.0 * band.std(ddof=1) / math.sqrt(REALISATIONS)
    # outside the band the process has no component: only the FFTs' rounding (~1e-32
    # relative in power)
    assert np.max(psd[:, ~inside]) < 1e-20


def test_the_samples_are_gaussian(records):
    # each record's sample skewness and kurtosis, averaged over R records: standard errors
    # at most sqrt(6 / n_eff) / sqrt(R) = 0.0091 and sqrt(24 / n_eff) / sqrt(R) = 0.018
    # (n_eff = 2K, module docstring)
    centred = records - records.mean(axis=1, keepdims=True)
    variance = (centred**2).mean(axis=1)
    skewness = (centred**3).mean(axis=1) / variance**1.5
    kurtosis = (centred**4).mean(axis=1) / variance**2
    assert abs(skewness.mean()) < 3.0 * math.sqrt(6.0 / N_EFF / REALISATIONS)
    assert abs(kurtosis.mean() - 3.0) < 3.0 * math.sqrt(24.0 / N_EFF / REALISATIONS)


def test_realisations_are_independent(records):
    # the sample correlation of two independent records has the variance (1/L) sum_j
    # rho_j^2 = 1 / (2K) = 1 / n_eff: within 3 / sqrt(n_eff) = 0.090
    bound = 3.0 / math.sqrt(N_EFF)
    correlation = np.corrcoef(records)
    assert abs(correlation[0, 1]) < bound
    other_seed = unit_forcing(SEED + 1, 0, BAND, PERIODS, STEPS)
    assert abs(np.corrcoef(records[0], other_seed)[0, 1]) < bound
    # over the 2016 pairs of the 64 records, 0.27 % are expected beyond 3 standard errors
    # (5.4 pairs, sd 2.3): at most 1 % of them (20)
    pairs = correlation[np.triu_indices(REALISATIONS, 1)]
    assert np.mean(np.abs(pairs) >= bound) <= 0.01
    # and their mean square is 1 / n_eff within 3 standard errors (each r^2 n_eff is about
    # chi-square with 1 degree of freedom: sd sqrt(2) / n_eff; the pairs are uncorrelated)
    assert abs(np.mean(pairs**2) * N_EFF - 1.0) < 3.0 * math.sqrt(2.0 / pairs.size)


def test_the_same_function_at_any_step():
    # the half steps of rk4 (per_step = 2) add samples between the steps' own, and a halved
    # step samples the same g: at common times equal to the FFTs' rounding (~1e-15)
    coarse = unit_forcing(SEED, 1, BAND, PERIODS, 64)
    halves = unit_forcing(SEED, 1, BAND, PERIODS, 64, per_step=2)
    fine = unit_forcing(SEED, 1, BAND, PERIODS, 128)
    assert halves.size == fine.size == 2 * coarse.size
    assert np.max(np.abs(halves[::2] - coarse)) < 1e-12
    assert np.max(np.abs(fine[::2] - coarse)) < 1e-12
    assert np.max(np.abs(halves - fine)) < 1e-12


def test_the_same_arguments_give_the_same_bits():
    first = unit_forcing(SEED, 5, BAND, PERIODS, STEPS)
    again = unit_forcing(SEED, 5, BAND, PERIODS, STEPS)
    assert first.tobytes() == again.tobytes()
    assert not np.array_equal(first, unit_forcing(SEED, 6, BAND, PERIODS, STEPS))
    assert not np.array_equal(first, unit_forcing(SEED + 1, 5, BAND, PERIODS, STEPS))


@pytest.mark.parametrize("realisation", [0, 3, 15])
def test_a_realisations_stream_does_not_depend_on_how_many_there_are(realisation):
    # the coefficients read back from the samples (G_k = (L/2)(a_k - i b_k)) are the draws
    # of the r-th child of SeedSequence(seed).spawn(R), for R = r + 1 and R = 64 alike,
    # a_k then b_k for each k in increasing order
    g = unit_forcing(SEED, realisation, BAND, PERIODS, STEPS)
    k = band_lines(BAND, PERIODS)
    spectrum = np.fft.rfft(g)[k] * 2.0 / g.size
    read = np.column_stack([spectrum.real, -spectrum.imag]).ravel()
    scale = math.sqrt((1.0 / PERIODS) / WIDTH)
    for count in (realisation + 1, 64):
        child = np.random.SeedSequence(SEED).spawn(count)[realisation]
        draws = np.random.default_rng(child).standard_normal(2 * k.size) * scale
        assert np.max(np.abs(read - draws)) < 1e-12


def test_the_forcing_refuses_a_band_beyond_the_steps_nyquist():
    with pytest.raises(ValueError, match="Nyquist"):
        unit_forcing(SEED, 0, (0.2, 8.0), PERIODS, STEPS)
    with pytest.raises(ValueError, match="band"):
        unit_forcing(SEED, 0, (3.0, 0.2), PERIODS, STEPS)
    with pytest.raises(ValueError, match="realisation"):
        unit_forcing(SEED, -1, BAND, PERIODS, STEPS)


def test_transmissibility():
    zeta = 0.0045
    assert transmissibility(0.0, zeta) == 1.0
    # at resonance |H| = sqrt(1 + 4 zeta^2) / (2 zeta) and N lags f by atan(1 / (2 zeta))
    h = transmissibility(1.0, zeta)
    assert abs(h) == pytest.approx(math.sqrt(1.0 + 4.0 * zeta**2) / (2.0 * zeta), rel=1e-14)
    assert -np.angle(h) == pytest.approx(math.atan(1.0 / (2.0 * zeta)), rel=1e-14)


@pytest.mark.parametrize("zeta", [1e-4, 0.0045, 0.05, 0.7, 2.0])
def test_the_linear_response_variance(zeta):
    # against a trapezoid on 2e5 intervals of the band plus 2e5 on 1 +- 50 zeta (the peak's
    # half width zeta over 2000 of them): its error (dw^2 / 12) |H''| / |H| is below 1e-6
    # relative, where the outer spacing 1.4e-5 meets the peak's flank 50 zeta away
    resonance = np.linspace(1.0 - 50.0 * zeta, 1.0 + 50.0 * zeta, 200_001)
    w = np.union1d(
        np.linspace(BAND[0], BAND[1], 200_001),
        resonance[(resonance > BAND[0]) & (resonance < BAND[1])],
    )
    power = np.abs(transmissibility(w, zeta)) ** 2
    dense = float(np.sum((power[1:] + power[:-1]) * 0.5 * np.diff(w))) / WIDTH
    assert linear_response_variance(BAND, zeta) == pytest.approx(dense, rel=1e-6)


@pytest.mark.parametrize("zeta", [1e-3, 0.0045, 0.3])
def test_the_whole_axis_bounds_the_band(zeta):
    # the preflight's closed form: integral over w > 0 of |H|^2 = pi (1 + 4 zeta^2) / (4
    # zeta); over (1e-9, 1e4) it lacks only the tail beyond 1e4, about 4 zeta^2 / 1e4 +
    # 1 / (3e12), 4e-5 absolute at most: within 1e-6 relative of the whole (above 2.6)
    whole = math.pi * (1.0 + 4.0 * zeta**2) / (4.0 * zeta)
    band = (1e-9, 1e4)
    wide = linear_response_variance(band, zeta) * (band[1] - band[0])
    assert wide == pytest.approx(whole, rel=1e-6 + 4.0 * zeta**2 / 1e4 / whole)
    assert linear_response_variance(BAND, zeta) * WIDTH < whole


def test_an_undamped_resonance_in_the_band_has_no_finite_variance():
    assert linear_response_variance(BAND, 0.0) == math.inf
    assert math.isfinite(linear_response_variance((1.5, 3.0), 0.0))
