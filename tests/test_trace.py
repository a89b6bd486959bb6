"""`hertzsweep trace`: records, spectra and flights at one frequency (paper Fig. 7, 8,
12, 16, 17)."""

import math
import tracemalloc

import numpy as np
import pytest

from hertzsweep.cli import main
from hertzsweep.core.config import load_scene
from hertzsweep.core.lockin import demodulate
from hertzsweep.core.rig import derive
from hertzsweep.drivers import spectrum as spectrum_module
from hertzsweep.drivers.spectrum import AmplitudeSpectrum, amplitude_spectrum, harmonic_orders
from hertzsweep.drivers.trace import (
    approach_path,
    flight_intervals,
    longest_flight,
    run_trace,
)
from hertzsweep.output.dataset import open_dataset, trace_dataset

from .conftest import CONFIGS, PAPER_RIG, make_scene

# The paper's vibro-impact case of Fig. 17 (sigma 7.8 %, zeta 1 %, n = 3/2). The grid
# starts from rest at 0.95, above the up sweep's jump (between 0.92 and 0.95 here): from
# rest at 0.92 or below the walk stays on the lower, non-impacting branch down to 0.58.
IMPACT = dict(
    damping={"ratio": 0.01, "law": "contact", "exponent": 1.5},
    excitation={"sigma": [0.078]},
    sweep={"start": 0.57, "stop": 0.95, "step": 0.01, "settle_periods": 200},
)


@pytest.fixture(scope="module")
def one_percent():
    scene = load_scene(CONFIGS / "default.toml", ["excitation.sigma=0.01"])
    return scene, run_trace(scene, 0.975, periods=8, branch="upper")


@pytest.fixture(scope="module")
def impacting():
    scene = make_scene(**IMPACT)
    return scene, run_trace(scene, 0.58, periods=8, branch="upper")


# --------------------------------------------------------------------------- spectrum
@pytest.mark.parametrize("backend", ["pyfftw", "numpy"])
@pytest.mark.parametrize("samples_per_period, periods", [(64, 3), (50, 7)])
def test_spectrum_convention_synthetic(backend, samples_per_period, periods):
    # Lines at whole harmonics of a record over whole periods fall on bins k P with no
    # leakage: the peak amplitudes and the mean come back to rounding (1e-12 is ~1e4
    # ulps of the O(1) signal); the Nyquist line cos(pi j) (M even) has amplitude |X|/M.
    m = samples_per_period * periods
    theta = 2 * np.pi * np.arange(m) / samples_per_period
    signal = 1.0 + 0.7 * np.sin(theta - 0.3) + 0.2 * np.cos(3 * theta) + 0.05 * np.sin(5 * theta)
    if m % 2 == 0:
        signal += 0.01 * np.cos(np.pi * np.arange(m))
    amplitude = amplitude_spectrum(signal, offset=1.0, backend=backend)
    assert amplitude.size == m // 2 + 1
    expected = np.zeros(m // 2 + 1)
    expected[0] = 1.0
    expected[[periods, 3 * periods, 5 * periods]] = [0.7, 0.2, 0.05]
    if m % 2 == 0:
        expected[-1] = 0.01
    np.testing.assert_allclose(amplitude, expected, atol=1e-12)
    orders = harmonic_orders(m, periods)
    assert orders[periods] == 1.0 and orders[5 * periods] == 5.0


def test_pyfftw_equals_numpy_and_offset_keeps_the_mean():
    rng = np.random.default_rng(3)
    signal = 1.0 + 1e-3 * rng.standard_normal(1000)
    a = AmplitudeSpectrum(1000, "pyfftw").amplitude(signal, offset=1.0)
    b = AmplitudeSpectrum(1000, "numpy").amplitude(signal)
    # two FFT algorithms over 1000 samples of O(1e-3) lines: 1e-15 absolute is rounding
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
    assert a[0] == pytest.approx(signal.mean(), abs=1e-15)


def test_plans_cached_in_the_process_and_nothing_written(tmp_path, monkeypatch):
    pytest.importorskip("pyfftw")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    samples = 3 * 7 * 64  # a length no other test plans
    rng = np.random.default_rng(5)
    signal = rng.standard_normal(samples)
    first = AmplitudeSpectrum(samples).amplitude(signal)
    # one plan per length for the process: a second spectrum reuses it
    assert spectrum_module.fftw_plan(samples) is spectrum_module.fftw_plan(samples)
    np.testing.assert_array_equal(AmplitudeSpectrum(samples).amplitude(signal), first)
    # FFTW_ESTIMATE plans from heuristics: no wisdom, no file anywhere
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- flights
def test_flight_intervals_of_a_known_motion():
    # q = -3/2 + cos(tau): out of contact (q <= -3/2) where cos(tau) <= 0, i.e. on
    # [pi/2, 3pi/2] + 2 pi n. Over tau in [0, 5 pi) the record holds two complete
    # flights and one cut by its end at 5 pi. The Hermite interpolant of (q, q') is
    # fourth-order accurate: with 64 samples per 2 pi the bounds are good to ~1e-7.
    dt = 2 * np.pi / 64
    tau = np.arange(160) * dt
    record = np.zeros((tau.size, 4))
    record[:, 0] = -1.5 + np.cos(tau)
    record[:, 1] = -np.sin(tau)
    record[:, 3] = (record[:, 0] > -1.5).astype(float)
    start, end, complete = flight_intervals(record, dt)
    np.testing.assert_allclose(start, [np.pi / 2, 5 * np.pi / 2, 9 * np.pi / 2], atol=1e-6)
    np.testing.assert_allclose(end[:2], [3 * np.pi / 2, 7 * np.pi / 2], atol=1e-6)
    assert end[2] == pytest.approx(160 * dt, abs=1e-12)
    assert complete.tolist() == [1, 1, 0]
    assert longest_flight(start, end, complete, 160 * dt) == pytest.approx(np.pi, abs=2e-6)


def test_longest_flight_without_a_complete_one():
    # a record that starts and ends in flight: joined as one flight of a periodic state
    start, end, complete = np.array([0.0, 8.0]), np.array([1.5, 10.0]), np.array([0, 0])
    assert longest_flight(start, end, complete, 10.0) == pytest.approx(3.5)
    assert longest_flight(np.array([]), np.array([]), np.array([], dtype=np.int8), 10.0) == 0.0


def test_approach_path():
    grid = np.round(0.9 + 0.0025 * np.arange(61), 12)  # 0.90 .. 1.05
    upper = approach_path(grid, 0.975, "upper")
    assert upper[0] == 1.05 and upper[-1] == 0.9775 and np.all(np.diff(upper) < 0)
    lower = approach_path(grid, 0.975, "lower")
    assert lower[0] == 0.9 and lower[-1] == 0.9725 and np.all(np.diff(lower) > 0)
    assert upper.size + lower.size == grid.size - 1  # W itself is dwelt at once, last
    assert approach_path(grid, 1.2, "upper").size == 0  # beyond stop: from rest at W
    assert approach_path(grid, 0.8, "lower").size == 0


# --------------------------------------------------------------------------- physics
def test_spectrum_lines_equal_lockin(one_percent):
    # Same samples, same whole periods: the FFT bin k P and the lock-in's sums are the
    # same Fourier coefficient computed two ways, so they differ by the rounding of sums
    # over 2048 O(1) samples (~1e-13); 1e-9 leaves a wide margin for summation order.
    _, result = one_percent
    p = result.periods
    assert result.samples_per_period == 256 and result.stride == 1
    np.testing.assert_allclose(result.spectrum[0, [p, 2 * p]], result.amplitude[0], atol=1e-9)
    assert result.harmonic_order[p] == 1.0 and result.harmonic_order[2 * p] == 2.0
    assert result.spectrum[0, 0] == pytest.approx(result.mean_force[0], abs=1e-9)
    # and the recorded N/F_s demodulated by the pure-numpy lock-in gives the same H_k
    mean, amplitude, phase = demodulate(result.record[0, :, 2], [1, 2], 256)
    np.testing.assert_allclose(amplitude, result.amplitude[0], atol=1e-9)
    np.testing.assert_allclose(phase, result.phase[0], atol=1e-6)


def test_one_percent_upper_branch_fig7(one_percent):
    # sigma 1 %, zeta 0.45 %, viscous, w = 0.975 on the upper branch (paper Fig. 7 and
    # 16 at 0.957: with these settings the upper branch ends near 0.972).
    _, result = one_percent
    assert result.approach[0] == 1.05 and result.approach[-1] == 0.9775
    assert result.settled[0] and result.periodic[0]
    assert result.contact_loss_fraction[0] == 0.0
    assert np.all(result.record[0, :, 3] == 1.0) and result.flights.complete.size == 0
    assert result.force_max[0] > 2.1
    assert 0.0 < result.force_min[0] < 0.15
    h2_h1 = result.amplitude[0, 1] / result.amplitude[0, 0]
    assert 0.1 < h2_h1 < 0.2  # paper: 17 %
    # with every step recorded, the record's extremes are the reading's
    assert result.record[0, :, 2].max() == result.force_max[0]
    assert result.record[0, :, 2].min() == result.force_min[0]


def test_branches_differ_at_the_same_frequency(one_percent):
    # hysteresis: the up sweep reaches 0.975 on the lower branch, H1 five times smaller
    scene, upper = one_percent
    lower = run_trace(scene, 0.975, periods=2, branch="lower")
    assert lower.approach[0] == 0.9 and lower.approach[-1] == 0.9725
    assert lower.amplitude[0, 0] < 0.25 * upper.amplitude[0, 0]


def test_impacting_fig17(impacting):
    # sigma 7.8 %, zeta 1 %, n = 3/2, w = 0.58 on the upper branch (paper Fig. 17 at
    # 0.57; the central-difference branch ends near 0.573).
    scene, result = impacting
    constants = derive(scene.rig)
    w = result.frequency_ratio
    period_tau = 2 * np.pi / w
    complete = result.flights.complete[0] == 1
    duration = (result.flights.end[0] - result.flights.start[0])[complete]
    assert result.settled[0] and result.periodic[0]
    assert complete.sum() >= result.periods - 1  # one flight per period
    assert np.all(duration > 0.5 * period_tau)
    assert result.contact_loss_fraction[0] > 0.5
    assert 5.0 < result.force_max[0] < 7.0
    assert result.force_min[0] == 0.0  # N/F_s vanishes in flight
    # Longest flight against the step-counted contact-loss fraction of one period,
    # fraction / (w f0) seconds: the interpolated bounds differ from the step count by
    # less than one step at each end, so by less than one step h / Omega in all.
    flight_s = result.flight_tau[0] / constants.natural_circular_frequency
    per_period_s = result.contact_loss_fraction[0] / (w * constants.natural_frequency)
    step_s = 2 * np.pi / (w * scene.solver.steps_per_period) / constants.natural_circular_frequency
    assert abs(flight_s - per_period_s) < step_s
    # every sample out of contact lies inside a flight, and no sample inside one is in contact
    tau = result.tau
    inside = np.zeros(tau.size, dtype=bool)
    for start, end in zip(result.flights.start[0], result.flights.end[0], strict=True):
        inside |= (tau >= start) & (tau < end)
    np.testing.assert_array_equal(inside, result.record[0, :, 3] == 0.0)


def test_lower_branch_at_the_impacting_frequency(impacting):
    # from below the same frequency is reached without impacts (so it is from rest at
    # any grid top up to 0.92: the walk must start above the up sweep's jump)
    scene, upper = impacting
    lower = run_trace(scene, 0.58, periods=2, branch="lower")
    assert lower.contact_loss_fraction[0] == 0.0
    assert lower.amplitude[0, 0] < 0.1 * upper.amplitude[0, 0]


def test_decimated_record_is_every_stride_th_step(impacting):
    # the same run with 64 of 256 steps kept: the samples are the same floats
    scene, full = impacting
    decimated = run_trace(scene, 0.58, periods=8, samples_per_period=64)
    assert decimated.record.shape == (1, 8 * 64, 4) and decimated.stride == 4
    np.testing.assert_array_equal(decimated.record[0], full.record[0, ::4])
    np.testing.assert_array_equal(decimated.amplitude, full.amplitude)  # lock-in: all steps
    assert decimated.sample_step == pytest.approx(4 * full.sample_step, rel=1e-15)
    # the flight bounds, interpolated over 4x longer intervals, move by < 1e-3 step
    np.testing.assert_allclose(
        decimated.flights.start, full.flights.start, atol=1e-3 * full.sample_step
    )
    np.testing.assert_allclose(
        decimated.flights.end, full.flights.end, atol=1e-3 * full.sample_step
    )


def test_memory_of_a_long_record():
    # 2000 periods x 64 samples: the peak traced allocation stays within 2x the arrays
    # the trace returns (record and spectrum); the integration keeps no history.
    scene = make_scene(
        excitation={"sigma": [0.01]},
        sweep={"start": 0.95, "stop": 0.95, "step": 0.01, "settle_periods": 20},
    )
    run_trace(scene, 0.95, periods=2, samples_per_period=64)  # compile and load kernels
    tracemalloc.start()
    try:
        result = run_trace(scene, 0.95, periods=2000, samples_per_period=64)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert result.record.shape == (1, 2000 * 64, 4)
    arrays = result.record.nbytes + result.spectrum.nbytes
    assert peak < 2 * arrays, (peak, arrays)


# --------------------------------------------------------------------------- CLI
def _scene_file(tmp_path):
    rig = "\n".join(
        f"{k} = {v!r}" if isinstance(v, str) else f"{k} = {v}" for k, v in PAPER_RIG.items()
    )
    text = f"""
[rig]
{rig}

[damping]
ratio = 0.0045
law = "viscous"

[excitation]
sigma = [0.006, 0.01]

[sweep]
start = 0.96
stop = 1.0
step = 0.0025
settle_periods = 300
""".replace("'", '"')
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def test_cli_end_to_end(tmp_path, capsys):
    scene_path = _scene_file(tmp_path)
    out = tmp_path / "trace.nc"
    main(["trace", str(scene_path), "--frequency", "0.975", "-o", str(out), "--periods", "4",
          "-q"])  # fmt: skip
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 3 and lines[0].startswith("sigma 0.006 w 0.9750 upper: H1 ")
    ds = open_dataset(out)
    assert ds.attrs["hertzsweep_kind"] == "trace" and ds.attrs["branch"] == "upper"
    assert ds.attrs["frequency_ratio"] == 0.975 and ds.attrs["periods"] == 4
    assert ds.attrs["samples_per_period"] == 256
    assert dict(ds.sizes) == {"sigma": 2, "sample": 1024, "harmonic": 2,
                              "harmonic_order": 513, "flight": 0}  # fmt: skip
    constants = derive(load_scene(scene_path).rig)
    h = 2 * np.pi / (0.975 * 256)
    np.testing.assert_allclose(np.diff(ds.tau.values), h, rtol=1e-12)
    np.testing.assert_allclose(ds.time.values, ds.tau.values / constants.natural_circular_frequency)
    np.testing.assert_allclose(
        ds.spectrum_frequency.values, ds.harmonic_order.values * 0.975 * constants.natural_frequency
    )
    lines_k = ds.spectrum.sel(harmonic_order=[1.0, 2.0]).values
    np.testing.assert_allclose(lines_k, ds.amplitude.values, atol=1e-9)
    np.testing.assert_array_equal(ds.normal_force.max("sample").values, ds.force_max.values)
    assert np.all(ds.in_contact.values == 1) and np.all(ds.contact_loss_fraction.values == 0)
    # sigma 1 % on the upper branch (as in test_one_percent_upper_branch_fig7), 0.6 % linear-ish
    h1 = ds.amplitude.sel(harmonic=1).values
    assert h1[1] > 1.0 and h1[0] < 0.2
    for name in ("displacement", "normal_force", "spectrum", "flight_duration", "time"):
        assert ds[name].attrs["units"] in ("1", "s") and ds[name].attrs["long_name"]


def test_cli_flights_with_decimation(tmp_path, capsys):
    out = tmp_path / "impact.nc"
    sets = ["excitation.sigma=0.078", "damping.ratio=0.01", "damping.law=contact",
            "damping.exponent=1.5", "sweep.start=0.57", "sweep.stop=0.95", "sweep.step=0.01",
            "sweep.settle_periods=200"]  # fmt: skip
    argv = ["trace", str(CONFIGS / "default.toml"), "-w", "0.58", "-o", str(out),
            "--samples-per-period", "32", "-q"]  # fmt: skip
    for item in sets:
        argv += ["--set", item]
    main(argv)  # returns on success (exit 0); errors exit 2
    assert "flight(s), longest" in capsys.readouterr().out
    ds = open_dataset(out).isel(sigma=0)
    omega = ds.attrs["natural_circular_frequency"]
    assert ds.sizes["sample"] == 8 * 32 and ds.attrs["record_stride"] == 8
    valid = ds.flight_complete.values >= 0
    assert int(ds.flight_count) == valid.sum() >= 8
    np.testing.assert_allclose(ds.flight_start_time.values[valid],
                               ds.flight_start.values[valid] / omega)  # fmt: skip
    duration = (ds.flight_end - ds.flight_start).values[valid] / omega
    np.testing.assert_allclose(ds.flight_duration.values[valid], duration)
    complete = ds.flight_complete.values == 1
    assert float(ds.flight_time) == pytest.approx(ds.flight_duration.values[complete].max())
    # one flight per period covering > half of it; flights cut by the ends are marked
    period_s = 1 / float(ds.frequency)
    assert np.all(ds.flight_duration.values[complete] > 0.5 * period_s)
    assert ds.flight_complete.values[0] == 0 and ds.flight_start.values[0] == 0.0


@pytest.mark.parametrize(
    "extra, key",
    [
        (["--samples-per-period", "100"], "--samples-per-period"),
        (["--samples-per-period", "0"], "--samples-per-period"),
        (["--frequency", "0"], "--frequency"),
        (["--frequency", "-0.5"], "--frequency"),
        (["--periods", "0"], "--periods"),
    ],
)
def test_cli_bad_input(tmp_path, capsys, extra, key):
    out = tmp_path / "bad.nc"
    argv = ["trace", str(CONFIGS / "default.toml"), "-o", str(out), "-q"]
    if "--frequency" not in extra:
        argv += ["--frequency", "0.975"]
    with pytest.raises(SystemExit) as exit_info:
        main(argv + extra)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and key in err and "Traceback" not in err
    assert not out.exists()


def test_dataset_without_file(impacting):
    # the builder's record variables are views of the result's record (no copy)
    scene, result = impacting
    ds = trace_dataset(result, scene, history="test").to_xarray()
    assert np.shares_memory(ds.normal_force.values, result.record)
    assert ds.flight_duration.attrs["units"] == "s"
    omega = derive(scene.rig).natural_circular_frequency
    assert math.isclose(float(ds.flight_time[0]), result.flight_tau[0] / omega)
