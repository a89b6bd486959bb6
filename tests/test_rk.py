"""The fourth-order method with contact events (``solver.method = "rk4"``): its order with and
without loss of contact, what the event handling buys, its agreement with the central
difference's Richardson limit and with the linear limit, its stability bound."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hertzsweep.core.model import STABILITY, check_stability, stability_limit
from hertzsweep.drivers.continuation import run_branch
from hertzsweep.drivers.oscillator import Oscillator, State
from hertzsweep.drivers.shooting import PeriodMap, newton, sorted_multipliers
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.errors import StabilityError
from hertzsweep.kernels import rk
from hertzsweep.kernels.methods import METHODS
from hertzsweep.kernels.scheme import OK

from .analytic import linear_response
from .conftest import make_scene

# the two dwells: no loss of contact (sigma = 1 %, viscous zeta = 0.45 %) and
# vibro-impact (sigma = 7.8 %, zeta = 1 %, contact law n = 3/2, 21 % of the time in flight
# at w = 0.95 from rest: the upper branch)
NO_LOSS = ({"ratio": 0.0045, "law": "viscous"}, 0.01, 0.95)
IMPACT = ({"ratio": 0.01, "law": "contact", "exponent": 1.5}, 0.078, 0.95)
SETTLE, MEASURE = 400, 20


def dwell(case, method, steps, events=True, settle=SETTLE):
    """H1 (complex, as the lock-in reads it) and the loss fraction of one dwell from rest."""
    damping, sigma, w = case
    scene = make_scene(damping=damping, excitation={"sigma": [sigma]},
                       solver={"method": method, "steps_per_period": steps},
                       sweep={"settle_periods": settle, "measure_periods": MEASURE})  # fmt: skip
    osc = Oscillator(scene, sigma)
    if not events:
        osc.drive = osc.drive._replace(events=False)
    state = osc.advance(osc.rest(w), w, settle)
    _, reading = osc.measure(state, w, MEASURE)
    h1 = reading.amplitude[0] * np.exp(-1j * np.radians(reading.phase[0]))
    return h1, reading.contact_loss_fraction


def observed_order(case, ladder, reference, **options):
    """Least-squares slope of log |H1(N) - H1_ref| against log N (and the errors)."""
    errors = np.array([abs(dwell(case, "rk4", n, **options)[0] - reference) for n in ladder])
    slope = -np.polyfit(np.log(ladder), np.log(errors), 1)[0]
    return slope, errors


@pytest.fixture(scope="module")
def references():
    """The converged H1 of each dwell: RK4 at N = 2048 (its error, by the orders measured
    below, is below 1e-12 without loss and 1e-11 with it)."""
    return {
        name: dwell(case, "rk4", 2048)[0]
        for name, case in (("no_loss", NO_LOSS), ("impact", IMPACT))
    }


def test_order_four_without_loss_of_contact(references):
    slope, errors = observed_order(NO_LOSS, [32, 64, 128, 256], references["no_loss"])
    assert dwell(NO_LOSS, "rk4", 64)[1] == 0.0  # the dwell never leaves contact
    # the floor: 3.8 (the fitted slope of a fourth-order method's errors)
    assert slope >= 3.8, (slope, errors)


def test_events_keep_order_three_through_impacts_and_without_them_it_drops(references):
    ladder = [64, 128, 256, 512]
    loss = dwell(IMPACT, "rk4", 256)[1]
    assert 0.15 < loss < 0.3  # a vibro-impact dwell: a fifth of the period in flight
    slope, errors = observed_order(IMPACT, ladder, references["impact"])
    assert slope >= 3.0, (slope, errors)
    # the same method with every step taken whole through the crossings: the singular
    # d^(3/2) and d^n terms and the misplaced law leave order about 2.5 (the "drop")
    plain, plain_errors = observed_order(IMPACT, ladder, references["impact"], events=False)
    assert plain < 3.0, (plain, plain_errors)
    # and at the finest step the events buy more than an order of magnitude
    assert plain_errors[-1] > 10.0 * errors[-1], (plain_errors, errors)


@pytest.mark.parametrize("name, case", [("no_loss", NO_LOSS), ("impact", IMPACT)])
def test_agrees_with_the_central_difference_richardson_limit(references, name, case):
    # the central difference is second order: (4 H(2N) - H(N)) / 3 cancels its h^2 term
    coarse, fine = (dwell(case, "central-difference", n)[0] for n in (2048, 4096))
    richardson = (4.0 * fine - coarse) / 3.0
    rk = dwell(case, "rk4", 256)[0]
    # the figure: 1e-6 (relative to H1), met by RK4 at N = 256 on both dwells
    assert abs(rk - richardson) <= 1e-6 * abs(richardson), abs(rk - richardson)
    assert abs(references[name] - richardson) <= 1e-6 * abs(richardson)


@pytest.mark.parametrize("w", [0.5, 0.9, 1.5])
def test_linear_limit(w):
    # sigma = 1e-4: q ~ 1e-3 at most, the nonlinear terms shift H1 by ~q^2 (1e-7 relative)
    zeta, sigma = 0.05, 1e-4
    case = ({"ratio": zeta, "law": "viscous"}, sigma, w)
    h1 = dwell(case, "rk4", 256, settle=200)[0] / sigma
    exact = linear_response(w, zeta)
    # the issue's figure 1e-6, relative; RK4's own error at N = 256 is ~1e-8 here
    assert abs(h1 - exact) <= 1e-6 * abs(exact), abs(h1 - exact) / abs(exact)


@pytest.mark.parametrize(
    "damping",
    [{"ratio": 0.0045, "law": "viscous"}, {"ratio": 0.01, "law": "contact", "exponent": 0.0},
     {"ratio": 0.01, "law": "contact", "exponent": 1.5},
     {"ratio": 0.01, "law": "contact", "exponent": 1.3}],
    ids=lambda d: f"{d['law']}-{d.get('exponent', '')}",
)  # fmt: skip
def test_batched_equals_single_bit_for_bit(damping):
    scene = make_scene(damping=damping,
                       excitation={"sigma": [0.005, 0.078]},
                       sweep={"start": 0.8, "stop": 1.0, "step": 0.05, "settle_periods": 40,
                              "measure_periods": 6},
                       solver={"method": "rk4", "steps_per_period": 64})  # fmt: skip
    single, batched = run_sweep(scene, batched=False), run_sweep(scene)
    for name in ("amplitude", "phase", "mean_force", "force_max", "force_min",
                 "contact_loss_fraction", "flight_tau", "settled", "periodic"):  # fmt: skip
        assert np.array_equal(getattr(single, name), getattr(batched, name), equal_nan=True)
    assert np.nanmax(single.contact_loss_fraction) > 0.1  # the batch crosses contact


def test_stability_bound_is_rk4s_interval_on_the_imaginary_axis():
    # RK4's amplification factor on the imaginary axis, |1 + z + z^2/2 + z^3/6 + z^4/24|,
    # is 1 at z = i 2 sqrt(2) and above 1 just beyond: the bound the scene check uses
    def growth(y):
        z = 1j * y
        return abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24)

    bound = STABILITY["rk4"]
    assert growth(bound) == pytest.approx(1.0, abs=1e-12)
    assert growth(0.999 * bound) < 1.0 < growth(1.001 * bound)
    scene = make_scene(solver={"method": "rk4", "steps_per_period": 64})
    cd = replace(scene, solver=replace(scene.solver, method="central-difference"))
    assert stability_limit(cd) / stability_limit(scene) == pytest.approx(np.sqrt(2.0))
    below = int(stability_limit(scene))  # at or below the limit: refused before running
    with pytest.raises(StabilityError, match="stability limit .* of rk4"):
        check_stability(replace(scene, solver=replace(scene.solver, steps_per_period=below)))


def test_the_kernel_refuses_a_step_beyond_rk4s_bound():
    # h omega = 3 > 2 sqrt(2) at rest (omega = 1): the kernel's own check, after one period
    w, steps = 1.0, 2
    scene = make_scene(solver={"method": "rk4", "steps_per_period": steps})
    osc = Oscillator(scene, 0.01)
    assert osc.step(w) == pytest.approx(np.pi)  # h omega = pi > 2 sqrt(2)
    with pytest.raises(StabilityError, match="beyond the stability limit"):
        osc.advance(osc.rest(w), w, 1)


def test_crossing_is_the_hermite_interpolants_root():
    # 2000 random steps whose ends lie on either side of q = -3/2 (d = 0): the fraction
    # is the cubic's root in (0, 1) to round-off (1e-12 of the step: the root's condition
    # number is below 1e3 for these slopes), the one nearest the start when it has three
    rng = np.random.default_rng(7)
    worst, bracketed, tested = 0.0, 0.0, 0
    for _ in range(2000):
        q0, q1 = -1.5 + rng.uniform(-0.2, 0.2, 2) * np.array([1.0, -1.0])
        v0, v1, h = rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0), rng.uniform(0.01, 0.5)
        c = [2 * (q0 - q1) + h * (v0 + v1), 3 * (q1 - q0) - h * (2 * v0 + v1), h * v0, q0 + 1.5]
        roots = np.roots(c) if abs(c[0]) > 1e-14 else np.roots(c[1:])
        inside = np.sort([r.real for r in roots if abs(r.imag) < 1e-9 and 0 <= r.real <= 1])
        slope = abs(np.polyval(np.polyder(c), inside))
        if (q0 + 1.5) * (q1 + 1.5) >= 0.0:  # no crossing: the kernels do not ask
            continue
        found = rk._crossing(q0, v0, q1, v1, h)
        # wherever the fraction was found (Newton's untested steps or, failing them, the
        # bracketed search), it is inside the step and H + 3/2 vanishes there to round-off
        assert 0.0 < found < 1.0 and abs(np.polyval(c, found)) <= 1e-14
        if inside.size != 1 or slope.min() < 1e-3:  # three roots, or a graze: ill-posed
            continue
        worst = max(worst, abs(found - inside[0]))
        chord = c[3] / (c[3] - (q1 + 1.5))
        bracketed = max(bracketed, abs(rk._bracketed(tuple(c[::-1]), chord) - inside[0]))
        tested += 1
    assert tested > 500 and worst <= 1e-12 and bracketed <= 1e-12, (tested, worst, bracketed)
    # near-grazing crossings, H + 3/2 = e (s - r) + 2 (s - r)^3 with slope e at the root r:
    # Newton's untested steps converge slowly there (about 2/3 a step), and the bracketed
    # search finds the root; where e is not small the untested steps find it themselves
    h = 0.2
    for e in (1e-8, 1e-6, 1e-3, 1.0):
        for r in (0.1, 0.4, 0.8):
            line = np.polynomial.Polynomial([-r, 1.0])
            p = 2.0 * line**3 + e * line
            q0, q1 = p(0.0) - 1.5, p(1.0) - 1.5
            v0, v1 = p.deriv()(0.0) / h, p.deriv()(1.0) / h
            found = rk._crossing(q0, v0, q1, v1, h)
            # the root's condition number is 1 / e: round-off of 1e-16 moves it 1e-16 / e
            assert abs(found - r) <= max(1e-12, 1e-15 / e) or abs(p(found)) <= 1e-15, (e, r)


# ------------------------------------------------------------- period map, shooting, branch
MAP_CASES = {
    "no-loss": NO_LOSS,
    "impact-1.5": IMPACT,
    "impact-0.5": ({"ratio": 0.01, "law": "contact", "exponent": 0.5}, 0.078, 0.95),
    "impact-0": ({"ratio": 0.01, "law": "contact", "exponent": 0.0}, 0.078, 0.95),
    "impact-viscous": ({"ratio": 0.01, "law": "viscous"}, 0.078, 0.95),
}


def rk4_oscillator(case, steps):
    damping, sigma, _ = case
    scene = make_scene(damping=damping, excitation={"sigma": [sigma]},
                       solver={"method": "rk4", "steps_per_period": steps})  # fmt: skip
    return Oscillator(scene, sigma)


def one_period(osc, state):
    derivative = np.zeros((2, 3))
    end, status = osc.period_map(state, derivative)
    return np.array([end.q_prev, end.q]), status, derivative


@pytest.mark.parametrize("case", MAP_CASES.values(), ids=MAP_CASES.keys())
def test_period_map_is_advance_and_its_jacobian_matches_finite_differences(case):
    """The exact derivative of the one-period map (through the crossings' fractions, the
    split steps and the singular terms' corrections) against central differences with a
    step of 1e-7 in (q', q) and 1e-7 of h in h. The quotient's own error is round-off over
    the step (1e-16 / 1e-7 times the growth over a period, about 1e-9 of each column, as
    measured) plus truncation O(1e-14): the issue's 1e-6 leaves three decades."""
    w = case[2]
    osc = rk4_oscillator(case, 64)
    state = osc.advance(osc.rest(w), w, 40)  # a transient state: generic
    end, status, derivative = one_period(osc, state)
    v, q, reference = rk.advance(state.q_prev, state.q, state.h, osc.law, osc.drive, 1)
    assert status == reference == OK
    assert end[0] == v and end[1] == q  # advance's arithmetic, bit for bit
    _, reading = osc.measure(state, w, 1)
    assert (reading.contact_loss_fraction > 0.1) == (case is not NO_LOSS)  # crossings in it
    x = np.array([state.q_prev, state.q, state.h])
    for column in range(3):
        step = np.zeros(3)
        step[column] = 1e-7 * (state.h if column == 2 else 1.0)
        plus, _, _ = one_period(osc, State(*(x + step)))
        minus, _, _ = one_period(osc, State(*(x - step)))
        quotient = (plus - minus) / (2.0 * step[column])
        error = np.max(np.abs(derivative[:, column] - quotient)) / np.max(np.abs(quotient))
        assert error <= 1e-6, (column, error)


def test_every_basis_keeps_q_as_its_first_scaled_coordinate():
    # the compiled Newton takes z0 = q / Q from the basis's second row (1, 0)
    for method in METHODS.values():
        np.testing.assert_array_equal(method.basis(64)[1], [1.0, 0.0])


@pytest.fixture(scope="module")
def orbits():
    """Shooting on the two dwells with rk4 at N = 256, from 50 periods after rest."""
    found = {}
    for name, case in (("no_loss", NO_LOSS), ("impact", IMPACT)):
        osc = rk4_oscillator(case, 256)
        w = case[2]
        found[name] = (osc, newton(PeriodMap(osc), osc.advance(osc.rest(w), w, 50), w))
    return found


def reference_period(case, v, q):
    """``(q', q)`` one period after ``(q', q)`` by scipy's DOP853 at rtol = atol = 1e-13,
    restarted at every contact crossing (located by its event finder): independent of
    hertzsweep's kernels."""
    damping, sigma, w = case
    twozeta, n = 2.0 * damping["ratio"], damping.get("exponent")

    def rhs(tau, y):
        d = 1.0 + 2.0 * y[0] / 3.0
        hertz = d**1.5 if d > 0.0 else 0.0
        c = twozeta if n is None else (twozeta * d**n if d > 0.0 else 0.0)
        return [y[1], 1.0 + sigma * np.sin(w * tau) - hertz - c * y[1]]

    def crossing(tau, y):
        return 1.0 + 2.0 * y[0] / 3.0

    crossing.terminal = True
    period, tau, y = 2.0 * np.pi / w, 0.0, np.array([q, v])
    while tau < period:
        run = solve_ivp(rhs, (tau, period), y, method="DOP853", rtol=1e-13, atol=1e-13,
                        events=crossing)  # fmt: skip
        if run.status != 1:
            return np.array([run.y[1, -1], run.y[0, -1]])
        tau, y = run.t_events[0][0], run.y_events[0][0].copy()
        y[0] = -1.5 + np.copysign(1e-15, y[1])  # just past d = 0, the way it goes
    return np.array([y[1], y[0]])


@pytest.mark.parametrize("name", ["no_loss", "impact"])
def test_shooting_converges_quadratically_to_the_settled_state(orbits, name):
    osc, orbit = orbits[name]
    residuals = np.array(orbit.residuals)
    assert orbit.converged and orbit.stable
    # quadratic convergence with the exact Jacobian: the observed order of the last three
    # residuals above the round-off floor (1e-13), log(r3 / r2) / log(r2 / r1), is 2
    logs = np.log(residuals[residuals > 1e-13][-3:])
    order = (logs[2] - logs[1]) / (logs[1] - logs[0])
    assert residuals[-1] < 1e-10 and order == pytest.approx(2.0, abs=0.3), residuals
    w = orbit.frequency_ratio
    settled = osc.advance(orbit.state, w, 200)  # the orbit repeats itself period after period
    scale = PeriodMap(osc).scale
    # Newton's tolerance is 1e-10 of the orbit scale Q; a stable orbit keeps it
    assert abs(settled.q - orbit.state.q) <= 1e-9 * scale
    assert abs(settled.q_prev - orbit.state.q_prev) <= 1e-9 * scale


@pytest.mark.parametrize("name", ["no_loss", "impact"])
def test_orbit_and_floquet_multipliers_against_an_event_located_reference(orbits, name):
    """rk4's orbit is a fixed point of the exact period map (DOP853 with events) and its
    multipliers are that map's, by central differences of step 1e-4 (truncation ~1e-8 of
    M, the reference's 1e-13 over the step 1e-9). rk4 at N = 256: measured 2e-8 off (order
    4 without loss, 3.5 through impacts)."""
    case = NO_LOSS if name == "no_loss" else IMPACT
    _, orbit = orbits[name]
    x = np.array([orbit.state.q_prev, orbit.state.q])
    assert np.max(np.abs(reference_period(case, *x) - x)) <= 1e-7 * np.max(np.abs(x))
    monodromy = np.empty((2, 2))
    for column in range(2):
        step = np.zeros(2)
        step[column] = 1e-4
        plus, minus = reference_period(case, *(x + step)), reference_period(case, *(x - step))
        monodromy[:, column] = (plus - minus) / 2e-4
    np.testing.assert_allclose(orbit.multipliers, sorted_multipliers(monodromy), rtol=1e-7)


def test_branch_folds_agree_with_the_central_difference():
    """The default scene's two branches: rk4 at N = 128 against the central difference at
    N = 2048 (its error in w ~ (2 pi / N)^2 / 24 w of order 1e-7 here)."""

    def folds(method, steps):
        scene = make_scene(solver={"method": method, "steps_per_period": steps})
        result = run_branch(scene)
        return np.array([f.frequency_ratio for b in result.branches for f in b.folds])

    rk4_folds, cd_folds = folds("rk4", 128), folds("central-difference", 2048)
    assert rk4_folds.size == cd_folds.size == 4  # two folds on each branch
    np.testing.assert_allclose(np.sort(rk4_folds), np.sort(cd_folds), atol=1e-6)


def test_shooting_sweep_agrees_with_the_settled_sweep():
    """rk4 sweeps of the default scene at N = 64 by shooting and by settling (300 periods):
    the settled one's remaining transient, below the scene's tolerance 1e-4 of H1 away
    from the jumps, is the whole difference."""
    scene = make_scene(solver={"method": "rk4", "steps_per_period": 64})
    settled = run_sweep(scene)
    shot = run_sweep(replace(scene, sweep=replace(scene.sweep, steady_state="shooting")))
    assert shot.settled.all()
    agree = np.abs(shot.amplitude[..., 0] - settled.amplitude[..., 0])
    assert np.median(agree) <= 1e-5 * np.max(settled.amplitude[..., 0])
    assert np.mean(agree <= 1e-4 * np.max(settled.amplitude[..., 0])) >= 0.9
