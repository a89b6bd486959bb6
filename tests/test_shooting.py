"""Shooting: the tangent-linear period map, Newton's fixed point, shooting-accelerated sweeps."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hertzsweep.core.config import load_scene
from hertzsweep.drivers import shooting
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
    oscillator.steps = 0
    state, reading, settled = shooting_dwell(oscillator, oscillator.rest(2.0), 2.0)
    assert not settled and not reading.periodic
    # the whole budget of max_settle_periods went to the transient (Newton's evaluations
    # besides), then the scene's measured periods
    periods = oscillator.steps // scene.solver.steps_per_period
    assert periods >= 2000 + scene.sweep.measure_periods, periods


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


# --------------------------------------------------------------------------- the compiled walk
PERIOD_DOUBLING = {  # up through w = 2, where the T-periodic orbit is unstable (above)
    "excitation": {"sigma": [0.3]},
    "sweep": {
        "start": 1.8,
        "stop": 2.2,
        "step": 0.05,
        "max_settle_periods": 2000,
        "steady_state": "shooting",
        "directions": ["up"],
    },
}


def dwell_by_dwell(scene, sigma):
    """The up sweep one Python dwell at a time (:func:`shooting_dwell`: Newton without
    prediction, the transient where it fails): what the compiled walk must read."""
    oscillator = Oscillator(scene, sigma)
    w = scene.sweep.frequency_ratios
    state = oscillator.rest(w[0])
    readings = []
    for frequency in w:
        before = oscillator.steps
        state, reading, settled = shooting_dwell(oscillator, state, frequency)
        periods = (oscillator.steps - before) // scene.solver.steps_per_period
        readings.append((reading, settled, periods))
    return readings


@pytest.mark.parametrize(
    "tables",
    [
        {**VISCOUS_1, "sweep": {"start": 0.95, "stop": 1.02, "steady_state": "shooting"}},
        PERIOD_DOUBLING,
    ],
    ids=["jump", "period-doubling"],
)
def test_compiled_walk_reads_what_each_dwell_reads_bit_for_bit(tables):
    # the walk (compiled Newton with its last iterate read unevaluated, the transient
    # past a fold, the unsettled dwell of a period doubling) against shooting_dwell one
    # dwell at a time: the same readings and verdicts, bit for bit, at every dwell
    scene = make_scene(**{**tables, "sweep": {**tables["sweep"], "directions": ["up"]}})
    sigma = float(np.atleast_1d(scene.excitation.sigma)[0])
    result = run_sweep(scene)
    expected = dwell_by_dwell(scene, sigma)
    jumps = [
        abs(b[0].amplitude[0] - a[0].amplitude[0])
        for a, b in zip(expected[:-1], expected[1:], strict=True)
    ]
    unsettled = [periods for _, settled, periods in expected if not settled]
    assert max(jumps) > 0.2 or unsettled  # a jump or a period doubling was walked through
    # an unsettled dwell spent the whole transient budget (Newton's tries besides)
    budget = scene.sweep.max_settle_periods + scene.sweep.measure_periods
    assert all(periods >= budget for periods in unsettled), (unsettled, budget)
    for i, (reading, settled, _) in enumerate(expected):
        assert result.settled[0, 0, i] == settled, i
        np.testing.assert_array_equal(result.amplitude[0, 0, i], reading.amplitude, err_msg=str(i))
        np.testing.assert_array_equal(result.phase[0, 0, i], reading.phase, err_msg=str(i))
        assert result.force_max[0, 0, i] == reading.force_max, i
        assert result.mean_force[0, 0, i] == reading.mean_force, i


def test_predicting_newtons_last_iterate_changes_no_number(monkeypatch):
    # the default scene's shooting sweep (four jumps) with and without the walk reading
    # Newton's last iterate before evaluating it: the same data bit for bit, and one
    # period fewer at 166 of the 244 dwells (the evaluation the reading replaces; not
    # where Newton converges at its first evaluation, nor near a fold)
    scene = load_scene(CONFIGS / "default.toml", ["sweep.steady_state=shooting"])
    predicted = run_sweep(scene)
    monkeypatch.setattr(shooting, "PREDICT_RESIDUAL", 0.0)
    plain = run_sweep(scene)
    for name in ("amplitude", "phase", "mean_force", "force_max", "force_min", "settled"):
        np.testing.assert_array_equal(getattr(predicted, name), getattr(plain, name), name)
    dwells = predicted.settled.size
    saved = (plain.steps - predicted.steps) // scene.solver.steps_per_period
    assert 0.5 * dwells < saved <= dwells, (saved, dwells)
