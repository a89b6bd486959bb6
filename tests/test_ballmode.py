"""The ball's own mode: how far a single-degree-of-freedom response reaches it."""

from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

from hertzsweep.core.ballmode import (
    THRESHOLD,
    ball_damping,
    error_of,
    power_sums,
    transmission_change,
)
from hertzsweep.core.rig import derive, sphere_plane_stiffness
from hertzsweep.drivers.sweep import run_sweep

from .conftest import CONFIGS, PAPER_RIG, make_scene, run_cli


def test_transmission_is_the_ball_between_two_contacts():
    """H - 1 against the ball's equation solved directly: m_b z2'' = k (z1 - z2) + c (z1' -
    z2') - k z2 - c z2' with z1 imposed, N = k z2 + c z2', N0 = (k z1 + c z1') / 2 (the
    massless ball); c from the scene's zeta on the first mode (two dashpots in series)."""
    m_b, k, omega = 0.067, 3.0e8, 1450.0
    zeta = 0.0045
    m = k / (2.0 * omega**2)  # the moving mass whose single-dof Omega this is
    c = 4.0 * m * omega * zeta  # c / 2 on k / 2 and m: zeta
    omega_b = np.sqrt(2.0 * k / m_b)
    frequency = np.array([10.0, 300.0, 2000.0, 0.9 * omega_b / (2 * np.pi), 2e4])
    w = 2 * np.pi * frequency
    kc = k + 1j * w * c
    z2 = kc / (2.0 * kc - m_b * w**2)  # per unit z1
    direct = kc * z2 / (kc / 2.0)
    zeta_b = ball_damping(zeta, omega / (2 * np.pi), omega_b / (2 * np.pi))
    ours = 1.0 + transmission_change(frequency, omega_b / (2 * np.pi), zeta_b)
    np.testing.assert_allclose(ours, direct, rtol=1e-12)  # algebra: rounding only


def test_ball_damping_is_the_two_dof_modal_damping():
    """zeta_b = zeta f_b / f0 is the damping ratio of the damped two-degree-of-freedom
    system's upper mode (dashpots proportional to the contacts' stiffness), with f_b the
    rig's ball mode: the complex eigenvalue's -Re/|.|, to rounding."""
    from hertzsweep.core.config import scene_from_dict

    rig = scene_from_dict({"rig": dict(PAPER_RIG)}, source="<test>").rig
    constants = derive(rig)
    k1 = sphere_plane_stiffness(rig)
    delta = (constants.static_load / k1) ** (2.0 / 3.0)
    upper = 1.5 * k1 * np.sqrt(delta)
    lower = 1.5 * k1 * ((constants.static_load + rig.ball_mass * 9.81) / k1) ** (1.0 / 3.0)
    stiffness = np.array([[upper, -upper], [-upper, upper + lower]])
    mass = np.diag([rig.mass, rig.ball_mass])
    zeta = 0.01
    # the first mode's Omega of the 2-dof system sets beta (C = beta K): zeta_1 = beta w1/2
    undamped = np.sort(np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real)
    w1, wb = np.sqrt(undamped)
    beta = 2.0 * zeta / w1
    inverse = np.linalg.inv(mass)
    a = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-inverse @ stiffness, -beta * inverse @ stiffness]])  # fmt: skip
    upper = max(np.linalg.eigvals(a), key=abs)
    modal = -upper.real / abs(upper)
    assert wb / (2 * np.pi) == pytest.approx(constants.ball_mode_frequency, rel=1e-12)
    assert ball_damping(zeta, w1 / (2 * np.pi), wb / (2 * np.pi)) == pytest.approx(modal, rel=1e-9)


def mode_error(amplitude, frequency, ball_mode, zeta_ball):
    """The figure e of one spectrum (its two sums in one part)."""
    return error_of(*power_sums(amplitude, frequency, ball_mode, zeta_ball))


def test_mode_error_of_one_line_and_of_none():
    """One line at f: e = |H(f) - 1|, which is r^2 / |1 - r^2 + 2 i zeta_b r|; the mean
    (0 Hz) does not count; no oscillation gives NaN; no ball (NaN f_b) gives NaN."""
    f_b, zeta_b = 5900.0, 0.1
    for f in (100.0, 2950.0, 5900.0):
        r = f / f_b
        expected = r**2 / abs(1.0 - r**2 + 2j * zeta_b * r)
        got = mode_error(np.array([0.7, 0.2]), np.array([0.0, f]), f_b, zeta_b)
        assert got == pytest.approx(expected, rel=1e-13)
    assert np.isnan(mode_error(np.array([1.0, 0.0]), np.array([0.0, 50.0]), f_b, zeta_b))
    assert np.isnan(mode_error(np.array([0.3]), np.array([50.0]), np.nan, zeta_b))


def test_period_spectrum_reads_the_harmonics():
    """The sweep's one period, read as a trace's spectrum (numpy's transform): 1 + 0.3
    cos(theta) - 0.1 sin(5 theta) at 64 points, lines 1 .. 31 hold 0.3 at 1 and 0.1 at 5,
    nothing else (to rounding)."""
    from hertzsweep.drivers.spectrum import AmplitudeSpectrum

    theta = 2 * np.pi * np.arange(64) / 64
    force = 1.0 + 0.3 * np.cos(theta) - 0.1 * np.sin(5 * theta)
    analyser = AmplitudeSpectrum(64, backend="numpy")
    amplitude = np.array([analyser.amplitude(force), analyser.amplitude(2.0 * force)])[:, 1:32]
    expected = np.zeros(31)
    expected[0], expected[4] = 0.3, 0.1
    np.testing.assert_allclose(amplitude, [expected, 2.0 * expected], atol=1e-15)


def sweep_scene(sigma, settle=100, **rig):
    return make_scene(
        rig={**PAPER_RIG, **rig},
        damping={"ratio": 0.01, "law": "contact", "exponent": 1.5},
        excitation={"sigma": sigma},
        sweep={"start": 0.55, "stop": 1.0, "step": 0.05, "settle_periods": settle,
               "measure_periods": 8},
        solver={"steps_per_period": 128},
    )  # fmt: skip


def test_linear_limit_is_the_transmission_at_the_excitation():
    """sigma = 1e-4: the response is one line at w f0, so e = |H(w f0) - 1| (the harmonics
    k >= 2 are of order sigma, their share of e about 1e-4 of it: the tolerance; 400
    settling periods leave e^-25 of the transient at zeta = 1 %)."""
    scene = sweep_scene([1e-4], settle=400)
    result = run_sweep(scene, ball_mode=True)
    constants = derive(scene.rig)
    f = result.frequency_ratio * constants.natural_frequency
    zeta_b = ball_damping(0.01, constants.natural_frequency, constants.ball_mode_frequency)
    expected = np.abs(transmission_change(f, constants.ball_mode_frequency, zeta_b))
    for d in range(2):
        np.testing.assert_allclose(result.ball_mode_error[d, 0], expected, rtol=1e-3)


def test_check_changes_no_reading_and_batched_equals_single():
    """The check reads a copy of each dwell's end state: every other reading is the same
    bit for bit with or without it; in lockstep or one sweep at a time the same e; one
    period more per periodic dwell in the step count, NaN where the dwell does not
    repeat."""
    scene = sweep_scene([0.005, 0.078])
    plain = run_sweep(scene)
    checked = run_sweep(scene, ball_mode=True)
    single = run_sweep(scene, batched=False, ball_mode=True)
    for name in ("amplitude", "phase", "force_max", "force_min", "flight_tau", "settled"):
        assert np.array_equal(getattr(plain, name), getattr(checked, name), equal_nan=True)
    assert plain.ball_mode_error is None
    assert np.array_equal(checked.ball_mode_error, single.ball_mode_error, equal_nan=True)
    # read where the dwell repeats every period, and only there
    assert np.array_equal(np.isfinite(checked.ball_mode_error), checked.periodic)
    assert checked.periodic.sum() >= checked.periodic.size // 2
    assert checked.steps == plain.steps + checked.periodic.sum() * 128


def test_impacts_reach_further_than_a_smooth_response():
    """At sigma = 7.8 % the contact is lost over the low end of the grid and the impacts
    put force nearer the ball's mode: e exceeds the first line's |H - 1| ~ (f / f_b)^2
    wherever the contact is lost, 4x where it is lost longest;
    at 0.5 % e stays within 10 % of it (the harmonics k >= 2 add their share)."""
    scene = sweep_scene([0.005, 0.078])
    result = run_sweep(scene, ball_mode=True)
    constants = derive(scene.rig)
    f = result.frequency_ratio * constants.natural_frequency
    zeta_b = ball_damping(0.01, constants.natural_frequency, constants.ball_mode_frequency)
    first = np.abs(transmission_change(f, constants.ball_mode_frequency, zeta_b))
    down = 1  # the down sweep stays on the upper branch, impacting, to the grid's low end
    impacting = result.contact_loss_fraction[down, 1] > 0.1
    assert impacting.sum() >= 3
    e = result.ball_mode_error[down, 1]
    assert np.all(e[impacting] > 1.2 * first[impacting])
    longest = np.argmax(result.contact_loss_fraction[down, 1])
    assert e[longest] > 4.0 * first[longest]
    for d in range(2):
        np.testing.assert_allclose(result.ball_mode_error[d, 0], first, rtol=0.1)
    assert np.nanmax(result.ball_mode_error) < THRESHOLD  # the paper's rig: no warning


def test_single_sphere_plane_has_no_ball():
    scene = make_scene(
        rig={**PAPER_RIG, "geometry": "sphere-plane"},
        excitation={"sigma": [0.01]},
        sweep={"start": 0.9, "stop": 1.0, "step": 0.05, "settle_periods": 20, "measure_periods": 4},
    )
    result = run_sweep(scene, ball_mode=True)
    assert result.ball_mode_error is None


def test_sweep_warns_once_where_the_model_stops_being_justified(tmp_path, capsys):
    """A 3 kg ball puts its mode at 0.95 kHz (the 2-dof linearisation, its weight on the
    lower contact; 0.88 kHz with the upper mass held and equal contacts), 4.1 f0: a
    smooth response at f0 already has e ~ (f0 / f_b)^2 = 6 %, beyond the 0.5 %
    threshold: one warning line naming the largest figure, exit 0, and the figure in the
    dataset; the default ball (5.9 kHz) gives none."""
    quick = ["--set", "sweep.settle_periods=300", "--set", "sweep.measure_periods=4",
             "--set", "sweep.step=0.05", "--set", "solver.steps_per_period=64"]  # fmt: skip
    heavy = tmp_path / "heavy.nc"
    code, _, err = run_cli(["sweep", CONFIGS / "default.toml", "-o", heavy, "--quiet", *quick,
                            "--set", "rig.ball_mass=3.0"], capsys)  # fmt: skip
    assert code == 0
    lines = [line for line in err.splitlines() if "warning" in line]
    assert len(lines) == 1
    assert lines[0].startswith("hertzsweep: warning: the response reaches the ball's own mode")
    with xr.open_dataset(heavy) as ds:
        e = ds.ball_mode_error.values
        f_b = float(ds.attrs["ball_mode_frequency"])
        assert f_b == pytest.approx(947.3, rel=1e-3)
        assert f"{100 * np.nanmax(e):.2g} %" in lines[0]
        assert np.nanmin(e) > THRESHOLD
    light = ["sweep", CONFIGS / "default.toml", "-o", tmp_path / "light.nc", "--quiet", *quick]
    code, _, err = run_cli(light, capsys)
    assert code == 0 and "warning" not in err


def test_trace_reads_the_same_figure_from_its_own_spectrum():
    """A trace reaches w = 0.65 down the same grid as the down sweep and records one
    period from where the sweep's check reads it: its spectrum (FFTW, every step) gives
    the sweep's e to rounding; over 4 periods of the periodic response, to the
    periodicity of the state (1e-6 relative)."""
    from hertzsweep.drivers.trace import run_trace

    scene = sweep_scene([0.078])
    sweep = run_sweep(scene, ball_mode=True)
    at = int(np.argmin(np.abs(sweep.frequency_ratio - 0.65)))
    expected = sweep.ball_mode_error[sweep.directions.index("down"), 0, at]
    assert sweep.contact_loss_fraction[1, 0, at] > 0.5  # impacting
    one = run_trace(scene, 0.65, periods=1, branch="upper")
    assert one.ball_mode_error[0] == pytest.approx(expected, rel=1e-10)
    four = run_trace(scene, 0.65, periods=4, branch="upper")
    assert four.ball_mode_error[0] == pytest.approx(expected, rel=1e-6)


def test_every_method_and_steady_state_reads_the_same_figure():
    """The check reads each path's end state with that path's method: shooting (the
    orbit, converged to 1e-10) gives the settled sweep's e to 1e-6, rk4 the central
    difference's to 1e-4 at N = 1024 (where the central difference at 4096 moves it by
    1e-4 at most: converged), at sigma = 7.8 % on the upper branch (impacting). Both read
    N samples a period: at N = 256 the impacts' lines above order 128 fold back and the
    two methods differ by 2.5e-3."""
    scene = sweep_scene([0.078], settle=300)
    table = {"start": 0.65, "stop": 1.0, "step": 0.05, "directions": ["down"]}
    scene = replace(scene, sweep=replace(scene.sweep, **table))
    fine = replace(scene, solver=replace(scene.solver, steps_per_period=1024))
    result = run_sweep(fine, ball_mode=True)
    settled = result.ball_mode_error
    assert np.sum(result.contact_loss_fraction > 0.2) >= 5  # impacting
    shooting = replace(fine, sweep=replace(fine.sweep, steady_state="shooting"))
    rk4 = replace(fine, solver=replace(fine.solver, method="rk4"))
    np.testing.assert_allclose(run_sweep(shooting, ball_mode=True).ball_mode_error, settled,
                               rtol=1e-6)  # fmt: skip
    np.testing.assert_allclose(run_sweep(rk4, ball_mode=True).ball_mode_error, settled, rtol=1e-4)


def test_trace_warns_from_its_spectrum(tmp_path, capsys):
    """The trace's figure (its own spectrum) warns as the sweep's does, naming its sigma
    and its one w, without a direction."""
    out = tmp_path / "heavy-trace.nc"
    code, _, err = run_cli(["trace", CONFIGS / "default.toml", "-w", "1.0", "-o", out, "--quiet",
                            "--set", "rig.ball_mass=3.0"], capsys)  # fmt: skip
    assert code == 0
    (line,) = [line for line in err.splitlines() if "warning" in line]
    with xr.open_dataset(out) as ds:
        e = ds.ball_mode_error.values
        s = int(np.nanargmax(e))
        assert line.endswith("neglects it there")
        assert f"{100 * e[s]:.2g} % at sigma = {float(ds.sigma[s]):g}, w = 1 (above" in line


def test_too_few_samples_to_see_the_mode_read_nan():
    """At 16 steps a period the harmonics stop at order 7, 1.6 kHz at f0, below the ball's
    5.9 kHz: a sweep's and a trace's figure are NaN there (not the smooth part alone),
    and nothing warns."""
    from hertzsweep.drivers.trace import run_trace

    coarse = make_scene(
        excitation={"sigma": [0.01]},
        sweep={"start": 0.95, "stop": 1.0, "step": 0.05, "settle_periods": 300},
        solver={"steps_per_period": 16},
    )
    result = run_sweep(coarse, ball_mode=True)
    assert result.periodic.all()  # read, and NaN for the lines, not for the transient
    assert np.all(np.isnan(result.ball_mode_error))
    fine = replace(coarse, solver=replace(coarse.solver, steps_per_period=64))
    assert np.all(np.isfinite(run_sweep(fine, ball_mode=True).ball_mode_error))
    trace = run_trace(fine, 1.0, periods=4, samples_per_period=16)
    assert np.all(np.isnan(trace.ball_mode_error))
    assert np.all(np.isfinite(run_trace(fine, 1.0, periods=4).ball_mode_error))
