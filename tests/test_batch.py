"""Batched trajectories: the same numbers as one trajectory at a time, bit for bit."""

import numpy as np
import pytest

from hertzsweep.drivers import bench
from hertzsweep.drivers.oscillator import Oscillator, drive
from hertzsweep.drivers.sweep import lockstep, run_sweep
from hertzsweep.errors import StabilityError
from hertzsweep.kernels import integrate, scheme
from hertzsweep.kernels.laws import make_law

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
    single = run_sweep(scene, batched=False)
    batched = run_sweep(scene)
    assert_same(single, batched)
    # the comparison covers loss of contact and both kinds of dwell
    assert np.nanmax(single.contact_loss_fraction) > 0.3
    assert np.nanmin(single.contact_loss_fraction) == 0.0
    assert np.all(batched.finished)


def test_single_measured_block_and_one_direction():
    scene = small_scene(LAWS[4], measure_periods=1, directions=["down"])
    assert_same(run_sweep(scene, batched=False), run_sweep(scene))


def test_auto_settling_falls_back_to_one_sweep_at_a_time():
    """``"auto"`` dwells differ in length per trajectory: the batched entry point runs the
    sweeps one by one; checked against dwells taken by hand on the oscillator."""
    scene = small_scene(LAWS[4], settle_periods="auto", stop=0.65)
    assert not lockstep(scene)
    assert lockstep(small_scene(LAWS[4]))
    result = run_sweep(scene)
    oscillator = Oscillator(scene, scene.excitation.sigma[2])
    w = scene.sweep.frequency_ratios[::-1]  # the down sweep
    state = oscillator.rest(w[0])
    for i, x in enumerate(w):
        state, reading, settled = oscillator.dwell(state, x)
        index = w.size - 1 - i
        assert result.amplitude[1, 2, index, 0] == reading.amplitude[0]
        assert result.settled[1, 2, index] == settled


@pytest.mark.parametrize("law", ["viscous", "contact"])
def test_advance_batch_equals_advance_per_trajectory(law):
    scene = small_scene({"ratio": 0.01, "law": law, "exponent": 1.5})
    record = make_law(law, 0.01, 1.5)
    n = scene.solver.steps_per_period
    w = np.array([0.6, 0.8, 0.95])
    sigma = np.array([0.078, 0.03, 0.005])
    h = np.array([scheme.step_size(x, n) for x in w])
    q_prev, q = np.zeros(3), np.zeros(3)
    status, bad = integrate.advance_batch(q_prev, q, h, record, drive(scene, sigma), 150)
    assert (status, bad) == (scheme.OK, -1)
    for t in range(3):
        ref = integrate.advance(0.0, 0.0, h[t], record, drive(scene, sigma[t]), 150)
        assert (q_prev[t], q[t]) == ref[:2]


def test_advance_batch_reports_the_unstable_trajectory():
    # N = 8 at w = 0.3 puts h omega beyond 2 even at rest (h = 2.6): trajectory 1 fails
    scene = small_scene(LAWS[0])
    h = np.array([scheme.step_size(1.0, 256), scheme.step_size(0.3, 8)])
    out = integrate.advance_batch(
        np.zeros(2), np.zeros(2), h, make_law("viscous", 0.01, 1.5), drive(scene, [0.01] * 2), 2
    )
    assert out == (scheme.UNSTABLE, 1)


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
        run_sweep(scene, batched=False)
    with pytest.raises(StabilityError) as batched:
        run_sweep(scene)
    assert str(batched.value) == str(single.value)


def test_bench_floor_is_the_kernels_own_recurrence():
    """The floor ``bench`` divides by is the viscous update itself, stripped of everything
    else: the same operands in the same order give the same bits as the kernel."""
    (a, b, k), loads = bench._chain_constants(1)
    scene = bench.bench_scene(2)
    h = scheme.step_size(0.97, 256)
    q_prev, q, status = integrate.advance(
        0.0, 0.0, h, make_law("viscous", 0.0045, 1.5), drive(scene, 0.01), 3
    )
    assert status == scheme.OK
    assert bench._bare_chain(1.0, a[0], b[0], k[0], loads, 3) == scheme_compression(q)
    lanes = bench._bare_lanes(np.ones(4), (a.repeat(4), b.repeat(4), k.repeat(4)), loads, 3)
    assert np.all(lanes == scheme_compression(q))


def test_bench_divided_floor_is_the_contact_update():
    """The contact law's floor is its update (n = 3/2) stripped of everything else: the
    same bits as the kernel, so the division and the root it times are the kernel's."""
    law = make_law("contact", 0.01, 1.5)
    h = scheme.step_size(0.97, 256)
    step = scheme.make_step(law, h)
    _, loads = bench._chain_constants(1)
    q_prev, q, status = integrate.advance(0.0, 0.0, h, law, drive(bench.bench_scene(2), 0.01), 3)
    assert status == scheme.OK
    lanes = bench._bare_lanes(np.ones(3), (law.twozeta, step.half_h, step.c0), loads, 3)
    assert np.all(lanes == scheme_compression(q))


def scheme_compression(q):
    return 1.0 + q * (2.0 / 3.0)
