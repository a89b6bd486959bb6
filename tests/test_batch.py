"""Batched trajectories: the same numbers as one trajectory at a time, bit for bit."""

import numpy as np
import pytest

from hertzsweep.core.model import law_code
from hertzsweep.drivers.batch import advance_batch, bench_batch, lockstep, run_sweep_batched
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.errors import StabilityError
from hertzsweep.kernels import integrators

from .conftest import make_scene

FIELDS = ("amplitude", "phase", "mean_force", "force_max", "force_min", "contact_loss_fraction",
          "flight_tau", "settled", "periodic", "jump_frequency_ratio")  # fmt: skip

LAWS = [
    {"ratio": 0.0045, "law": "viscous"},
    {"ratio": 0.01, "law": "contact", "exponent": 0.0},
    {"ratio": 0.01, "law": "contact", "exponent": 0.5},
    {"ratio": 0.01, "law": "contact", "exponent": 1.0},
    {"ratio": 0.01, "law": "contact", "exponent": 1.5},
    {"ratio": 0.01, "law": "contact", "exponent": 1.3},  # the general law (pow)
]


def small_scene(damping, measure_periods=8, **sweep):
    # sigma = 7.8 % loses contact over most of the grid (Fig. 17), 0.5 % never does;
    # up and down walk the grid in opposite orders, so every dwell mixes step sizes
    table = {"start": 0.55, "stop": 1.0, "step": 0.05, "settle_periods": 60,
             "measure_periods": measure_periods, **sweep}  # fmt: skip
    return make_scene(damping=damping, excitation={"sigma": [0.005, 0.03, 0.078]}, sweep=table,
                      solver={"steps_per_period": 128})  # fmt: skip


def assert_same(single, batched):
    for name in FIELDS:
        a, b = getattr(single, name), getattr(batched, name)
        # bit for bit: the batched kernels do each trajectory's operations in the same order
        assert np.array_equal(a, b, equal_nan=True), name
    assert single.steps == batched.steps
    assert single.directions == batched.directions


@pytest.mark.parametrize("damping", LAWS, ids=lambda d: f"{d['law']}-{d.get('exponent', '')}")
def test_batched_sweep_equals_single_bit_for_bit(damping):
    scene = small_scene(damping)
    single = run_sweep(scene)
    batched = run_sweep_batched(scene)
    assert_same(single, batched)
    # the comparison covers loss of contact and both kinds of dwell
    assert np.nanmax(single.contact_loss_fraction) > 0.3
    assert np.nanmin(single.contact_loss_fraction) == 0.0
    assert np.all(batched.finished)


def test_single_measured_block_and_one_direction():
    scene = small_scene(LAWS[4], measure_periods=1, directions=["down"])
    assert_same(run_sweep(scene), run_sweep_batched(scene))


def test_auto_settling_falls_back_to_run_sweep():
    scene = small_scene(LAWS[4], settle_periods="auto", stop=0.65)
    assert not lockstep(scene)
    assert lockstep(small_scene(LAWS[4]))
    assert_same(run_sweep(scene), run_sweep_batched(scene))


@pytest.mark.parametrize("law", ["viscous", "contact"])
def test_advance_batch_equals_advance_per_trajectory(law):
    # three trajectories at three step sizes and input levels, two of them impacting
    scene = make_scene(damping={"ratio": 0.01, "law": law, "exponent": 1.5})
    code = law_code(scene.damping)
    n = 64
    sin_table, _ = integrators.period_tables(n)
    w = np.array([0.6, 0.8, 0.97])
    h = np.array([integrators.step_size(x, n) for x in w])
    sigma = np.array([0.08, 0.002, 0.05])
    q_prev, q = np.zeros(3), np.zeros(3)
    status, bad = advance_batch(q_prev, q, h, sigma, sin_table, 150, 0.01, code, 1.5)
    assert (status, bad) == (integrators.OK, -1)
    for t in range(3):
        ref = integrators.advance(0.0, 0.0, h[t], sigma[t], sin_table, 150, 0.01, code, 1.5)
        assert (q_prev[t], q[t]) == ref[:2]


def test_advance_batch_reports_the_unstable_trajectory():
    # 3 steps per period at w = 0.3 is far beyond the limit (h omega >= 2 at rest)
    n = 3
    sin_table, _ = integrators.period_tables(n)
    h = np.array([integrators.step_size(1.0, 256), integrators.step_size(0.3, n)])
    out = advance_batch(np.zeros(2), np.zeros(2), h, np.array([0.01, 0.01]), sin_table, 2,
                        0.01, 0, 1.5)  # fmt: skip
    assert out == (integrators.UNSTABLE, 1)


def test_batched_failure_raises_the_single_runs_error():
    # sigma = 2, n = 0 at w = 0.5 passes the pre-run check at N = 12 but reaches a
    # compression beyond the limit (as in test_extremes): the same one-line error
    scene = make_scene(
        damping={"ratio": 0.05, "law": "contact", "exponent": 0.0},
        excitation={"sigma": [2.0]},
        sweep={"start": 0.5, "stop": 0.5, "directions": ["up"], "settle_periods": 300},
        solver={"steps_per_period": 12},
    )
    assert lockstep(scene)
    with pytest.raises(StabilityError) as single:
        run_sweep(scene)
    with pytest.raises(StabilityError) as batched:
        run_sweep_batched(scene)
    assert str(batched.value) == str(single.value)


def test_bench_batch_figures():
    figures = bench_batch(counts=(2,), repeats=1)
    assert set(figures) == {"ns_per_trajectory_step_2", "sweep_ns_per_trajectory_step_2"}
    # compiled kernels take a few ns per trajectory-step; 500 ns is far above that on a
    # loaded machine and far below an interpreted step (about 1 us)
    assert all(0 < v < 500 for v in figures.values())
