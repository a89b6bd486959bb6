"""The emulated lock-in: exact Fourier coefficients over whole periods."""

import numpy as np
import pytest

from hertzsweep.core.lockin import amplitude_phase, complex_amplitude, demodulate, lockin_xy
from hertzsweep.drivers.oscillator import Oscillator
from hertzsweep.kernels import scheme

from .conftest import make_scene


@pytest.mark.parametrize("samples_per_period, periods", [(64, 1), (256, 7), (1000, 3)])
def test_synthetic_harmonics_exact(samples_per_period, periods):
    # A sum of harmonics below the Nyquist order is recovered exactly by a whole-period
    # filter: only rounding remains (1e-12 is ~1e4 ulps of the O(1) signal).
    theta = 2 * np.pi * np.arange(samples_per_period * periods) / samples_per_period
    harmonics = np.array([1, 2, 3, 5])
    amplitude = np.array([0.8, 0.17, 0.02, 1e-3])
    phase = np.array([12.0, 200.0, 359.5, 90.0])
    signal = 1.3 + sum(
        a * np.sin(k * theta - np.radians(p))
        for k, a, p in zip(harmonics, amplitude, phase, strict=True)
    )
    mean, a_out, p_out = demodulate(signal, harmonics, samples_per_period)
    assert mean == pytest.approx(1.3, abs=1e-12)
    np.testing.assert_allclose(a_out, amplitude, atol=1e-12)
    # phase error in degrees of a harmonic of amplitude a is ~ 1e-12 / a rad
    np.testing.assert_allclose(p_out, phase, atol=1e-12 / 1e-3 * 180 / np.pi)


def test_phase_convention_quasistatic_and_inverted():
    theta = 2 * np.pi * np.arange(128) / 128
    _, _, in_phase = demodulate(1 + 0.01 * np.sin(theta), [1], 128)
    _, _, opposed = demodulate(1 - 0.01 * np.sin(theta), [1], 128)
    # phase in [0, 360): in phase is 0 (not 360), opposed 180
    assert in_phase[0] == pytest.approx(0.0, abs=1e-9)
    assert opposed[0] == pytest.approx(180.0, abs=1e-9)


def test_lockin_xy_matches_spec():
    amplitude, phase = np.array([2.0]), np.array([30.0])
    x, y = lockin_xy(amplitude, phase)
    assert x[0] == pytest.approx(2 * np.cos(np.radians(30)) / np.sqrt(2), rel=1e-15)
    assert y[0] == pytest.approx(-2 * np.sin(np.radians(30)) / np.sqrt(2), rel=1e-15)
    assert complex_amplitude(amplitude, phase)[0] == pytest.approx(2 * np.exp(-1j * np.pi / 6))


def test_partial_period_refused():
    with pytest.raises(ValueError, match="whole number of periods"):
        demodulate(np.ones(100), [1], 64)


def test_kernel_lockin_equals_demodulation_of_recorded_force():
    # The compiled loop accumulates the same sums the pure function computes from the
    # recorded N/F_s; only the summation order differs (1e-12 relative).
    scene = make_scene(
        excitation={"sigma": [0.078]}, damping={"ratio": 0.01, "law": "contact", "exponent": 1.5}
    )
    osc = Oscillator(scene, 0.078)
    state = osc.advance(osc.rest(0.6), 0.6, 50)
    record = np.zeros((4 * osc.steps_per_period, 4))
    _, reading = osc.measure(state, 0.6, 4, record=record, stride=1)
    mean, amplitude, phase = demodulate(record[:, 2], osc.harmonics, osc.steps_per_period)
    np.testing.assert_allclose(reading.amplitude, amplitude, rtol=1e-12)
    np.testing.assert_allclose(reading.phase, phase, atol=1e-10)
    assert reading.mean_force == pytest.approx(mean, rel=1e-12)
    assert reading.force_max == pytest.approx(record[:, 2].max(), rel=1e-14)
    assert reading.contact_loss_fraction == pytest.approx(1 - record[:, 3].mean(), abs=1e-15)


def test_amplitude_phase_from_sums():
    sums = np.array([[0.0, 50.0]])  # b = 2*50/100 = 1, a = 0
    amplitude, phase = amplitude_phase(sums, 100)
    assert amplitude[0] == pytest.approx(1.0) and phase[0] == pytest.approx(0.0)
    assert scheme.period_tables(4)[0] == pytest.approx([0, 1, 0, -1], abs=1e-15)
