"""The emulated lock-in: exact Fourier coefficients over whole periods."""

from dataclasses import replace

import numpy as np
import pytest

from hertzsweep import load_scene, sweep
from hertzsweep.core.lockin import amplitude_phase, complex_amplitude, demodulate, lockin_xy
from hertzsweep.drivers.oscillator import Block, Oscillator
from hertzsweep.drivers.oscillator import drive as oscillator_drive
from hertzsweep.errors import ConfigError
from hertzsweep.kernels import scheme

from .conftest import CONFIGS, make_scene


def harmonic_sum(theta, orders, amplitude, phase):
    """``sum_k A_k sin(k theta - phi_k)`` (phases in degrees): the lock-in's convention."""
    return sum(
        a * np.sin(k * theta - np.radians(p))
        for k, a, p in zip(orders, amplitude, phase, strict=True)
    )


@pytest.mark.parametrize("samples_per_period, periods", [(64, 1), (256, 7), (1000, 3)])
def test_synthetic_harmonics_exact(samples_per_period, periods):
    # A sum of harmonics below the Nyquist order is recovered exactly by a whole-period
    # filter: only rounding remains (1e-12 is ~1e4 ulps of the O(1) signal).
    theta = 2 * np.pi * np.arange(samples_per_period * periods) / samples_per_period
    harmonics = np.array([1, 2, 3, 5])
    amplitude = np.array([0.8, 0.17, 0.02, 1e-3])
    phase = np.array([12.0, 200.0, 359.5, 90.0])
    signal = 1.3 + harmonic_sum(theta, harmonics, amplitude, phase)
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


# --------------------------------------------------------------------------- fractional orders
HALVES = [0.5, 1, 1.5, 2]  # a period-2 response's lines and the excitation's


def test_synthetic_fractional_orders_read_exactly_over_whole_response_periods():
    # H1/2, H1, H3/2, H2 and a mean, sampled 64 times an excitation period over 3 response
    # periods of 2 excitation periods: the whole-response-period filter is the exact
    # Fourier coefficient of the samples (1e-12, as for whole orders); tau = 0 at the first
    # sample, so each phase is the lag of A_k sin(k theta - phi_k)
    n = 64
    theta = 2 * np.pi * np.arange(6 * n) / n
    amplitude = np.array([0.6, 0.13, 0.011, 7e-4])
    phase = np.array([28.7, 169.4, 298.0, 96.8])
    signal = 1.25 + harmonic_sum(theta, HALVES, amplitude, phase)
    mean, a_out, p_out = demodulate(signal, HALVES, n)
    assert abs(mean - 1.25) < 1e-12
    np.testing.assert_allclose(a_out, amplitude, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p_out, phase, rtol=0, atol=1e-12 / 7e-4 * 180 / np.pi)
    # the same with the response period given (a multiple of L = 2), and thirds, quarters
    assert np.array_equal(demodulate(signal, HALVES, n, response_periods=6)[1], a_out)
    thirds = [1 / 3, 0.25, 1]  # L = 12
    theta = 2 * np.pi * np.arange(12 * n) / n
    signal = 0.3 * np.sin(theta / 3 - 1.0) + 0.2 * np.cos(theta / 4) + 0.1 * np.sin(theta)
    _, a_out, p_out = demodulate(signal, thirds, n)
    np.testing.assert_allclose(a_out, [0.3, 0.2, 0.1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(p_out, [np.degrees(1.0), 270.0, 0.0], rtol=0, atol=1e-9)


def test_part_of_a_response_period_is_refused():
    n = 64
    signal = np.ones(3 * n)  # 3 excitation periods: 1.5 periods of H1/2
    with pytest.raises(ValueError, match="whole number of periods of 128 samples"):
        demodulate(signal, HALVES, n)
    with pytest.raises(ValueError, match="not a multiple of the orders' common denominator 2"):
        demodulate(np.ones(6 * n), HALVES, n, response_periods=3)
    with pytest.raises(ValueError, match="not a multiple of 1/2, 1/3 or 1/4"):
        demodulate(np.ones(2 * n), [0.2, 1], n)
    assert demodulate(np.ones(4 * n), HALVES, n)[1].max() == 0.0  # 2 response periods


def period_two(method: str, model: str = "single", steps: int = 256, impacts: bool = False):
    """An oscillator on a period-2 orbit, settled 3000 periods, reading H1/2 .. H2, and its
    state and frequency ratio: sigma = 0.3, w = 2 (the 2-subharmonic resonance,
    tests/test_continuation.py), in contact throughout; or with ``impacts`` sigma = 1.2,
    w = 1.8, zeta = 1 %, contact law n = 3/2, out of contact 44 % of the time."""
    sigma, w = (1.2, 1.8) if impacts else (0.3, 2.0)
    damping = {"ratio": 0.01, "law": "contact", "exponent": 1.5} if impacts else {}
    scene = make_scene(
        excitation={"sigma": sigma},
        damping=damping,
        lockin={"harmonics": HALVES},
        solver={"method": method, "steps_per_period": steps},
        model={"kind": model},
    )
    osc = Oscillator(scene, sigma)
    return osc, osc.advance(osc.rest(w), w, 3000), w


def read_and_record(osc, state, w, periods=4):
    """The kernels' reading of ``periods`` periods and demodulate of their recorded N/F_s."""
    n = osc.steps_per_period
    columns = 8 if osc.scene.model.kind == "ball" else 4
    record = np.zeros((periods * n, columns))
    _, reading = osc.measure(state, w, periods, record=record, stride=1)
    return reading, demodulate(record[:, 2], osc.harmonics, n)


@pytest.mark.parametrize(
    "model, steps, impacts", [("single", 256, False), ("single", 256, True), ("ball", 512, False)]
)
def test_kernel_fractional_reading_equals_demodulation_of_the_record(model, steps, impacts):
    # The central difference's lock-in (the single model's blocked loop, and the ball
    # model's) sums the very samples it records with the references of its N L table:
    # only the order of the sums differs from demodulate's (1e-12 relative). The orbit's
    # H1/2 is above 0.5 of F_s: the reading is of a real subharmonic, not of round-off.
    osc, state, w = period_two("central-difference", model, steps, impacts)
    reading, (mean, amplitude, phase) = read_and_record(osc, state, w)
    assert (reading.contact_loss_fraction > 0.4) == impacts and not reading.periodic
    assert reading.amplitude[0] > 0.5  # H1/2
    np.testing.assert_allclose(reading.amplitude, amplitude, rtol=1e-12)
    np.testing.assert_allclose(reading.phase, phase, rtol=0, atol=1e-9)
    assert reading.mean_force == pytest.approx(mean, rel=1e-12)


@pytest.mark.parametrize("method", ["central-difference", "rk4"])
def test_many_trajectories_read_fractional_orders_as_one(method):
    # The sweep's lockstep kernel (measure, T trajectories in blocks) reads the orders as
    # measure_one reads one trajectory: bit for bit, fractional orders included, so each
    # trajectory's reading is the demodulation of its own record (as above). The two
    # trajectories start a period apart on the orbit: H1/2 and H3/2 read 180 degrees on.
    osc, state, w = period_two(method)
    n = osc.steps_per_period
    starts = [state, osc.advance(state, w, 1)]
    q_prev = np.array([start.q_prev for start in starts])
    q = np.array([start.q for start in starts])
    h = np.full(2, state.h)
    record = np.zeros((4 * n, 4, 2))
    buffers = osc.method.new_readout(len(HALVES), 2, record, 1)
    drive = oscillator_drive(osc.scene, np.full(2, 0.3))
    assert osc.method.measure(q_prev, q, h, osc.law, drive, 4, buffers)[0] == 0
    block = Block.read(buffers, 4 * n, h, osc.periodic_tolerance)
    tolerance = 1e-12 if method == "central-difference" else 1e-8  # as the tests above
    for t, start in enumerate(starts):
        _, one = osc.measure(start, w, 4)
        assert np.array_equal(block.amplitude[t], one.amplitude)
        assert np.array_equal(block.phase[t], one.phase)
        _, amplitude, _ = demodulate(record[:, 2, t], HALVES, n)
        np.testing.assert_allclose(block.amplitude[t], amplitude, rtol=0, atol=tolerance)
    shift = (block.phase[1] - block.phase[0]) % 360.0
    np.testing.assert_allclose(shift[[0, 2]], [180.0, 180.0], rtol=0, atol=1e-8)


def test_rk4_fractional_reading_equals_demodulation_to_its_quadrature():
    # rk4 reads the Fourier integrals of x over its stages (Simpson's rule on each step,
    # error O(h^4)); demodulate sums the step-end samples of the same run (the rectangle
    # rule). In contact throughout, the orbit is smooth and periodic over the record, so
    # the samples' sum is exact to aliasing: they differ by the quadrature's O(h^4), 5.4e-10
    # of H1/2's amplitude at N = 256 and 3.4e-11 at N = 512 (16 times less): within 1e-8.
    differences = []
    for steps in (256, 512):
        osc, state, w = period_two("rk4", steps=steps)
        reading, (mean, amplitude, phase) = read_and_record(osc, state, w)
        assert reading.amplitude[0] > 0.5
        differences.append(np.max(np.abs(reading.amplitude - amplitude)) / amplitude.max())
        np.testing.assert_allclose(reading.phase, phase, rtol=0, atol=1e-6)
        assert reading.mean_force == pytest.approx(mean, abs=1e-9)
    assert differences[0] < 1e-8
    assert 10.0 < differences[0] / differences[1] < 25.0  # order 4 in h


def test_rk4_fractional_reading_through_impacts_equals_demodulation():
    # Out of contact 44 % of the time, rk4 splits the steps that cross d = 0 and reads
    # their parts with phases from math (the period's offset 2 pi k p included) and the
    # singular terms' correction; the rectangle rule of demodulate meets the force's
    # s^(3/2) kinks there, an error O(h^(5/2)): 6e-8 of H1/2's amplitude at N = 256, within
    # 1e-6. Without the offset (a crossing in an odd period read as if in period 0) H1/2
    # and H3/2 are off by 8e-4 and 2e-3.
    osc, state, w = period_two("rk4", impacts=True)
    reading, (mean, amplitude, phase) = read_and_record(osc, state, w)
    assert reading.contact_loss_fraction > 0.4 and reading.amplitude[0] > 1.0
    ours = complex_amplitude(reading.amplitude, reading.phase)  # amplitude and phase
    theirs = complex_amplitude(amplitude, phase)
    assert np.max(np.abs(ours - theirs)) / amplitude.max() < 1e-6
    assert reading.mean_force == pytest.approx(mean, abs=1e-6)


@pytest.mark.parametrize("method", ["central-difference", "rk4"])
def test_fractional_phase_moves_by_360_k_a_period(method):
    # The phase of an order k that is not whole depends on the excitation period the
    # record starts at: one period later adds 360 k degrees. On the period-2 orbit H1/2
    # and H3/2 move by 180 degrees; H1 and H2 keep their phase; every amplitude is the same.
    osc, state, w = period_two(method)
    _, early = osc.measure(state, w, 4)
    _, late = osc.measure(osc.advance(state, w, 1), w, 4)
    shift = (late.phase - early.phase) % 360.0
    np.testing.assert_allclose(shift[[0, 2]], [180.0, 180.0], rtol=0, atol=1e-8)
    wrapped = np.minimum(shift[[1, 3]], 360.0 - shift[[1, 3]])
    np.testing.assert_allclose(wrapped, [0.0, 0.0], rtol=0, atol=1e-8)
    np.testing.assert_allclose(late.amplitude, early.amplitude, rtol=1e-10)


@pytest.mark.parametrize(
    "orders, periods", [(HALVES, 20), ([0.25, 1 / 3, 1, 2], 24)], ids=["halves", "L=12"]
)
def test_a_sweep_reads_its_whole_orders_bit_for_bit_with_fractional_ones_beside(orders, periods):
    # The lock-in's table of N L entries holds the excitation's table at every L-th entry
    # and the reference index runs on over the periods: a whole order reads the same
    # references in the same order whatever other orders are read, and with measure_periods
    # a multiple of 2 L the dwell's two halves are the same: the same bits.
    measured = {"sweep.measure_periods": periods}
    whole = sweep(load_scene(CONFIGS / "default.toml", measured))
    mixed = sweep(load_scene(CONFIGS / "default.toml", {**measured, "lockin.harmonics": orders}))
    assert mixed.harmonic.values.tolist() == orders and mixed.harmonic.dtype == np.float64
    for name in ("amplitude", "phase"):
        for k in (1, 2):
            a, b = whole[name].sel(harmonic=k).values, mixed[name].sel(harmonic=k).values
            assert np.array_equal(a, b, equal_nan=True), (name, k)
    for name in ("force_max", "settled", "periodic", "jump_frequency_ratio"):
        assert np.array_equal(whole[name].values, mixed[name].values, equal_nan=True), name
    assert np.nanmax(mixed.amplitude.isel(harmonic=0).values) > 0.0  # read, not skipped


def test_a_long_trace_reads_fractional_orders_over_its_chunks():
    # A trace records in chunks of whole response periods (255 periods of 256 steps for
    # L = 3, not 256) and adds their sums: its H1/3, H2/3 are demodulate's of the whole
    # record, and the spectrum's line at order k is bin k P (P = 510, a multiple of L)
    from hertzsweep.drivers.trace import chunk_periods, run_trace
    from hertzsweep.output.dataset import trace_dataset
    from hertzsweep.output.summary import trace_summary

    assert chunk_periods(256, 3) == 255 and chunk_periods(256) == 256
    orders = [1 / 3, 2 / 3, 1]
    scene = make_scene(
        excitation={"sigma": [0.3]},
        sweep={"start": 2.0, "stop": 2.0, "settle_periods": 0, "measure_periods": 6},
        lockin={"harmonics": orders},
    )
    result = run_trace(scene, 2.0, periods=510)
    _, amplitude, phase = demodulate(result.record[0, :, 2], orders, 256)
    assert amplitude.max() > 1e-3  # the transient from rest holds every order
    np.testing.assert_allclose(result.amplitude[0], amplitude, rtol=1e-11)
    np.testing.assert_allclose(result.phase[0], phase, rtol=0, atol=1e-8)
    lines = np.rint(np.array(orders) * 510).astype(int)
    np.testing.assert_allclose(result.spectrum[0, lines], amplitude, rtol=1e-9)
    with pytest.raises(ConfigError, match="--periods: 512 is not a multiple of 3"):
        run_trace(scene, 2.0, periods=512)

    summary = trace_summary(result, trace_dataset(result, scene))
    assert summary.startswith(f"sigma 0.3 w 2.0000 upper: H1/3 {amplitude[0]:.4f} H2/3 ")


@pytest.mark.parametrize("method", ["central-difference", "rk4"])
def test_shooting_reads_a_converged_orbit_over_whole_response_periods(method):
    # A converged T-periodic orbit is read over CONVERGED_PERIODS times L periods (here 2):
    # its H1/2 and H3/2 cancel to round-off (read over one period they would not: 0.14
    # and 0.09 at w = 0.97, beside H1 = 0.17),
    # and its H1 is the H1 of the same sweep reading whole orders, to Newton's residual
    overrides = {"sweep.steady_state": "shooting", "excitation.sigma": [0.01],
                 "solver.method": method}  # fmt: skip
    whole = sweep(load_scene(CONFIGS / "smoke.toml", overrides))
    halves = {**overrides, "lockin.harmonics": HALVES}
    mixed = sweep(load_scene(CONFIGS / "smoke.toml", halves))
    assert mixed.settled.values.all()
    assert np.nanmax(mixed.amplitude.sel(harmonic=[0.5, 1.5]).values) < 1e-9
    h1 = np.abs(mixed.amplitude.sel(harmonic=1).values - whole.amplitude.sel(harmonic=1).values)
    assert h1.max() < 1e-8
    # one dwell at a time (the ball model's way, and the walk's fallback) reads so too
    from hertzsweep.drivers.shooting import shooting_dwell

    osc = Oscillator(load_scene(CONFIGS / "smoke.toml", halves), 0.01)
    state, reading, settled = shooting_dwell(osc, osc.rest(0.97), 0.97)
    assert settled and max(reading.amplitude[[0, 2]]) < 1e-9 and reading.amplitude[1] > 0.1


def test_a_branch_reads_its_orbits_over_whole_response_periods():
    # Each point of a branch (a T-periodic orbit) is read over L periods: H1/2 cancels
    branch = run_branch_scene(HALVES)
    assert branch.amplitude[:, [0, 2]].max() < 1e-9 and branch.amplitude[:, 1].max() > 0.5
    assert [b.amplitude for b in branch.bifurcations] == pytest.approx(
        [b.amplitude for b in run_branch_scene([1, 2]).bifurcations], rel=1e-9
    )


def run_branch_scene(orders):
    from hertzsweep.drivers.continuation import run_branch

    overrides = {"excitation.sigma": [0.01], "lockin.harmonics": orders}
    return run_branch(load_scene(CONFIGS / "smoke.toml", overrides)).branches[0]


def test_a_dwell_reads_two_halves_of_whole_response_periods():
    # measure_periods = 6 with L = 2: halves of 2 and 4 periods (not 3 and 3), each whole
    # response periods, whose sums add to the reading of the 6 periods at once (1e-12)
    from hertzsweep.drivers.oscillator import measured_blocks

    assert measured_blocks(6, 2) == (2, 4) and measured_blocks(20, 2) == (10, 10)
    assert measured_blocks(20) == (10, 10) and measured_blocks(12, 12) == (12,)
    assert measured_blocks(36, 12) == (12, 24) and measured_blocks(1) == (1,)
    osc, state, w = period_two("central-difference")
    osc.scene = replace(
        osc.scene, sweep=replace(osc.scene.sweep, settle_periods=0, measure_periods=6)
    )
    _, dwelt, settled = osc.dwell(state, w)
    _, once = osc.measure(state, w, 6)
    assert settled
    np.testing.assert_allclose(dwelt.amplitude, once.amplitude, rtol=1e-12)
    np.testing.assert_allclose(dwelt.phase, once.phase, rtol=0, atol=1e-9)
