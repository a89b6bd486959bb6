"""Shooting: the tangent-linear period map, Newton's fixed point, shooting-accelerated sweeps."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hertzsweep.core.config import load_scene
from hertzsweep.drivers.bench import compare_with_settle
from hertzsweep.drivers.oscillator import Oscillator
from hertzsweep.drivers.shooting import PeriodMap, newton, shooting_dwell
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.kernels import integrate, scheme

from .conftest import CONFIGS, make_scene

VISCOUS_1 = {"damping": {"ratio": 0.0045, "law": "viscous"}, "excitation": {"sigma": 0.01}}
CONTACT_78 = {
    "damping": {"ratio": 0.01, "law": "contact", "exponent": 1.5},
    "excitation": {"sigma": 0.078},
}
# (scene tables, w): no loss of contact; loss of contact 2.7 % of the period (checked below)
CASES = [(VISCOUS_1, 0.95), (CONTACT_78, 0.98)]


def _map(oscillator, state):
    derivative = np.zeros((2, 3))
    end, status = oscillator.period_map(state, derivative)
    return np.array([end.q_prev, end.q]), status, derivative


@pytest.mark.parametrize(("tables", "w"), CASES)
def test_period_map_is_one_period_of_the_scheme(tables, w):
    oscillator = Oscillator(make_scene(**tables), tables["excitation"]["sigma"])
    state = oscillator.advance(oscillator.rest(w), w, 7)
    end, status, _ = _map(oscillator, state)
    q_prev, q, reference_status = integrate.advance(
        state.q_prev, state.q, state.h, oscillator.law, oscillator.drive, 1
    )
    assert status == reference_status == scheme.OK
    # the tangent map's trajectory is advance's own step: bit for bit
    assert end[0] == q_prev and end[1] == q


@pytest.mark.parametrize(("tables", "w"), CASES)
def test_period_map_jacobian_matches_finite_differences(tables, w):
    """The exact derivative of the discrete map against central differences with a step
    of 1e-7 in the state and 1e-6 of h in h: the kernels carry d = 1 + 2q/3, known to
    1.1e-16 absolute, so round-off contributes about 1e-16 / step times the growth over the
    period (1e-8 relative; 1e-7 on the h column, whose step is only 2.6e-8 at w = 0.95),
    truncation O(1e-14) where the force is smooth; where a
    step grazes d = 0 (the second case) the Hertz law's R'' ~ d^(-1/2) makes the
    quotient's error O(eps^(1/2)) in the worst case, about 5e-9 at this state."""
    oscillator = Oscillator(make_scene(**tables), tables["excitation"]["sigma"])
    state = oscillator.advance(oscillator.rest(w), w, 40)  # a transient state: generic
    _, _, derivative = _map(oscillator, state)
    eps = 1e-7
    for column, (dq_prev, dq, dh) in enumerate([(eps, 0, 0), (0, eps, 0), (0, 0, 1e-6 * state.h)]):
        plus, _, _ = _map(oscillator, replace(state, q_prev=state.q_prev + dq_prev,
                                              q=state.q + dq, h=state.h + dh))  # fmt: skip
        minus, _, _ = _map(oscillator, replace(state, q_prev=state.q_prev - dq_prev,
                                               q=state.q - dq, h=state.h - dh))  # fmt: skip
        quotient = (plus - minus) / (2.0 * max(dq_prev, dq, dh))
        np.testing.assert_allclose(derivative[:, column], quotient, rtol=1e-6)


@pytest.mark.parametrize(("tables", "w"), CASES)
def test_orbit_is_the_state_of_a_long_settled_run(tables, w):
    sigma = tables["excitation"]["sigma"]
    oscillator = Oscillator(make_scene(**tables), sigma)
    orbit = newton(PeriodMap(oscillator), oscillator.rest(w), w)
    assert orbit.converged and orbit.stable
    # 4000 periods: the transient decays by |mu|^4000 < 0.94^4000 ~ 1e-107
    settled = oscillator.advance(oscillator.rest(w), w, 4000)
    # the fixed point is off by at most the last Newton residual (< 1e-10 of Q) over
    # 1 - |mu| (> 0.06), times Q (< 4): 7e-9 (measured 2e-12)
    assert abs(settled.q - orbit.state.q) < 1e-8
    assert abs(settled.q_prev - orbit.state.q_prev) < 1e-8
    _, reading = oscillator.measure(orbit.state, w, 1)
    if tables is CONTACT_78:
        assert reading.contact_loss_fraction > 0.02  # the orbit does lose contact


@pytest.mark.parametrize(("tables", "w"), CASES)
def test_newton_converges_quadratically(tables, w):
    """From a state 60 periods into a run from rest, the residuals fall quadratically:
    the observed order log(r[k+1]/r[k]) / log(r[k]/r[k-1]) is 2 within 0.3 for every
    triple of residuals above the round-off floor (1e-13)."""
    oscillator = Oscillator(make_scene(**tables), tables["excitation"]["sigma"])
    start = oscillator.advance(oscillator.rest(w), w, 60)
    orbit = newton(PeriodMap(oscillator), start, w)
    residuals = np.array(orbit.residuals)
    assert orbit.converged and residuals[-1] < 1e-10
    above = residuals[residuals > 1e-13]
    assert above.size >= 3
    logs = np.log(above)
    orders = (logs[2:] - logs[1:-1]) / (logs[1:-1] - logs[:-2])
    np.testing.assert_allclose(orders, 2.0, atol=0.3)


def test_multipliers_of_a_viscous_orbit_have_the_exact_discrete_modulus():
    """For viscous damping det M = ((1 - zeta h)/(1 + zeta h))^N exactly (each step's
    Jacobian has determinant (1 - zeta h)/(1 + zeta h)); a complex pair has modulus
    sqrt(det M), whatever the stiffness along the orbit. Tolerance: round-off of the
    product of 256 step Jacobians (measured 1.7e-12)."""
    scene = make_scene(**VISCOUS_1)
    oscillator = Oscillator(scene, 0.01)
    w = 0.95
    orbit = newton(PeriodMap(oscillator), oscillator.rest(w), w)
    h = oscillator.step(w)
    zeta = oscillator.zeta
    exact = ((1.0 - zeta * h) / (1.0 + zeta * h)) ** (oscillator.steps_per_period / 2)
    assert np.all(orbit.multipliers.imag != 0.0)
    np.testing.assert_allclose(np.abs(orbit.multipliers), exact, rtol=1e-10)


def test_shooting_dwell_on_a_period_doubled_response_reports_unsettled():
    """At w = 2, sigma = 0.3 the T-periodic orbit exists but is unstable (a multiplier
    below -1): the dwell integrates to the period-2 attractor and says so."""
    scene = make_scene(excitation={"sigma": 0.3}, sweep={"max_settle_periods": 2000})
    oscillator = Oscillator(scene, 0.3)
    orbit = newton(PeriodMap(oscillator), oscillator.rest(2.0), 2.0)
    assert orbit.converged and not orbit.stable
    assert orbit.multipliers[0].imag == 0.0 and orbit.multipliers[0].real < -1.0
    state, reading, settled = shooting_dwell(oscillator, oscillator.rest(2.0), 2.0)
    assert not settled and not reading.periodic


@pytest.fixture(scope="module")
def comparison():
    scene = load_scene(CONFIGS / "default.toml", ["excitation.sigma=[0.01]"])
    return scene, compare_with_settle(scene)


def test_shooting_sweep_costs_ten_times_fewer_steps(comparison):
    _, out = comparison
    assert out["step_ratio"] >= 10.0
    assert out["shooting_unsettled"] == 0
    assert out["jump_frequency_ratio_shooting"] == out["jump_frequency_ratio_settle"]
    assert out["jump_frequency_ratio_shooting"] == [[0.985], [0.9725]]


def test_shooting_sweep_agrees_with_the_settled_sweep(comparison):
    """Within 1e-4 in H1 at every dwell the settled sweep reports settled. The first dwell
    after each jump is not settled after 300 periods (the settled sweep flags it, and
    differs there by up to 6e-4); there the shooting sweep matches a 3000-period settled
    sweep, as it does everywhere (to 1e-8: both are the same orbit of the same scheme)."""
    scene, out = comparison
    assert out["max_h1_difference_settled"] < 1e-4
    assert out["settle_unsettled"] <= 4  # the two post-jump dwells, and the first dwell
    shooting = run_sweep(replace(scene, sweep=replace(scene.sweep, steady_state="shooting")))
    long = run_sweep(replace(scene, sweep=replace(scene.sweep, settle_periods=3000)))
    difference = np.abs(shooting.amplitude[..., 0] - long.amplitude[..., 0])
    assert difference.max() < 1e-8
