"""The solver at the edges of its range: tiny and large damping, tiny and huge input, very
low and very high frequency, the n = 0 contact damping, the step at 0.9x and 1.1x the
stability limit, and the scheme's conserved energy. Each case gives finite, physically
sensible numbers or the SPEC's one-line error, never NaN or a hang."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from hertzsweep.core.model import omega_max, stability_limit
from hertzsweep.drivers.oscillator import Oscillator, State
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.errors import StabilityError
from hertzsweep.kernels import scheme

from .analytic import linear_response, modified_energy, potential
from .conftest import CONFIGS, make_scene, run_cli


def scene_at(frequencies, *, sigma, zeta=0.0045, law="viscous", exponent=1.5, steps=256,
             settle=300, measure=20, direction="up"):  # fmt: skip
    """A one-sigma scene on the paper's rig over an evenly spaced list of frequencies."""
    w = list(frequencies)
    step = (w[-1] - w[0]) / (len(w) - 1) if len(w) > 1 else 0.1
    return make_scene(
        damping={"ratio": zeta, "law": law, "exponent": exponent},
        excitation={"sigma": [sigma]},
        sweep={"start": w[0], "stop": w[-1], "step": step, "directions": [direction],
               "settle_periods": settle, "measure_periods": measure},
        solver={"steps_per_period": steps},
    )  # fmt: skip


def h1(result):
    return result.amplitude[0, 0, :, 0]


def assert_finite(result):
    for name in ("amplitude", "phase", "mean_force", "force_max", "force_min",
                 "contact_loss_fraction", "flight_tau"):  # fmt: skip
        assert np.all(np.isfinite(getattr(result, name))), name


def momentum_defect(before, after, reading):
    """``mean(N/F_s) - 1`` predicted by the discrete momentum balance.

    Summing the scheme over M whole-period steps, the excitation's sine sums to zero and
    the second differences telescope: ``sum (N/F_s - 1) = -(dq_end - dq_start) / h^2``
    with ``dq`` the last displacement increment. Exact for every law, with or without
    contact loss, periodic or not.
    """
    h = before.h
    change = (after.q - after.q_prev) - (before.q - before.q_prev)
    return -change / (h * h * reading.samples)


# --------------------------------------------------------------------------- damping
def test_tiny_damping_adds_no_numerical_damping_and_says_unsettled():
    # zeta = 1e-5 (Q = 5e4). Started on the scheme's exact linear steady state (sigma = 1e-4,
    # Hertz nonlinearity ~1e-4 of the response), 2000 periods later H1 is still the linear
    # response: the explicit scheme neither damps nor pumps.
    zeta, sigma, w, steps = 1e-5, 1e-4, 0.9, 256
    scene = scene_at([w], sigma=sigma, zeta=zeta, steps=steps)
    oscillator = Oscillator(scene, sigma)
    h = scheme.step_size(w, steps)
    # q[n] = Im(Q exp(i w h n)) with Q the displacement response of the scheme
    damping = 2j * zeta * math.sin(w * h) / h
    displacement = sigma / (1 - 4 * math.sin(0.5 * w * h) ** 2 / h**2 + damping)
    start = State((displacement * np.exp(-1j * w * h)).imag, 0.0, h)
    state = oscillator.advance(start, w, 2000)
    _, reading = oscillator.measure(state, w, 20)
    exact = sigma * abs(linear_response(w, zeta, steps))
    assert reading.amplitude[0] == pytest.approx(exact, rel=1e-3)  # 1e-3: Hertz terms
    # From rest the free vibration (decay time 1/zeta = 1e5 tau) outlives any settling:
    # the sweep must say so rather than report it as steady.
    result = run_sweep(scene_at([0.9, 0.95], sigma=sigma, zeta=zeta, settle=300))
    assert_finite(result)
    assert not np.any(result.settled) and not np.any(result.periodic)
    # auto settling gives up at its cap (a bounded run, not a hang) and says so
    auto = scene_at([0.9], sigma=sigma, zeta=zeta)
    sweep = replace(auto.sweep, settle_periods=None, tolerance=1e-6, max_settle_periods=200)
    auto = replace(auto, sweep=sweep)
    capped = run_sweep(auto)
    assert not capped.settled[0, 0, 0]
    assert capped.steps <= (200 + 2 * 20) * 256


def test_heavy_damping_matches_the_linear_response():
    # zeta = 0.3, sigma = 1e-3: against the scheme's exact linear response the only
    # difference is the Hertz nonlinearity (response ~2e-3, its effect on H1 ~1e-7);
    # against the continuous response, the O(h^2) of N = 256 (measured <= 8.4e-5).
    zeta, sigma = 0.3, 1e-3
    result = run_sweep(scene_at([0.8, 1.0, 1.2], sigma=sigma, zeta=zeta, settle=100))
    w = result.frequency_ratio
    np.testing.assert_allclose(h1(result), sigma * abs(linear_response(w, zeta, 256)), rtol=1e-6)
    np.testing.assert_allclose(h1(result), sigma * abs(linear_response(w, zeta)), rtol=2e-4)
    lag = np.degrees(-np.angle(linear_response(w, zeta))) % 360
    np.testing.assert_allclose(result.phase[0, 0, :, 0], lag, atol=0.05)
    assert np.all(result.settled) and np.all(result.periodic)


# --------------------------------------------------------------------------- input level
def test_tiny_input_matches_the_analytic_linear_response():
    # sigma = 1e-7: N/F_s - 1 ~ 1e-7 is accumulated without its static part, so no digit
    # is lost to cancellation. N = 1024 puts the discretisation error below 1e-5 and 1000
    # settle periods leave exp(-2 pi 0.0045 0.5 1000) ~ 1e-6 of the transient at w = 0.5.
    zeta, sigma = 0.0045, 1e-7
    result = run_sweep(scene_at([0.5, 0.75, 1.0], sigma=sigma, zeta=zeta, steps=1024,
                                settle=1000))  # fmt: skip
    w = result.frequency_ratio
    np.testing.assert_allclose(h1(result), sigma * abs(linear_response(w, zeta)), rtol=1e-4)
    # against the scheme's own linear response, round-off level: the kernels carry
    # d = 1 + 2q/3, known to 1.1e-16 absolute, so a response of q ~ sigma = 1e-7 carries
    # 1e-9 relative rounding per step, which accumulates over the 1020-period dwell
    # (measured 3.4e-7; 1.4e-10 when the state was q itself, at 20 % more time per step)
    np.testing.assert_allclose(h1(result), sigma * abs(linear_response(w, zeta, 1024)), rtol=1e-6)
    assert np.all(result.contact_loss_fraction == 0)


def test_half_the_static_load_loses_contact_periodically():
    # sigma = 0.5, n = 3/2, zeta = 1 %, down sweep 1.0 -> 0.6: a periodic vibro-impact
    # response, in flight 34 % (w = 1) to 70 % (w = 0.6) of the period.
    result = run_sweep(scene_at([0.6, 0.7, 0.8, 0.9, 1.0], sigma=0.5, zeta=0.01, law="contact",
                                direction="down"))  # fmt: skip
    assert_finite(result)
    loss = result.contact_loss_fraction[0, 0]
    assert np.all((loss > 0.3) & (loss < 0.75))
    assert np.all(np.diff(loss) < 0)  # longer flights at lower frequency (paper, Fig. 12)
    assert np.all(result.periodic) and np.all(result.settled)
    # in flight N is exactly 0; in contact N = d^(3/2) (1 + 2 zeta q') >= 0 (|q'| < 50)
    assert np.all(result.force_min == 0)
    assert np.all(result.force_max > 1.5)  # impacts: above the input's 1 + sigma
    # a periodic response transmits the static load on average (momentum balance)
    np.testing.assert_allclose(result.mean_force, 1.0, atol=1e-8)


def test_twice_the_static_load_flies_most_of_the_period():
    # sigma = 2: the input pulls the mass off for a third of each period (1 + 2 sin < 0)
    # and it flies most of the period. No periodic orbit is reached (impacts at random
    # phases); the readings must still be finite and obey the exact identities.
    zeta, sigma, w, steps = 0.05, 2.0, 1.0, 256
    scene = scene_at([w], sigma=sigma, zeta=zeta, law="contact", steps=steps)
    oscillator = Oscillator(scene, sigma)
    before = oscillator.advance(oscillator.rest(w), w, 300)
    record = np.zeros((20 * steps, 4))
    after, reading = oscillator.measure(before, w, 20, record, 1)
    q, velocity, force, contact = record.T
    assert np.all(np.isfinite(record)) and np.isfinite(reading.amplitude).all()
    assert reading.contact_loss_fraction > 0.5
    assert np.all(force[contact == 0] == 0)  # flight: no force at all
    assert np.max(np.abs(velocity)) < 1 / (2 * zeta)  # so that in contact N >= 0:
    assert np.all(force[contact == 1] >= 0) and reading.force_min == 0
    defect = momentum_defect(before, after, reading)
    assert reading.mean_force - 1 == pytest.approx(defect, abs=1e-9)
    # the step stays within the stability limit at the stiffest contact reached
    h = scheme.step_size(w, steps)
    assert h * reading.force_max ** (1 / 6) < 2


def test_compression_beyond_the_bound_stops_with_stability_error():
    # sigma = 2, zeta = 5 %, n = 0 at w = 0.5 reaches N = 48 F_s (N = 20 steps per period),
    # beyond the force bound 1 + sigma / (2 zeta) = 21 behind the pre-run limit (10.4):
    # at N = 12 the run passes the check but the kernels stop it at the real compression.
    scene = scene_at([0.5], sigma=2.0, zeta=0.05, law="contact", exponent=0.0, steps=12)
    assert stability_limit(scene) < 12
    with pytest.raises(StabilityError, match="beyond the stability limit at the compression"):
        run_sweep(scene)


# --------------------------------------------------------------------------- frequency
def test_very_low_frequency_is_quasi_static():
    # w = 0.05: N/F_s = 1 + f - q'' with q'' ~ w^2 q: H1 = sigma |T(w)|, H2 ~ w^2 q^2 tiny.
    # 50 periods are 3142 tau: exp(-0.0045 3142) ~ 1e-6 of the transient.
    zeta, sigma = 0.0045, 0.01
    result = run_sweep(scene_at([0.05], sigma=sigma, zeta=zeta, settle=50, measure=4))
    assert h1(result)[0] == pytest.approx(sigma * abs(linear_response(0.05, zeta)), rel=1e-5)
    assert result.phase[0, 0, 0, 0] < 0.05 or result.phase[0, 0, 0, 0] > 359.95
    assert result.amplitude[0, 0, 0, 1] < 1e-4 * h1(result)[0]
    assert result.settled.all()


def test_very_high_frequency_is_mass_controlled():
    # w = 3: the mass barely moves, H1 = sigma |T(3)| ~ sigma / 8, lagging ~180 degrees.
    # A period is only 2.1 tau: 3000 periods leave exp(-0.0045 6283) ~ 5e-13 of the
    # transient. Tolerance 2e-4: the O(h^2) of N = 256 (measured 5.6e-5).
    zeta, sigma = 0.0045, 0.01
    result = run_sweep(scene_at([3.0], sigma=sigma, zeta=zeta, settle=3000))
    assert h1(result)[0] == pytest.approx(sigma * abs(linear_response(3.0, zeta)), rel=2e-4)
    lag = math.degrees(-np.angle(linear_response(3.0, zeta))) % 360
    assert result.phase[0, 0, 0, 0] == pytest.approx(lag, abs=0.05)
    assert 175 < lag < 180
    assert result.settled.all() and result.periodic.all()


# --------------------------------------------------------------------------- n = 0
def test_contact_damping_n0_with_contact_loss():
    # n = 0: f_d = 2 zeta q' in contact, 0 in flight, so the force jumps at each impact
    # and the damper pulls (N < 0) as the ball leaves. The paper's sigma = 7.8 %,
    # zeta = 1 %, stepped down 1.0 -> 0.9 -> 0.8 onto the branch with loss of contact.
    zeta, sigma = 0.01, 0.078
    scene = scene_at([0.8], sigma=sigma, zeta=zeta, law="contact", exponent=0.0, steps=512)
    oscillator = Oscillator(scene, sigma)
    state = oscillator.rest(1.0)
    for w in (1.0, 0.9, 0.8):
        state, reading, _ = oscillator.dwell(state, w)
    # Not 'settled' at tolerance 1e-4: where the impact falls between two steps jitters
    # from period to period, so consecutive blocks differ by ~1e-4 (H1 by ~2e-5) at
    # N = 512; the state returns within 1e-3 each period ('periodic').
    record = np.zeros((20 * 512, 4))
    after, reading = oscillator.measure(state, 0.8, 20, record, 1)
    q, velocity, force, contact = record.T
    assert np.all(np.isfinite(record))
    assert 0.3 < reading.contact_loss_fraction < 0.6  # measured 0.48
    assert np.all(force[contact == 0] == 0)
    # in contact N - 2 zeta q' = d^(3/2) >= 0 (to round-off)
    in_contact = contact == 1
    assert np.all(force[in_contact] - 2 * zeta * velocity[in_contact] >= -1e-12)
    assert -2 * zeta * np.max(np.abs(velocity)) <= reading.force_min < 0
    assert reading.periodic
    defect = momentum_defect(state, after, reading)
    assert reading.mean_force - 1 == pytest.approx(defect, abs=1e-9)


# --------------------------------------------------------------------------- stability
def scene_at_margin(fraction, steps=16, sigma=1e-3, zeta=0.0045, settle=300):
    """A linear-case scene whose step is ``fraction`` of the stability limit:
    h omega_max = 2 fraction, i.e. w = pi omega_max / (fraction N)."""
    w = round(math.pi * omega_max(sigma, zeta) / (fraction * steps), 12)
    return scene_at([w], sigma=sigma, zeta=zeta, steps=steps, settle=settle), w


def test_stable_at_0p9_of_the_stability_limit_over_1e4_periods():
    scene, w = scene_at_margin(0.9, settle=10_000)
    assert stability_limit(scene) / 16 == pytest.approx(0.9, rel=1e-9)
    result = run_sweep(scene)
    assert_finite(result)
    # bounded and right: the scheme's own linear response (measured 3.3e-9; 1e-6 bounds
    # the Hertz terms, second order in the response ~1e-3). The free vibration is barely
    # resolved (h omega ~ 1.77) but decays; the forced one (w h = 2 pi / 16) is within
    # 7e-4 of the continuous response.
    exact = 1e-3 * abs(linear_response(w, 0.0045, 16))
    assert h1(result)[0] == pytest.approx(exact, rel=1e-6)
    assert result.settled.all() and result.periodic.all()
    assert result.steps == (10_000 + 20) * 16


def test_refused_at_1p1_of_the_stability_limit(tmp_path, capsys):
    scene, w = scene_at_margin(1.1)
    with pytest.raises(StabilityError, match="at or below the stability limit"):
        run_sweep(scene)
    # bypassing the check, the kernels refuse at the first step (h omega > 2 at rest)
    oscillator = Oscillator(scene, 1e-3)
    with pytest.raises(StabilityError):
        oscillator.advance(oscillator.rest(w), w, 1)
    # the command line: one line naming the key, exit 2, no output
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(
        f'rig = "{CONFIGS / "rig.toml"}"\n[excitation]\nsigma = 1e-3\n'
        f"[sweep]\nstart = {w!r}\nstop = {w!r}\ndirections = ['up']\n"
        "[solver]\nsteps_per_period = 16\n"
    )
    for command in ("sweep", "accuracy"):
        out = tmp_path / f"{command}.nc"
        code, _, err = run_cli([command, scene_file, "-o", out, "-q"], capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1
        assert "solver.steps_per_period" in err and "stability limit" in err
        assert not out.exists()
    # and 0.9x passes validation
    good = tmp_path / "good.toml"
    w_good = scene_at_margin(0.9)[1]
    good.write_text(scene_file.read_text().replace(repr(w), repr(w_good)))
    code, out, _ = run_cli(["validate", good], capsys)
    assert code == 0 and "1.1x the stability limit" in out


# --------------------------------------------------------------------------- energy
@pytest.mark.parametrize("compression", [1.0, -1.0])
def test_undamped_unforced_energy_has_no_drift(compression):
    # From q = +-1 (d = 1.67 / 0.33, strongly nonlinear, in contact throughout), 1e5
    # periods of 2 pi at N = 256 (2.6e7 steps): the modified energy (modified_energy,
    # O(h^4) ~ 1e-8 here) stays within 1e-6 of its start; the plain energy
    # p^2/2 + V oscillates by O(h^2) ~ 1e-4.
    steps, periods, stride = 256, 100_000, 257  # stride prime to N: all phases sampled
    scene = make_scene(damping={"ratio": 0.0}, solver={"steps_per_period": steps})
    oscillator = Oscillator(scene, 0.0)
    state = oscillator.from_velocity(compression, 0.0, 1.0)
    record = np.zeros((-(-periods * steps // stride), 4))
    _, reading = oscillator.measure(state, 1.0, periods, record, stride)
    q, velocity = record[:, 0], record[:, 1]
    assert reading.contact_loss_fraction == 0
    energy = modified_energy(q, velocity, state.h)
    start = energy[0]
    assert start == pytest.approx(potential(compression), rel=1e-3)
    assert np.max(np.abs(energy - start)) <= 1e-6 * abs(start)
    # no drift: the first and last thousand samples agree far below the bound (measured
    # 2.5e-9 of the energy over 2.6e7 steps, 1e-16 per step: the state d is rounded to
    # 1.1e-16 at every step; 5e-9 allows two ulp per step)
    assert abs(energy[-1000:].mean() - energy[:1000].mean()) <= 5e-9 * abs(start)
    plain = 0.5 * velocity**2 + potential(q)
    assert np.ptp(plain) > 1e-5 * abs(start)  # the plain energy would fail the 1e-6 test
