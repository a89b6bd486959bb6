"""The two-degree-of-freedom model (``[model] kind = "ball"``): its limit, its mode, its
balance of momentum, its order, and where it parts from the single model."""

import math

import numpy as np
import pytest
import xarray as xr

from hertzsweep.core.ballmodel import BallModel
from hertzsweep.core.model import stability_limit
from hertzsweep.core.rig import derive
from hertzsweep.drivers.oscillator import drive, model_law
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.drivers.trace import run_trace
from hertzsweep.kernels import ball, scheme

from .conftest import CONFIGS, PAPER_RIG, make_scene, run_cli

PAPER_BALL = 0.070  # [kg] the paper's ball (section 3.1)
VIBRO_IMPACT = {"law": "contact", "ratio": 0.01, "exponent": 1.5}  # with sigma = 7.8 %


def scene(kind="ball", ball_mass=PAPER_BALL, damping=None, **tables):
    """A scene on the paper's rig with the ball's mass and the model's kind."""
    from hertzsweep.core.config import scene_from_dict

    raw = {"rig": {**PAPER_RIG, "ball_mass": ball_mass}, "model": {"kind": kind}}
    raw["damping"] = damping or {"law": "viscous", "ratio": 0.0045}
    raw.update(tables)
    return scene_from_dict(raw, source="<test>")


def both(ball_mass, **tables):
    """The same scene with the ball model and with the single model."""
    return scene("ball", ball_mass, **tables), scene("single", ball_mass, **tables)


# ------------------------------------------------------------------- the m_b -> 0 limit
@pytest.mark.parametrize(
    "case",
    [
        # sigma = 1 %, no loss of contact, both sides of the resonance on both directions
        dict(sigma=[0.01], sweep=dict(start=0.9, stop=1.05, step=0.025), damping=None),
        # the vibro-impact scene, on its upper branch coming down
        dict(
            sigma=[0.078],
            sweep=dict(start=0.7, stop=1.0, step=0.025, directions=["down"]),
            damping=VIBRO_IMPACT,
        ),
    ],
)
def test_massless_ball_is_the_single_model(case):
    """m_b = 1e-4 m: the ball follows the contacts quasi-statically and the model is eq.
    (8)/(11) with the double contact's k (eq. 12): H1 within 1e-3. The residual is the
    ball's mass (1e-4, its mode 200 f0 away) and the lower contact's load 1 + 1e-4; the
    steps (N = 2048, above the ball's stability limit) are the same for both models."""
    mass_ratio = 1e-4
    sweep = dict(case["sweep"], settle_periods=300, measure_periods=20)
    tables = dict(
        excitation={"sigma": case["sigma"]},
        sweep=sweep,
        solver={"steps_per_period": 2048},
    )
    two, one = both(mass_ratio * PAPER_RIG["mass"], damping=case["damping"], **tables)
    assert stability_limit(two) < 2048  # the ball's mode, 200 f0, is resolved
    a, b = run_sweep(two), run_sweep(one)
    h1, reference = a.amplitude[..., 0], b.amplitude[..., 0]
    assert np.all(np.isfinite(reference))
    np.testing.assert_allclose(h1, reference, rtol=1e-3)
    if case["sigma"][0] > 0.05:  # it impacts
        # the moving mass leaves the ball as it leaves the single model's contact, to 1 %
        # of a period: the ball, left on the lower disc by its weight alone, keeps a
        # compression (L - 1)^(2/3) = 2e-3 of its static one, so it sits higher and the
        # moving mass leaves it a little later and meets it a little earlier (the upper
        # contact is open up to 0.7 % of a period less: 0.0068 measured)
        assert np.nanmax(b.contact_loss_fraction) > 0.3
        np.testing.assert_allclose(
            a.extra["upper_contact_loss_fraction"], b.contact_loss_fraction, atol=0.01
        )
        np.testing.assert_allclose(a.extra["upper_force_max"], a.force_max, rtol=1e-3)
        # the ball, pressed on the lower disc by its own weight only, opens the lower
        # contact less often; it flies (both open) only while both are open
        assert np.all(a.contact_loss_fraction <= a.extra["upper_contact_loss_fraction"])
        assert np.all(a.extra["ball_flight_fraction"] <= a.contact_loss_fraction)


# ------------------------------------------------------------------- the ball's mode
def one_step_map(model, h, state):
    """``(u[n-1], u, l[n-1], l) -> (u, u[n+1], l, l[n+1])`` of the compiled step at rest's
    load F = 1."""
    u_prev, u, l_prev, l = state
    _, _, _, _, x, y = ball.step(model, u_prev, u, l_prev, l, 1.0, h, h * h * 2.0 / 3.0)
    return np.array([u, u_prev + x, l, l_prev + y])


def test_kernel_mode_is_the_rig_ball_mode():
    """The compiled step, linearised at rest (central differences of the map, undamped),
    has the discrete eigenvalues ``lambda + 1/lambda = 2 - h^2 W`` of the central
    difference, exactly: W of the higher pair is the ball's mode, which ``hertzsweep rig``
    computes from the dimensional stiffness and mass matrices (the lower contact at F_s +
    m_b g). Agreement to 1e-9: the finite differences' rounding (1e-16 / 1e-4 against
    h^2 W1 = 2.5e-3) and truncation (eps^2: 1e-8 of the curvature of u^(3/2)), nothing
    else."""
    two = scene(damping={"law": "viscous", "ratio": 0.0})
    model = model_law(two)
    h = 0.05  # h^2 W2 = 1.6: inside the stability limit 4
    eps = 1e-4
    rest = np.ones(4)
    jacobian = np.empty((4, 4))
    for k in range(4):
        e = np.zeros(4)
        e[k] = eps
        jacobian[:, k] = (one_step_map(model, h, rest + e) - one_step_map(model, h, rest - e)) / (
            2 * eps
        )
    cosines = np.sort(np.linalg.eigvals(jacobian).real)[::2]  # conjugate pairs
    squared = np.sort((2.0 - 2.0 * cosines) / h**2)
    constants = derive(two.rig)
    mode = math.sqrt(squared[-1]) * constants.natural_frequency
    assert mode == pytest.approx(constants.ball_mode_frequency, rel=1e-9)
    first, second = BallModel.of(two).squared_frequencies()
    assert squared == pytest.approx([first, second], rel=1e-9)


# ------------------------------------------------------------------- momentum
def test_momentum_balance_closes_over_a_period():
    """Over one period of an impacting transient (sigma = 30 %, contact law), the
    impulse of the input and of the upper contact's force equals the change of the
    moving mass's momentum, and the impulse of both contacts' forces and the ball's weight
    the ball's: the two rows of the scheme summed over the steps (kernels.ball), to 1e-10
    of the impulse of the input (rounding over 256 steps)."""
    sigma = 0.3  # at w = 0.8 it flies 121 steps of 256
    two = scene(damping=VIBRO_IMPACT, excitation={"sigma": [sigma]})
    model = model_law(two)
    constants = BallModel.of(two)
    n = two.solver.steps_per_period
    h = scheme.step_size(0.8, n)
    inputs = drive(two, sigma)
    q_prev, q = np.zeros((1, 2)), np.zeros((1, 2))
    status, _ = ball.advance_batch(q_prev, q, np.array([h]), model, inputs, 200)
    assert status == scheme.OK
    readout = ball.new_readout(inputs.harmonics.size, 1)
    # a period at another step, unretuned: a transient whose momentum changes
    h = scheme.step_size(0.75, n)
    status, _ = ball.measure(q_prev, q, np.array([h]), model, inputs, 1, readout)
    assert status == scheme.OK
    assert readout.counts[0, 0] > 0.2 * n  # it flies: the impacts are in the period
    extra = dict(zip(ball.BALL_FIELDS, readout.extra[:, 0], strict=True))
    sums = readout.sums[:, 0]

    def compressions(q1, q2):
        return 1.0 + (q1 - q2) * (2 / 3) / constants.upper, 1.0 + q2 * (2 / 3) / constants.lower

    u0p, l0p = compressions(sums[3], extra["q2_prev_last"])
    u0, l0 = compressions(sums[4], extra["q2_last"])
    u1p, l1p = compressions(sums[5], extra["q2_prev"])
    u1, l1 = compressions(sums[6], extra["q2"])
    du = (u1 - u1p) - (u0 - u0p)
    dl = (l1 - l1p) - (l0 - l0p)
    c0 = h * h * 2.0 / 3.0
    load = sigma * np.sum(inputs.sin_table)  # sum (F_n - 1)
    upper, lower = extra["upper_total"], sums[0]  # sums of (force / F_s - 1)
    scale = c0 * sigma * n
    moving = c0 * (load - upper) - (constants.upper * du + constants.lower * dl)
    ball_row = c0 * (n * (constants.load - 1.0) + upper - lower) - (
        constants.mass_ratio * constants.lower * dl
    )
    assert abs(moving) < 1e-10 * scale
    assert abs(ball_row) < 1e-10 * scale
    assert abs(constants.upper * du) > 1e-3 * scale  # the balance is not of zeros


# ------------------------------------------------------------------- the scheme
def test_order_two_with_the_paper_ball():
    """H1 of one settled dwell (sigma = 1 %, w = 0.95) at N, 2N, 4N, 8N: the differences
    fall by 4 per doubling (order 2 of the central difference), 1.9 to 2.1."""
    values = []
    for n in (256, 512, 1024, 2048):
        two = scene(
            excitation={"sigma": [0.01]},
            sweep={"start": 0.95, "stop": 0.95, "step": 0.01, "directions": ["up"],
                   "settle_periods": 1000, "measure_periods": 10},
            solver={"steps_per_period": n},
        )  # fmt: skip
        values.append(run_sweep(two).amplitude[0, 0, 0, 0])
    differences = np.abs(np.diff(values))
    orders = np.log2(differences[:-1] / differences[1:])
    assert np.all((orders > 1.9) & (orders < 2.1)), orders


def test_batched_equals_one_at_a_time():
    """Every (direction, sigma) in lockstep and one sweep at a time: the same numbers,
    bit for bit (one kernel; one trajectory is a batch of one)."""
    two = scene(
        excitation={"sigma": [0.01, 0.078]},
        sweep={"start": 0.8, "stop": 1.0, "step": 0.05, "settle_periods": 30,
               "measure_periods": 4},
    )  # fmt: skip
    a, b = run_sweep(two), run_sweep(two, batched=False)
    for name in ("amplitude", "phase", "force_max", "force_min", "contact_loss_fraction"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for name in a.extra:
        np.testing.assert_array_equal(a.extra[name], b.extra[name])


def test_restart_at_the_same_step_is_the_identity():
    """Retuning to the same step returns the state unchanged (``d - h d' + h^2/2 d''``
    with the centred differences of the next step is ``d[n-1]``), to rounding."""
    two = scene(excitation={"sigma": [0.05]})
    model = model_law(two)
    h = scheme.step_size(0.9, 256)
    q_prev, q = np.zeros((1, 2)), np.zeros((1, 2))
    ball.advance_batch(q_prev, q, np.array([h]), model, drive(two, 0.05), 7)
    again = ball.restart(q_prev[0], q[0], h, h, model)
    np.testing.assert_allclose(again, q_prev[0], rtol=0, atol=1e-12)


def test_kernel_refuses_steps_beyond_the_ball_mode():
    """A step the first mode allows but the ball's mode does not (h W2^(1/2) > 2):
    UNSTABLE, from the compression the run reaches."""
    two = scene()
    model = model_law(two)
    w2 = BallModel.of(two).squared_frequencies()[1]
    h = 2.05 / math.sqrt(w2)  # about 80 steps a period of the first mode
    q_prev, q = np.zeros((1, 2)), np.zeros((1, 2))
    status, where = ball.advance_batch(q_prev, q, np.array([h]), model, drive(two, 0.01), 2)
    assert (status, where) == (scheme.UNSTABLE, 0)
    status, _ = ball.advance_batch(
        np.zeros((1, 2)), np.zeros((1, 2)), np.array([1.8 / math.sqrt(w2)]), model,
        drive(two, 0.01), 2,
    )  # fmt: skip
    assert status == scheme.OK


# ------------------------------------------------------------------- the paper's ball
def test_paper_ball_is_the_single_model_at_its_first_mode():
    """The 70 g ball at sigma = 1 % (no loss of contact): its first mode lies at
    ``f0 (W1)^(1/2) = 0.99975 f0`` (the ball's mass and the lower contact's extra load),
    which against zeta = 0.45 % moves H1 near the resonance by up to 3 % at the same w.
    The single model with that f0 (the grid at the same frequencies in Hz) gives H1
    within 0.5 % over the whole sweep below w = 1.05; what remains is the ball's inertia
    in the transmitted force (about mu / 2 = 0.3 %)."""
    first = math.sqrt(BallModel.of(scene()).squared_frequencies()[0])
    assert first == pytest.approx(0.99975, abs=1e-5)
    f0 = derive(scene().rig).natural_frequency
    grid = {"start": 0.9, "stop": 1.05, "step": 0.0025}
    two = scene(excitation={"sigma": [0.01]}, sweep=grid)
    moved = {key: value / first for key, value in grid.items()}
    one = scene(
        "single",
        excitation={"sigma": [0.01]},
        sweep=moved,
        rig={**PAPER_RIG, "ball_mass": PAPER_BALL, "natural_frequency": f0 * first},
    )
    a, b = run_sweep(two), run_sweep(one)
    assert a.frequency_ratio.size == b.frequency_ratio.size
    relative = np.abs(a.amplitude[..., 0] / b.amplitude[..., 0] - 1.0)
    assert np.max(relative) < 0.005
    assert np.max(relative) > 0.001  # the ball's inertia is there
    same_w = run_sweep(scene("single", excitation={"sigma": [0.01]}, sweep=grid))
    shifted = np.abs(a.amplitude[..., 0] / same_w.amplitude[..., 0] - 1.0)
    assert np.max(shifted) > 0.02  # at the same w the first mode's shift shows


# ------------------------------------------------------------------- outputs
def test_sweep_and_trace_datasets_carry_the_ball(tmp_path, capsys):
    """The ball model's sweep carries both contacts' readings and the ball's flight with
    CF attributes; its trace records the ball and the upper force; the single model's
    datasets have none of them."""
    out = tmp_path / "ball.nc"
    argv = ["sweep", CONFIGS / "smoke.toml", "--set", "model.kind=ball", "-o", out]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    ds = xr.open_dataset(out)
    names = ("upper_force_max", "upper_force_min", "upper_contact_loss_fraction",
             "ball_flight_fraction", "ball_flight_time")  # fmt: skip
    for name in names:
        assert ds[name].dims == ("direction", "sigma", "frequency_ratio")
        assert ds[name].attrs["units"] in ("1", "s")
    assert ds.attrs["model_kind"] == "ball"
    # at rest the transducer carries the ball's weight too: mean N / F_s = 1 + m_b g / F_s
    load = BallModel.of(make_scene(model={"kind": "ball"})).load
    assert float(ds.mean_force.min()) == pytest.approx(load, abs=5e-3)
    single = tmp_path / "single.nc"
    code, _, _ = run_cli(["sweep", CONFIGS / "smoke.toml", "-o", single], capsys)
    assert code == 0
    assert not set(names) & set(xr.open_dataset(single).data_vars)

    trace = tmp_path / "trace.nc"
    argv = ["trace", CONFIGS / "smoke.toml", "--set", "model.kind=ball", "-w", "0.98",
            "--periods", "2", "-o", trace]  # fmt: skip
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    ds = xr.open_dataset(trace)
    for name in ("ball_displacement", "ball_velocity", "upper_force", "upper_in_contact"):
        assert ds[name].dims == ("sigma", "sample")
    # the ball moves about half as far as the moving mass (two like contacts in series)
    ratio = ds.ball_displacement.std("sample") / ds.displacement.std("sample")
    np.testing.assert_allclose(ratio, 0.5, atol=0.01)


def test_trace_flights_are_the_lower_contacts():
    """The trace's interpolated flights are the lower contact's (the transducer's), read
    from the ball's own columns: every sample inside a flight has the lower contact open
    and every open sample lies in a flight, and the flights' total duration is the open
    samples' within a sample per flight. The upper contact opens for longer (the ball
    stays on the lower disc under its weight while the moving mass flies)."""
    tables = dict(
        excitation={"sigma": [0.078]},
        damping=VIBRO_IMPACT,
        sweep={"start": 0.7, "stop": 1.0, "step": 0.025, "settle_periods": 200,
               "measure_periods": 4},
    )  # fmt: skip
    result = run_trace(scene(**tables), 0.7, periods=4)
    record = result.record[0]
    count = int(result.flights.count[0])
    assert count > 0
    tau = result.tau
    start, end = result.flights.start[0, :count], result.flights.end[0, :count]
    inside = np.zeros(tau.size, dtype=bool)
    for a, b in zip(start, end, strict=True):
        inside |= (tau >= a) & (tau < b)  # a flight cut by the record starts at 0
    lower_open = record[:, 3] == 0.0
    np.testing.assert_array_equal(inside, lower_open)
    step = result.sample_step
    assert np.sum(end - start) == pytest.approx(lower_open.sum() * step, abs=count * step)
    assert np.sum(record[:, 7] == 0.0) > lower_open.sum()
    # each bound where the lower compression l = 1 + 2 q2 / (3 a_l) vanishes: the linear
    # interpolation of l between the samples on either side agrees with the Hermite one
    # the flights use to 5 % of a sample (their difference is of the order of the
    # curvature of l over a sample)
    lower = BallModel.of(scene(**tables)).lower
    l = 1.0 + record[:, 4] * (2.0 / 3.0) / lower
    for bound in np.concatenate([start, end]):
        i = int(bound // step)
        if 0 < bound < tau[-1]:
            linear = i + l[i] / (l[i] - l[i + 1])
            assert bound / step == pytest.approx(linear, abs=0.05)


# ------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "overrides, words",
    [
        (["rig.geometry=sphere-plane"], "rig.geometry = 'double-sphere-plane'"),
        (["solver.method=rk4"], "solver.method = 'central-difference'"),
        (["solver.steps_per_period=64"], "the ball's own mode"),
    ],
)
def test_ball_model_refuses_what_it_cannot_run(overrides, words, capsys, tmp_path):
    argv = ["sweep", CONFIGS / "default.toml", "--set", "model.kind=ball"]
    for item in overrides:
        argv += ["--set", item]
    code, _, err = run_cli(argv + ["-o", tmp_path / "x.nc"], capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert words in err


# ------------------------------------------------------------------- the period map
PERIOD_MAP_SCENES = {
    # sigma = 7.8 %, contact law n = 3/2: at w = 0.95 both contacts open every period
    "loss": dict(damping=VIBRO_IMPACT, sigma=0.078, w=0.95),
    # sigma = 1 %, viscous: no loss of contact
    "no-loss": dict(damping=None, sigma=0.01, w=0.95),
}


def settled(case, periods=300):
    """``(model, inputs, h, q_prev, q)`` of a scene of :data:`PERIOD_MAP_SCENES` after
    ``periods`` periods from rest (on its orbit: the multipliers are below 0.94)."""
    two = scene(damping=case["damping"], excitation={"sigma": [case["sigma"]]})
    model = model_law(two)
    inputs = drive(two, case["sigma"])
    h = scheme.step_size(case["w"], two.solver.steps_per_period)
    q_prev, q, status = ball.advance(np.zeros(2), np.zeros(2), h, model, inputs, periods)
    assert status == scheme.OK
    return model, inputs, h, q_prev, q


def contact_pattern(model, inputs, q_prev, q, h):
    """Which contacts are closed (``u > 0``, ``l > 0``) at each step of one period, by
    the compiled step (bool[N, 2])."""
    u_prev, l_prev = ball.compressions(model, q_prev[0], q_prev[1])
    u, l = ball.compressions(model, q[0], q[1])
    closed = []
    for s in inputs.sin_table:
        load = scheme.forcing(inputs.sigma[0], s)
        _, _, _, _, x, y = ball.step(model, u_prev, u, l_prev, l, load, h, h * h * 2.0 / 3.0)
        u_prev, u, l_prev, l = u, u_prev + x, l, l_prev + y
        closed.append((u > 0.0, l > 0.0))
    return np.array(closed)


@pytest.mark.parametrize("name", PERIOD_MAP_SCENES)
def test_period_map_is_one_period_of_advance(name):
    """The period map's trajectory is advance's, bit for bit (the same step on the same
    operands), on and off the orbit: the settled state and 20 periods of the transient
    from rest, where in the loss scene the contacts open."""
    case = PERIOD_MAP_SCENES[name]
    model, inputs, h, q_prev, q = settled(case)
    derivative = np.empty((4, 5))
    starts = [(q_prev, q)]
    a, b = np.zeros(2), np.zeros(2)
    for _ in range(20):
        starts.append((a, b))
        a, b, _ = ball.advance(a, b, h, model, inputs, 1)
    for a, b in starts:
        p, r, status = ball.period_map(a, b, h, model, inputs, derivative)
        p_ref, r_ref, status_ref = ball.advance(a, b, h, model, inputs, 1)
        assert status == status_ref == scheme.OK
        assert np.all(p == p_ref) and np.all(r == r_ref)
        assert np.all(np.isfinite(derivative))
    opens = (~contact_pattern(model, inputs, q_prev, q, h)).sum(axis=0)
    assert np.all(opens > 0) if name == "loss" else np.all(opens == 0)


@pytest.mark.parametrize("name", PERIOD_MAP_SCENES)
def test_period_map_jacobian_is_the_finite_differences(name):
    """The exact Jacobian against central differences of the map's own end state, on the
    settled orbit: within 1e-6 of each column's largest entry. The steps: 1e-6 of the
    static compression's scale (|q| ~ 1, d = 1 + 2 q / 3) for the state, 1e-5 of h for h.
    The state columns' round-off (the end state's rounding, ~1e-16 amplified by the
    period, over 2 eps) is ~1e-7 of the ball's columns (0.04-0.2: its mode is damped out
    within a period) and their truncation O(eps^2 R''') is ~2e-7 in the loss scene
    (R''' ~ d^(-1/2) at the steps next to a contact's opening, 3e-5 at eps = 1e-5);
    measured at most 2.3e-7 (loss) and 1.8e-7 (no loss). A step of 1e-6 of |x| (1e-8 at
    sigma = 1 %) would leave the round-off at 1e-5-2e-4. No entry's differences straddle a contact
    change: every perturbed period has the same contacts open at the same steps."""
    case = PERIOD_MAP_SCENES[name]
    model, inputs, h, q_prev, q = settled(case)
    derivative = np.empty((4, 5))
    ball.period_map(q_prev, q, h, model, inputs, derivative)
    x0 = np.concatenate([q_prev, q])
    pattern = contact_pattern(model, inputs, q_prev, q, h)
    differences = np.empty((4, 5))
    for k in range(5):
        eps = 1e-6 if k < 4 else 1e-5 * h
        ends = []
        for sign in (1.0, -1.0):
            x = x0.copy()
            step = h
            if k < 4:
                x[k] += sign * eps
                assert np.array_equal(contact_pattern(model, inputs, x[:2], x[2:], h), pattern)
            else:
                step = h + sign * eps
            p, r, status = ball.period_map(x[:2], x[2:], step, model, inputs, np.empty((4, 5)))
            assert status == scheme.OK
            ends.append(np.concatenate([p, r]))
        differences[:, k] = (ends[0] - ends[1]) / (2.0 * eps)
    scale = np.max(np.abs(derivative), axis=0)
    assert np.all(scale > 0.01)  # no column of (near) zeros
    error = np.max(np.abs(differences - derivative), axis=0) / scale
    assert np.all(error < 1e-6), error


def test_period_map_refuses_steps_beyond_the_ball_mode():
    """As :func:`test_kernel_refuses_steps_beyond_the_ball_mode`: a step the ball's mode
    does not allow (h W2^(1/2) > 2) gives UNSTABLE, at advance's state; one it allows,
    OK."""
    two = scene()
    model = model_law(two)
    inputs = drive(two, 0.01)
    w2 = BallModel.of(two).squared_frequencies()[1]
    h = 2.05 / math.sqrt(w2)
    derivative = np.empty((4, 5))
    p, r, status = ball.period_map(np.zeros(2), np.zeros(2), h, model, inputs, derivative)
    assert status == scheme.UNSTABLE
    p_ref, r_ref, status_ref = ball.advance(np.zeros(2), np.zeros(2), h, model, inputs, 1)
    assert status_ref == scheme.UNSTABLE
    np.testing.assert_array_equal(np.concatenate([p, r]), np.concatenate([p_ref, r_ref]))
    h = 1.8 / math.sqrt(w2)
    _, _, status = ball.period_map(np.zeros(2), np.zeros(2), h, model, inputs, derivative)
    assert status == scheme.OK
