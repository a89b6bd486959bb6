"""The response's period, the tap's start and the sweep's subharmonic jumps (issue #33).

The scene where the stepped sine falls onto a subharmonic: the paper's rig, viscous zeta =
0.45 %, sigma = 30 %, w from 1.96 to 2.06 in steps of 0.01. The branch of period-1 orbits
(``hertzsweep branch``) loses stability by period doubling between w = 1.9849 and 2.0131;
with 3000 settling periods the up sweep runs on the period-2 response from 1.99 to 2.01,
the down sweep falls onto it at 2.01 and stays there to 1.96 (the period-2 branch folds far
below). sigma = 10 % stays below the period doubling.
"""

from __future__ import annotations

import numpy as np
import pytest

from hertzsweep.drivers.oscillator import Block, Oscillator
from hertzsweep.drivers.period import MAX_RESPONSE_PERIOD, response_periods
from hertzsweep.drivers.sweep import find_subharmonic, run_sweep
from hertzsweep.errors import ConfigError
from hertzsweep.output.dataset import sweep_dataset
from hertzsweep.output.frame import load_xarray
from hertzsweep.output.plot import MULTI_PERIOD, NOT_PERIODIC, SUBHARMONIC_JUMPS, sweep_figure
from hertzsweep.output.summary import sweep_summary

from .conftest import CONFIGS, make_scene

xr = load_xarray()

GRID = np.round(np.arange(1.96, 2.0601, 0.01), 12)


def subharmonic_scene(settle: int = 3000, **sweep):
    return make_scene(
        damping={"ratio": 0.0045},
        excitation={"sigma": [0.1, 0.3]},
        sweep={"start": 1.96, "stop": 2.06, "step": 0.01, "settle_periods": settle, **sweep},
        lockin={"harmonics": [1, 2]},
    )


@pytest.fixture(scope="module")
def subharmonic_sweep():
    return run_sweep(subharmonic_scene())


def settled_state(scene, sigma: float, path):
    """The state and reading after dwelling along ``path`` one dwell at a time (not the
    sweep's code path: the oscillator's own dwell)."""
    oscillator = Oscillator(scene, sigma)
    state = oscillator.initial(float(path[0]))
    for w in path:
        state, reading, _ = oscillator.dwell(state, float(w))
    return oscillator, state, reading


def relative_returns(oscillator, state, reading, w: float, periods: int) -> np.ndarray:
    """``max |x_n - x_0|`` over the scale of ``periodic``, n = 1 .. periods."""
    x0 = np.array([state.q_prev, state.q])
    scale = max(np.abs(x0).max(), 0.5 * (reading.force_max - reading.force_min))
    out = []
    for n in range(1, periods + 1):
        later = oscillator.advance(state, w, n)
        out.append(np.abs(np.array([later.q_prev, later.q]) - x0).max() / scale)
    return np.array(out)


# --------------------------------------------------------------------------- response_period
def test_default_scene_settled_dwells_repeat_every_period():
    scene = make_scene(
        damping={"ratio": 0.0045},
        excitation={"sigma": [0.006, 0.01]},
        sweep={"start": 0.96, "stop": 1.00, "step": 0.0025, "settle_periods": 300},
    )
    result = run_sweep(scene)
    settled = result.settled & result.periodic
    assert settled.sum() >= 60
    assert np.all(result.response_period[settled] == 1)
    # periodic means n == 1, and nothing here repeats after more periods
    np.testing.assert_array_equal(result.response_period == 1, result.periodic)
    assert set(np.unique(result.response_period)) <= {0, 1}


def test_period_two_dwell_against_an_independent_integration(subharmonic_sweep):
    result = subharmonic_sweep
    up, w = 0, 2.00
    i = int(np.flatnonzero(np.isclose(GRID, w))[0])
    assert result.response_period[up, 1, i] == 2
    assert not result.periodic[up, 1, i] and result.settled[up, 1, i]
    path = GRID[: i + 1]
    oscillator, state, reading = settled_state(subharmonic_scene(), 0.3, path)
    returns = relative_returns(oscillator, state, reading, w, 4)
    assert returns[1] < 1e-8 and returns[3] < 1e-8  # after 2 and 4 periods: back
    assert returns[0] > 0.5 and returns[2] > 0.5  # after 1 and 3: the other half
    # the same dwell read by the sweep: its readings are the oscillator's, bit for bit
    assert result.amplitude[up, 1, i, 0] == reading.amplitude[0]


def test_dwell_that_does_not_repeat_reads_zero():
    """300 periods after the period doubling the period-1 orbit has not finished leaving
    (its multiplier near -1 grows a perturbation slowly): the up sweep's dwell at 1.99
    repeats within none of 8 periods."""
    result = run_sweep(subharmonic_scene(settle=300, directions=["up"]))
    i = int(np.flatnonzero(np.isclose(GRID, 1.99))[0])
    assert result.response_period[0, 1, i] == 0
    oscillator, state, reading = settled_state(subharmonic_scene(settle=300), 0.3, GRID[: i + 1])
    returns = relative_returns(oscillator, state, reading, 1.99, MAX_RESPONSE_PERIOD)
    assert np.all(returns > oscillator.periodic_tolerance)


@pytest.mark.parametrize(
    "model, method",
    [("single", "central-difference"), ("single", "rk4"), ("ball", "central-difference")],
)
def test_every_method_and_model_reads_the_period(model, method):
    """A periodic dwell taken as not periodic returns after one period: read as 0 (still
    settling), through each method's and model's kernels; periodic ones are 1."""
    scene = make_scene(
        damping={"ratio": 0.0045},
        excitation={"sigma": [0.01]},
        sweep={"start": 0.9, "stop": 0.91, "step": 0.01, "settle_periods": 200},
        solver={"method": method},
        model={"kind": model},
    )
    oscillator = Oscillator(scene, 0.01)
    state, block = oscillator.measure_block(
        oscillator.advance(oscillator.rest(0.9), 0.9, 200), 0.9, 10
    )
    assert block.periodic[0]
    h = np.array([state.h])
    assert response_periods(oscillator, block, np.array([0.01]), h)[0] == 1
    forced = Block(**{**block.__dict__, "periodic": np.array([False])})
    assert response_periods(oscillator, forced, np.array([0.01]), h)[0] == 0


# --------------------------------------------------------------------------- subharmonic jumps
def test_find_subharmonic_follows_the_jump_convention():
    w = np.arange(10) * 0.1
    periods = np.array([1, 1, 2, 2, 1, 0, 2, 2, 2, 1])
    assert find_subharmonic(periods, w, "up") == (pytest.approx(0.5), pytest.approx(0.8))
    assert find_subharmonic(periods, w, "down") == (pytest.approx(0.9), pytest.approx(0.6))
    assert np.isnan(find_subharmonic(np.ones(10), w, "up")).all()
    onset, end = find_subharmonic(np.array([2, 2, 1, 1, 1, 1, 1, 1, 1, 1]), w, "up")
    assert np.isnan(onset) and end == pytest.approx(0.1)  # starts on it: no jump onto it


def test_sweep_reports_where_the_response_period_switches(subharmonic_sweep):
    result = subharmonic_sweep
    up, down = 0, 1
    np.testing.assert_array_equal(result.response_period[up, 1], [1, 1, 1, 2, 2, 2] + [1] * 5)
    np.testing.assert_array_equal(result.response_period[down, 1], [2] * 6 + [1] * 5)
    assert result.subharmonic_onset_frequency_ratio[up, 1] == pytest.approx(1.98)
    assert result.subharmonic_end_frequency_ratio[up, 1] == pytest.approx(2.01)
    assert result.subharmonic_onset_frequency_ratio[down, 1] == pytest.approx(2.02)
    assert np.isnan(result.subharmonic_end_frequency_ratio[down, 1])  # on it to the end
    assert np.isnan(result.subharmonic_onset_frequency_ratio[:, 0]).all()  # sigma = 10 %
    assert np.isnan(result.subharmonic_end_frequency_ratio[:, 0]).all()
    assert np.all(result.response_period[:, 0] == 1)


def test_shorter_dwells_leave_the_period_one_orbit_late():
    """With 300 settling periods the up sweep reaches the period-2 response only at 2.02,
    past the period doubling at 2.0131 (3000 periods: at 1.99)."""
    result = run_sweep(subharmonic_scene(settle=300, directions=["up"]))
    assert result.subharmonic_onset_frequency_ratio[0, 1] == pytest.approx(2.01)
    assert result.subharmonic_end_frequency_ratio[0, 1] == pytest.approx(2.02)


def test_dataset_summary_and_figure_show_the_subharmonic(subharmonic_sweep):
    scene = subharmonic_scene()
    frame = sweep_dataset(subharmonic_sweep, scene)
    ds = frame.to_xarray()
    assert ds.response_period.dtype == np.int8
    assert ds.response_period.dims == ds.periodic.dims
    for name in ("response_period", *SUBHARMONIC_JUMPS):
        assert ds[name].attrs["long_name"] and ds[name].attrs["units"] == "1"
    lines = sweep_summary(subharmonic_sweep, ds).splitlines()
    assert lines[0].endswith(" sub on sub off")
    assert lines[2].endswith(" 1.9800  2.0100")  # up, sigma = 30 %
    assert lines[4].endswith(" 2.0200       -")  # down, sigma = 30 %
    fig = sweep_figure(ds, view="amplitude", harmonics=[1])
    texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert MULTI_PERIOD[1] in texts and NOT_PERIODIC[1] not in texts
    assert all(label in texts for _, label in SUBHARMONIC_JUMPS.values())
    squares = [line for line in fig.axes[0].get_lines() if line.get_marker() == MULTI_PERIOD[0]]
    drawn = np.concatenate([np.asarray(line.get_xdata(), float) for line in squares])
    assert drawn.size == int((ds.response_period.sel(sigma=0.3) == 2).sum())
    marks = [line for line in fig.axes[0].get_lines() if line.get_linestyle() in ("--", ":")]
    assert sorted(float(line.get_xdata()[0]) for line in marks) == pytest.approx([1.98, 2.01, 2.02])


def test_without_a_subharmonic_table_and_figure_are_as_before(subharmonic_sweep):
    ds = sweep_dataset(subharmonic_sweep, subharmonic_scene()).to_xarray().isel(sigma=[0])
    lines = sweep_summary(None, ds).splitlines()
    assert lines[0].endswith("N min  loss")
    fig = sweep_figure(ds, view="amplitude", harmonics=[1])
    texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert MULTI_PERIOD[1] not in texts
    assert not any(label in texts for _, label in SUBHARMONIC_JUMPS.values())
    assert not [line for line in fig.axes[0].get_lines() if line.get_linestyle() in ("--", ":")]


# --------------------------------------------------------------------------- initial_state
@pytest.mark.parametrize("method", ["central-difference", "rk4"])
def test_initial_state_starts_the_first_dwell_of_each_direction(method):
    tap = [0.3, -0.2]
    scene = make_scene(
        damping={"ratio": 0.0045},
        excitation={"sigma": [0.006, 0.01]},
        sweep={"start": 0.96, "stop": 0.97, "step": 0.005, "settle_periods": 20,
               "measure_periods": 4, "initial_state": tap},
        solver={"method": method},
    )  # fmt: skip
    result = run_sweep(scene)
    for d, w in ((0, 0.96), (1, 0.97)):  # up starts at start, down at stop
        for s, sigma in enumerate((0.006, 0.01)):
            oscillator = Oscillator(scene, sigma)
            _, reading, _ = oscillator.dwell(oscillator.from_velocity(*tap, w), w)
            i = 0 if d == 0 else 2
            np.testing.assert_array_equal(result.amplitude[d, s, i], reading.amplitude)
            np.testing.assert_array_equal(result.phase[d, s, i], reading.phase)
            assert result.force_max[d, s, i] == reading.force_max
    # one sweep at a time (the oscillator's walk) starts there too
    alone = run_sweep(scene, batched=False)
    np.testing.assert_array_equal(alone.amplitude, result.amplitude)
    # from rest, it is not the same
    rest = run_sweep(scene.with_overrides({"sweep.initial_state": [0.0, 0.0]}))
    assert np.abs(rest.amplitude[:, :, 0] - result.amplitude[:, :, 0]).max() > 1e-4


def test_initial_state_at_rest_is_the_default_bit_for_bit():
    scene = make_scene(
        excitation={"sigma": [0.01]},
        sweep={"start": 0.96, "stop": 0.97, "step": 0.005, "settle_periods": 30},
    )
    default = run_sweep(scene)
    tapped = run_sweep(scene.with_overrides({"sweep.initial_state": [0.0, 0.0]}))
    np.testing.assert_array_equal(default.amplitude, tapped.amplitude)
    np.testing.assert_array_equal(default.force_min, tapped.force_min)
    assert "sweep_initial_state" not in scene.attributes()
    assert "initial_state" not in scene.to_dict()["sweep"]
    tapped_scene = scene.with_overrides({"sweep.initial_state": [0.25, 0.5]})
    assert tapped_scene.attributes()["sweep_initial_state"] == [0.25, 0.5]
    assert tapped_scene.to_dict()["sweep"]["initial_state"] == [0.25, 0.5]


def test_initial_state_is_refused_for_the_ball_model():
    with pytest.raises(ConfigError, match="sweep.initial_state.*ball"):
        make_scene(model={"kind": "ball"}, sweep={"initial_state": [0.1, 0.0]})


def test_default_config_has_no_initial_state():
    from hertzsweep.core.config import load_scene

    assert load_scene(CONFIGS / "default.toml").sweep.initial_state is None


def test_trace_reads_the_period_and_says_so():
    from hertzsweep.drivers.trace import run_trace
    from hertzsweep.output.dataset import trace_dataset
    from hertzsweep.output.summary import trace_summary

    scene = subharmonic_scene()
    result = run_trace(scene, 2.0, periods=4, branch="lower")
    np.testing.assert_array_equal(result.response_period, [1, 2])  # sigma = 10 %, 30 %
    ds = trace_dataset(result, scene).to_xarray()
    assert ds.response_period.dims == ("sigma",)
    lines = trace_summary(result, ds).splitlines()
    assert lines[0].endswith("(settled)")
    assert lines[1].endswith("(settled, not periodic: repeats every 2 periods)")
