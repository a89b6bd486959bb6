"""Random excitation with the other method and model: rk4 (its crossings located and
corrected) and the ball model (central difference), and the trace of a random run.

The linear regime checks a run against the linearised eq. (8) as ``test_random`` does:
the variance of N/F_s is ``rms^2`` times the integral of ``|H|^2 S_f`` over the band. For
the ball model the transmissibility departs from H near the ball's own mode (w of about
26 on the paper's rig), so its band stays far below it (0.2 .. 3, where the ball's
inertia changes |H|^2 by about ``(w / 26)^2``, 1 % at the band's top, and the resonance
moves by ``5e-4``, far below the half-power width ``2 zeta``). Every tolerance on a
statistic is a number of its standard errors across realisations
(``std(ddof=1) / sqrt(R)``); the convergence orders are measured in the step with the
seed fixed, N/F_s compared at the steps of the coarsest step.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from hertzsweep.core.ballmodel import BallModel
from hertzsweep.core.excitation import coefficients, linear_response_variance, unit_forcing
from hertzsweep.drivers import random as driver
from hertzsweep.drivers.oscillator import model_law
from hertzsweep.drivers.random import run_random
from hertzsweep.errors import Interrupted
from hertzsweep.kernels import random as kernels
from hertzsweep.output.dataset import random_dataset, write_netcdf

from .conftest import PAPER_RIG, make_scene, run_cli
from .tomlwriter import toml_document

ZETA = 0.0045  # the paper's damping ratio
BAND = (0.2, 3.0)  # the band of frequency ratios, below the ball's mode
LINEAR = 1e-4  # an rms level of the linear regime
IMPACTS = 0.3  # an rms level with frequent loss of contact (about half the time)
RK4 = {"solver": {"method": "rk4"}}
BALL = {"model": {"kind": "ball"}}
BALL_STEPS = 128  # steps a period for the ball model: its stability limit at rest is
# 2 pi x 26 / 2 = 82 (the ball's mode), about 91 at the forces of rms 0.3


def random_scene(rms, tables=None, n=32, duration=400, transient=100, **run):
    """A random scene on the paper's rig (``tables``: the model's and the method's): 8
    realisations of ``duration`` measured periods after ``transient``, segments of 32
    periods, unless ``run`` (the other keys of ``[random]``) says otherwise."""
    tables = dict(tables or {})
    solver = {"steps_per_period": n, **tables.pop("solver", {})}
    return make_scene(
        damping={"ratio": ZETA},
        excitation={"kind": "random", "rms": list(rms), "band": list(BAND), "seed": 0},
        solver=solver,
        random={
            "realisations": 8,
            "duration_periods": duration,
            "transient_periods": transient,
            "segment_periods": 32,
            **run,
        },
        **tables,
    )


def record(tables, level, periods, n, law="viscous", realisation=0):
    """N/F_s - 1 of one trajectory from rest over ``periods`` periods of N steps with the
    kernel of the scene's model and method (one segment: the numbers of any cut), and
    the record's contact flags."""
    scene = make_scene(damping={"ratio": ZETA, "law": law}, **tables)
    kernel = driver.kernel(scene)
    m = kernel.per_step
    g = unit_forcing(0, realisation, BAND, periods, n, per_step=m)
    g = np.concatenate([g, g[: m - 1]])[:, None]  # rk4: the record's end is its start
    h = 2 * math.pi / n
    law = model_law(scene)
    drive = kernels.inputs(np.array([level]), np.array([0]), n)
    buffers = kernel.new_record(periods * n, 1)
    status = kernel.advance(law, h, kernel.at_rest(drive, g, h, law), drive, g, buffers)
    assert status == (kernels.OK, -1)
    return buffers.excess[:, 0], buffers.contact[:, 0]


def orders(tables, level, periods, steps, law="viscous"):
    """The differences of N/F_s between N and 2N at the steps of ``steps[0]`` for each N
    of ``steps``, and the orders they show (log2 of successive ratios)."""
    base = steps[0]
    values = {n: record(tables, level, periods, n, law)[0][:: n // base] for n in steps}
    values[2 * steps[-1]] = record(tables, level, periods, 2 * steps[-1], law)[0][
        :: 2 * steps[-1] // base
    ]
    differences = [np.abs(values[n] - values[2 * n]).max() for n in steps]
    found = [math.log2(a / b) for a, b in zip(differences, differences[1:], strict=False)]
    return differences, found, values[2 * steps[-1]]


# --------------------------------------------------------------------------- linear regime
@pytest.mark.parametrize(("tables", "n"), [(RK4, 32), (BALL, BALL_STEPS)], ids=["rk4", "ball"])
def test_variance_is_the_linear_response(tables, n):
    # var(N/F_s) per realisation against rms^2 x integral of |H|^2 S_f, within 3 standard
    # errors of its mean over the 8 realisations (measured: 1.12 rk4, 1.21 ball)
    result = run_random(random_scene([LINEAR], tables, n=n))
    variance = result.per_realisation["force_rms"][0] ** 2
    mean, stderr = variance.mean(), variance.std(ddof=1) / math.sqrt(variance.size)
    expected = LINEAR**2 * linear_response_variance(BAND, ZETA)
    assert abs(mean - expected) < 3.0 * stderr, (mean, expected, stderr)
    assert stderr < 0.1 * expected  # the comparison means something
    # the mean: the static load of the contact the transducer reads, within 3 standard
    # errors (1 for the single model; the lower contact's L = 1 + m_b g / F_s = 1.006 for
    # the ball model, which carries the ball's weight too)
    static = BallModel.of(random_scene([LINEAR], tables, n)).load if tables is BALL else 1.0
    assert abs(result.mean["force_mean"][0] - static) < 3.0 * result.stderr["force_mean"][0]
    assert result.mean["contact_loss_fraction"][0] == 0.0


# --------------------------------------------------------------------------- the kernels
KERNEL_CASES = [(RK4, 32, "viscous"), (RK4, 32, "contact"), (BALL, BALL_STEPS, "viscous")]
KERNEL_IDS = ["rk4-viscous", "rk4-contact", "ball"]


@pytest.mark.parametrize(("tables", "n", "law"), KERNEL_CASES, ids=KERNEL_IDS)
def test_segments_and_batches_give_the_numbers_of_one_run(tables, n, law):
    # with impacts: a record cut into segments of 7 periods (the state carries the last
    # crossing and the steps taken) and three trajectories together give the numbers of
    # one trajectory in one long run, bit for bit
    periods, levels = 21, np.array([0.05, IMPACTS, 0.15])
    scene = make_scene(damping={"ratio": ZETA, "law": law}, **tables)
    kernel = driver.kernel(scene)
    m = kernel.per_step
    g = np.stack([unit_forcing(0, r, BAND, periods, n, per_step=m) for r in range(3)], axis=1)
    g = np.concatenate([g, g[: m - 1]])
    h, law = 2 * math.pi / n, model_law(scene)

    def run(level, column, cut):
        drive = kernels.inputs(level, column, n)
        state = kernel.at_rest(drive, g, h, law)
        out = []
        for first in range(0, periods * n, cut * n):
            buffers = kernel.new_record(cut * n, level.size)
            status = kernel.advance(law, h, state, drive, g[m * first :], buffers)
            assert status == (kernels.OK, -1)
            out.append(buffers)
        return [np.concatenate(part) for part in zip(*out, strict=True)]

    batch = run(levels, np.arange(3), 7)
    assert np.count_nonzero(~batch[1][:, 1]) > 0  # rms 0.3 loses contact
    for t in range(3):
        alone = run(levels[t : t + 1], np.array([t]), periods)
        for mine, theirs in zip(alone, batch, strict=True):
            assert np.array_equal(mine[:, 0], theirs[:, t])


def test_the_load_at_a_crossing_is_third_order():
    # rk4 reads the load inside a step from the quadratic through its three samples: the
    # error against the process itself (its lines summed) falls 8-fold a halving of the
    # step (measured: 2.1e-3, 2.6e-4, 3.2e-5 at N = 32, 64, 128: orders 2.99, 3.00),
    # O(h^3 g'''), so O(h^4) in q' a crossing; the trajectory keeps the method's order
    # (test_a_short_trajectory_converges_at_the_methods_order). Evaluated exactly
    # instead (the lines summed at the crossing), the trajectory at rms 0.3 over 30
    # periods moves by 6.7e-7 at N = 64 (0.2 % of the step's own error there, 3.9e-4)
    # and 7.6e-13 at N = 1024; but a line sum costs 14 us on the paper's record (6160
    # lines), 40 us a crossing, where rk4 costs 40 ns a trajectory-step: at rms 0.3 (1.2
    # crossings a period) the run would be about 18 times slower at N = 64.
    periods = 30
    k, a, b = coefficients(0, 0, BAND, periods)
    w = k / periods
    fractions = np.linspace(0.0, 1.0, 11)
    errors = []
    for n in (32, 64, 128):
        h = 2 * math.pi / n
        samples = unit_forcing(0, 0, BAND, periods, n, per_step=2)[: 2 * 10 * n + 1]
        start = np.arange(10 * n) * h
        g0, gm, g1 = samples[0:-1:2], samples[1::2], samples[2::2]
        worst = 0.0
        for s in fractions:
            tau = start + s * h
            exact = np.cos(np.outer(tau, w)) @ a + np.sin(np.outer(tau, w)) @ b
            quadratic = np.array(
                [
                    kernels._interpolated(1.0, (x, y, z), s) - 1.0
                    for x, y, z in zip(g0, gm, g1, strict=True)
                ]
            )
            worst = max(worst, np.abs(quadratic - exact).max())
        errors.append(worst)
    found = [math.log2(x / y) for x, y in zip(errors, errors[1:], strict=False)]
    assert all(2.8 < order < 3.2 for order in found), (errors, found)


# --------------------------------------------------------------------------- convergence
CONVERGENCE = [
    # (tables, level, periods, steps, law, lowest, highest): the seed fixed, a short
    # record, N/F_s at the steps of the coarsest N from N, 2N, ...
    # rk4, linear regime: order 4 (measured: 4.01, 4.00)
    (RK4, LINEAR, 20, (32, 64, 128), "viscous", 3.8, 4.2),
    # rk4 through impacts (20 crossings, 14 % of the time out of contact): order 4 with
    # the Hertz term's s^(3/2) integrated exactly (measured: 4.03, 4.09, 4.02, 4.01; the
    # method's bound is 3.5, from the s^(5/2) terms it leaves, not seen here)
    (RK4, IMPACTS, 30, (64, 128, 256, 512, 1024), "viscous", 3.5, 4.3),
    # and with the contact law's damping (n = 3/2): measured 4.05, 4.02, 4.08, 4.06
    (RK4, IMPACTS, 30, (64, 128, 256, 512, 1024), "contact", 3.5, 4.3),
    # the ball model, central difference, linear regime: order 2 (measured: 2.00, 2.00)
    (BALL, LINEAR, 20, (128, 256, 512), "viscous", 1.9, 2.1),
    # and through impacts (measured: 2.03, 2.00, 2.04)
    (BALL, IMPACTS, 30, (128, 256, 512, 1024), "viscous", 1.9, 2.1),
]


@pytest.mark.parametrize(
    ("tables", "level", "periods", "steps", "law", "lowest", "highest"),
    CONVERGENCE,
    ids=["rk4-linear", "rk4-impacts", "rk4-impacts-contact", "ball-linear", "ball-impacts"],
)
def test_a_short_trajectory_converges_at_the_methods_order(
    tables, level, periods, steps, law, lowest, highest
):
    differences, found, finest = orders(tables, level, periods, steps, law)
    assert lowest < min(found) and max(found) < highest, (differences, found)
    assert differences[-1] < 1e-3 * np.abs(finest).max()
    _, contact = record(tables, level, periods, steps[0], law)
    assert contact.all() == (level == LINEAR)  # impacts where meant, none in the linear


LONG = [(RK4, 32), (BALL, BALL_STEPS)]  # the coarser step of the two compared


@pytest.mark.parametrize(("tables", "n"), LONG, ids=["rk4", "ball"])
def test_one_long_trajectory_is_sensitive_to_the_step(tables, n):
    # rms 0.3 over 400 periods at N and 2N, realisation 0: within 1e-3 of N/F_s's RMS over
    # the first period, apart by more than that RMS (O(1)) over most periods of the last
    # 100. Measured, the largest |difference| a period over the first and its median
    # over the last 100: rk4 2.9e-5 and 5.0, ball 2.0e-4 and 4.0 (RMS 1.5 both); it
    # passes 0.1 RMS in period 29 (rk4) and 24 (ball).
    coarse, _ = record(tables, IMPACTS, 400, n)
    fine = record(tables, IMPACTS, 400, 2 * n)[0][::2]
    apart = np.abs(coarse - fine).reshape(400, n).max(axis=1)
    rms = coarse.std()
    assert apart[0] < 1e-3 * rms
    assert np.median(apart[-100:]) > rms


@pytest.mark.parametrize(("tables", "n"), LONG, ids=["rk4", "ball"])
def test_the_ensemble_statistics_agree_across_the_step(tables, n):
    # the same scene at N and 2N (16 realisations of 400 periods, rms 0.15 and 0.3): the
    # statistics agree within 3 combined standard errors (the runs share their forcing,
    # so the independent errors combined overstate the difference's, a little: the
    # trajectories part within about 50 periods). Measured |z|, rk4: loss 0.21, 2.05;
    # force_rms 0.06, 2.03; peak 0.25, 1.41. Ball: 0.28, 0.48; 0.17, 0.20; 0.51, 0.93.
    results = [
        run_random(random_scene([0.15, IMPACTS], tables, n=steps, realisations=16))
        for steps in (n, 2 * n)
    ]
    assert results[0].mean["contact_loss_fraction"][1] > 0.4
    for name in ("contact_loss_fraction", "force_rms", "peak_frequency_ratio"):
        (a, a_err), (b, b_err) = ((r.mean[name], r.stderr[name]) for r in results)
        assert np.all(np.abs(a - b) < 3.0 * np.hypot(a_err, b_err)), (name, a, b)
        assert np.all(a_err > 0.0)


# --------------------------------------------------------------------------- the ball's own
def test_a_blow_up_between_two_checks_ends_as_a_stability_error(tmp_path, capsys):
    # rms 30 at 8 steps a period, contact law, rk4: validate accepts it (the step 1.1x its
    # estimated stability limit), but an impact drives a trajectory beyond the limit and
    # to a non-finite state between two checks (one a period). The crossing of such a
    # state must end, and the run with it: one line, exit 2, the stability error. In a
    # process of its own with a timeout, because what this guards against is a loop.
    raw = {
        "rig": dict(PAPER_RIG),
        "damping": {"ratio": 0.01, "law": "contact", "exponent": 1.5},
        "excitation": {"kind": "random", "rms": [30.0], "band": list(BAND)},
        "solver": {"method": "rk4", "steps_per_period": 8},
        "random": {"realisations": 5, "duration_periods": 64, "transient_periods": 0},
    }
    path = tmp_path / "edge.toml"
    path.write_text(toml_document(raw))
    code, stdout, err = run_cli(["validate", path], capsys)
    assert code == 0 and "1.1x the stability limit" in stdout, err
    argv = [sys.executable, "-m", "hertzsweep", "random", str(path), "-o", str(tmp_path / "x.nc")]
    done = subprocess.run(argv, capture_output=True, text=True, timeout=240)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert "beyond the stability limit at the compression reached (rms = 30" in lines[0]
    assert not (tmp_path / "x.nc").exists()


def test_the_ball_flies_when_both_contacts_open():
    # ball_flight_fraction: the share of the measured steps with both contacts open, at
    # most the lower contact's loss fraction; none in the linear regime. On the paper's
    # rig the lower contact opens only with the upper one open (the ball's weight is
    # 0.6 % of F_s; the upper opens alone too), so the two fractions agree: measured,
    # equal at every step.
    scene = random_scene([LINEAR, IMPACTS], BALL, n=BALL_STEPS, duration=100, transient=20)
    result = run_random(scene)
    flight = result.per_realisation["ball_flight_fraction"]
    assert np.all(flight[0] == 0.0) and np.all(flight[1] > 0.0)
    assert np.all(flight <= result.per_realisation["contact_loss_fraction"])
    ds = random_dataset(result, scene, history="test")
    assert ds["ball_flight_fraction"].dims == ("rms",)
    assert ds["ball_flight_fraction_stderr"].attrs["long_name"]
    single = run_random(random_scene([LINEAR], duration=64, transient=0, realisations=2))
    assert "ball_flight_fraction" not in single.mean


# --------------------------------------------------------------------------- the trace
@pytest.mark.parametrize("tables", [{}, RK4, BALL], ids=["central-difference", "rk4", "ball"])
def test_the_trace_is_the_record(tables, tmp_path):
    # 3 periods traced across segments of 2: N/F_s is the record's at those steps and f
    # the forcing's, bit for bit; the statistics are those of a run without a trace
    n = BALL_STEPS if tables is BALL else 32
    run = {"duration": 8, "transient": 4, "segment_periods": 2, "realisations": 2}
    scene = random_scene([0.05, IMPACTS], tables, n=n, trace_periods=3, **run)
    traced = run_random(scene)
    plain = run_random(random_scene([0.05, IMPACTS], tables, n=n, **run))
    assert plain.trace_tau.size == 0
    for name in plain.mean:
        assert np.array_equal(
            traced.per_realisation[name], plain.per_realisation[name], equal_nan=True
        ), name
    # the record of one long segment (the numbers of any cut) from the kernels
    plan = driver.Plan.of(scene)
    kernel = driver.kernel(scene)
    table = driver.forcing_table(plan)
    drive = kernels.inputs(np.repeat(plan.rms, 2), np.tile(np.arange(2), 2), n)
    law = model_law(scene)
    state = kernel.at_rest(drive, table, plan.h, law)
    steps = plan.transient_steps + plan.trace_steps
    buffers = kernel.new_record(steps, plan.trajectories)
    assert kernel.advance(law, plan.h, state, drive, table, buffers) == (kernels.OK, -1)
    measured = slice(plan.transient_steps, steps)
    for level in range(2):
        expected = 1.0 + buffers.excess[measured, 2 * level]
        assert np.array_equal(traced.trace_force[level], expected)
        forcing = plan.rms[level] * table[:: kernel.per_step][measured, 0]
        assert np.array_equal(traced.trace_forcing[level], forcing)
    assert np.array_equal(traced.trace_tau, np.arange(3 * n) * plan.h)
    ds = random_dataset(traced, scene, history="test")
    assert ds["trace_force"].dims == ("rms", "trace_sample") == ds["trace_forcing"].dims
    assert ds["trace_time"].attrs["units"] == "s" and ds["trace_tau"].attrs["long_name"]
    assert "trace_force" not in random_dataset(plain, scene, history="test").data_vars
    write_netcdf(ds, tmp_path / "traced.nc")


def test_an_interrupted_trace_keeps_what_was_recorded():
    # the trace past the last measured segment finished is NaN
    calls = []

    def progress(steps):
        calls.append(steps)
        if len(calls) == 3:  # 2 transient segments, 1 measured of 2 periods
            raise KeyboardInterrupt

    scene = random_scene([IMPACTS], RK4, trace_periods=4, segment_periods=2, transient=4)
    with pytest.raises(Interrupted) as caught:
        run_random(scene, progress)
    trace = caught.value.partial.trace_force[0]
    assert np.isfinite(trace[: 2 * 32]).all() and np.isnan(trace[2 * 32 :]).all()
