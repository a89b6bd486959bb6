"""Orbits of n excitation periods: the n-period map and its exact tangent, shooting on it
(``[sweep] period_multiple``), and the period-doubled branches that ``hertzsweep branch
--follow-pd`` continues from every period doubling.

The rig is the paper's (configs/paper/fig04_06.toml: viscous zeta = 0.45 %). At sigma =
0.2 the period-1 branch doubles its period twice near w = 2 (the quadratic term of the
Hertz law drives the w/2 subharmonic resonance): at w_PD = 2.006103 and 1.993025, where
one Floquet multiplier is -1; between them the period-1 orbit is unstable. From each a
period-2 branch runs down in w (the subharmonic resonance leans to low frequencies, as
the Hertz contact softens): from 2.006103 a stable one (supercritical), from 1.993025 an
unstable one (subcritical).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hertzsweep.core.config import load_scene
from hertzsweep.core.lockin import demodulate
from hertzsweep.drivers.continuation import run_branch
from hertzsweep.drivers.oscillator import Oscillator, State
from hertzsweep.drivers.shooting import PeriodMap, shooting_dwell
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.errors import ConfigError
from hertzsweep.output.dataset import branch_dataset, open_dataset

from .conftest import CONFIGS, make_scene, run_cli

PAPER = CONFIGS / "paper" / "fig04_06.toml"
SIGMA = 0.2
W_PD = (2.006103, 1.993025)  # the two period doublings at SIGMA, to 1e-6
SPAN = {"sweep.start": 1.95, "sweep.stop": 2.1, "sweep.step": 0.01}
RECORD_COLUMNS = 4  # q, q', N/F_s, in contact (the single model's record)


def pd_scene(**changes):
    """The paper's scene at SIGMA over SPAN, following period doublings."""
    overrides = {"excitation.sigma": [SIGMA], **SPAN, "branch.follow_period_doubling": True}
    return load_scene(PAPER).with_overrides({**overrides, **changes})


@pytest.fixture(scope="module")
def followed():
    scene = pd_scene()
    result = run_branch(scene)
    return scene, result


def half_order(oscillator: Oscillator, state: State, w: float, periods: int) -> float:
    """The amplitude of order 1/2 of N/F_s over ``periods`` (even) periods of the orbit
    from ``state``: numpy demodulation of the recorded force against the reference w/2
    (harmonic 1 of a 'period' of two excitation periods)."""
    n = oscillator.steps_per_period
    record = np.empty((periods * n, RECORD_COLUMNS))
    oscillator.measure_block(state, w, periods, record=record, stride=1)
    _, amplitude, _ = demodulate(record[:, 2], [1], 2 * n)
    return float(amplitude[0])


def mismatch_after(oscillator: Oscillator, period: PeriodMap, state: State, w, periods) -> float:
    """``|x(periods T) - x(0)|_inf / Q``, integrating forward."""
    after = oscillator.advance(state, w, periods)
    return float(np.max(np.abs(period.vector(after) - period.vector(state)))) / period.scale


# --------------------------------------------------------------------------- config
@pytest.mark.parametrize("value", [0, 9, 1.5, True, "2"])
def test_a_bad_period_multiple_is_refused(value):
    with pytest.raises(ConfigError, match="sweep.period_multiple"):
        make_scene(sweep={"period_multiple": value})


def test_new_keys_stay_out_of_a_scene_that_does_not_use_them():
    plain = make_scene()
    assert "sweep_period_multiple" not in plain.attributes()
    assert "branch" not in plain.to_dict()
    used = make_scene(sweep={"period_multiple": 2}, branch={"follow_period_doubling": True})
    assert used.attributes()["sweep_period_multiple"] == 2
    assert used.to_dict()["branch"] == {"follow_period_doubling": True}


# --------------------------------------------------------------------------- the n-period map
TANGENT_CASES = {  # name -> (scene changes, sigma, w): a transient out of contact 26-31 %
    "central-difference": ({}, 0.05, 0.95),
    "rk4": ({"solver": {"method": "rk4"}}, 0.05, 0.95),
    "ball": ({"model": {"kind": "ball"}, "solver": {"steps_per_period": 512}}, 0.05, 0.95),
}
FD_TOLERANCE = 1e-6  # central differences of P^n, relative to the Jacobian's largest entry


@pytest.mark.parametrize("name", sorted(TANGENT_CASES))
@pytest.mark.parametrize("periods", [2, 3])
def test_n_period_tangent_matches_finite_differences(name, periods):
    """``dG/d(z, w)`` of ``G = (P^n(x) - x) / Q`` (the product of the one-period tangents)
    against central differences of P^n, for both methods and both models; and the
    n-period monodromy against the product of one-period ones along the trajectory."""
    changes, sigma, w = TANGENT_CASES[name]
    scene = make_scene(excitation={"sigma": sigma}, **changes)
    oscillator = Oscillator(scene, sigma)
    period = PeriodMap(oscillator, periods)
    state = oscillator.advance(oscillator.rest(w), w, 40)  # a transient: not an orbit
    z = period.coordinates(state)
    evaluation = period(z, w)
    assert evaluation.ok
    eps = 1e-6
    columns = []
    for j in range(z.size + 1):
        step = np.zeros(z.size + 1)
        step[j] = eps
        plus = period(z + step[:-1], w + step[-1]).residual
        minus = period(z - step[:-1], w - step[-1]).residual
        columns.append((plus - minus) / (2 * eps))
    difference = np.column_stack(columns)
    scale = np.max(np.abs(evaluation.jacobian))
    assert np.max(np.abs(difference - evaluation.jacobian)) <= FD_TOLERANCE * scale
    one = PeriodMap(oscillator, 1)
    product = np.eye(z.size)
    x = one.basis @ z
    for _ in range(periods):  # period by period along the trajectory
        step_eval = one(one.inverse @ x, w)
        product = step_eval.monodromy @ product
        x = x + step_eval.residual * one.scale
    np.testing.assert_allclose(evaluation.monodromy, product, rtol=1e-9, atol=1e-9)


# --------------------------------------------------------------------------- period doubling
MULTIPLIER = 1e-6  # |mu + 1| at a located period doubling; |mu_2 - mu_1^2| at a branch's start
REPEATS = 1e-10  # |x(2T) - x(0)| / Q of a period-2 orbit (the corrector's tolerance)
NOT_PERIODIC = 1e-4  # |x(T) - x(0)| / Q of a period-2 orbit away from the period doubling
SAME_ORBIT = 1e-6  # relative: two Newton solves (residual 1e-10 each) of an orbit whose
# multipliers lie near 1 (0.97: (M - I)^-1 magnifies the residual some 30 times)
SQRT_LAW = 0.02  # spread of H_1/2 / sqrt(|w - w_PD|) over the first points of a branch


def test_period_doublings_are_located_where_a_multiplier_is_minus_one(followed):
    _, result = followed
    primary = result.branches[0]
    doublings = [f for f in primary.bifurcations if f.kind == "period-doubling"]
    assert [round(f.frequency_ratio, 6) for f in doublings] == list(W_PD)
    for found in doublings:
        assert np.min(np.abs(found.multipliers + 1.0)) <= MULTIPLIER


def test_a_period_2_branch_starts_at_each_period_doubling(followed):
    _, result = followed
    family = result.family(0)
    assert [b.period_multiple for b in family] == [1, 2, 2]
    assert [(b.parent, b.parent_bifurcation) for b in family] == [(-1, -1), (0, 0), (0, 1)]
    primary = family[0]
    for child in family[1:]:
        found = primary.bifurcations[child.parent_bifurcation]
        assert child.frequency_ratio[0] == found.frequency_ratio
        assert child.end == "end" and child.frequency_ratio[-1] == SPAN["sweep.start"]
    # supercritical at the upper period doubling (stable), subcritical at the lower one
    assert family[1].stable[1:].all() and not family[2].stable.any()


def test_the_half_order_grows_from_zero_as_the_square_root(followed):
    """H_1/2 is 0 at the period doubling and grows as sqrt(|w - w_PD|) along the branch
    (a pitchfork of P^2): the ratio is constant to 2 % over the first four points."""
    scene, result = followed
    oscillator = Oscillator(scene, SIGMA)
    for child in result.family(0)[1:]:
        period = PeriodMap(oscillator, 2)
        w_pd = child.frequency_ratio[0]
        half = []
        for y in child.y[:5]:
            half.append(half_order(oscillator, period.state(y[:-1], y[-1]), y[-1], 2))
        half = np.array(half)
        assert half[0] <= 1e-8
        assert np.all(np.diff(half) > 0.0)
        ratio = half[1:] / np.sqrt(np.abs(child.frequency_ratio[1:5] - w_pd))
        assert np.ptp(ratio) <= SQRT_LAW * ratio.mean()


def test_the_branch_reads_the_half_order_its_orbits_hold():
    """With ``[lockin] harmonics = [0.5, 1]`` the followed branch's H_1/2 (the kernels'
    lock-in over the orbits' two periods) is the numpy demodulation of each orbit's
    record, to round-off (1e-12 relative), and 0 on the period-1 branch (below 1e-9)."""
    scene = pd_scene(**{"lockin.harmonics": [0.5, 1]})
    result = run_branch(scene)
    oscillator = Oscillator(scene, SIGMA)
    period = PeriodMap(oscillator, 2)
    primary, child = result.family(0)[0], result.family(0)[1]
    assert np.max(primary.amplitude[:, 0]) < 1e-9
    for i in (1, 5, 10):
        y = child.y[i]
        expected = half_order(oscillator, period.state(y[:-1], y[-1]), y[-1], 2)
        assert child.amplitude[i, 0] == pytest.approx(expected, rel=1e-12)


def test_period_2_orbits_repeat_after_two_periods_and_not_one(followed):
    scene, result = followed
    oscillator = Oscillator(scene, SIGMA)
    period = PeriodMap(oscillator, 2)
    for child in result.family(0)[1:]:
        assert child.size >= 10
        for y in child.y[1:]:  # the first point is the period doubling: a period-1 orbit
            w = float(y[-1])
            state = period.state(y[:-1], w)
            assert mismatch_after(oscillator, period, state, w, 2) <= REPEATS
            assert mismatch_after(oscillator, period, state, w, 1) >= NOT_PERIODIC


def test_multipliers_at_the_start_are_the_squares_of_the_parents(followed):
    _, result = followed
    primary = result.branches[0]
    for child in result.family(0)[1:]:
        parent = primary.bifurcations[child.parent_bifurcation].multipliers
        squares = parent**2
        squares = squares[np.lexsort((-squares.imag, -np.abs(squares)))]
        np.testing.assert_allclose(child.multipliers[0], squares, rtol=0, atol=MULTIPLIER)


def test_shooting_on_the_two_period_map_lands_on_the_branch(followed):
    """Between the period doublings the period-1 orbit is unstable; shooting with
    period_multiple = 2 from rest lands on the stable period-2 orbit of the branch (one of
    its two halves, a period apart), and a sweep reads it as settled, not periodic."""
    scene, result = followed
    stable_branch = result.family(0)[1]
    k = int(np.argmin(np.abs(stable_branch.frequency_ratio - 2.0)))
    y = stable_branch.y[k]
    w = float(y[-1])
    shooting = {"sweep.steady_state": "shooting", "sweep.period_multiple": 2}
    shot = scene.with_overrides({**shooting, "sweep.start": w, "sweep.stop": w})
    oscillator = Oscillator(shot, SIGMA)
    period = PeriodMap(oscillator, 2)
    state, reading, settled = shooting_dwell(oscillator, oscillator.rest(w), w)
    assert settled
    x = period.vector(state)
    on_branch = period.basis @ y[:-1]
    later = period.vector(oscillator.advance(period.state(y[:-1], w), w, 1))
    distance = min(np.max(np.abs(x - on_branch)), np.max(np.abs(x - later))) / period.scale
    assert distance <= SAME_ORBIT
    np.testing.assert_allclose(reading.amplitude, stable_branch.amplitude[k], rtol=SAME_ORBIT)
    sweep = run_sweep(shot)
    assert sweep.settled.all() and not sweep.periodic.any()
    np.testing.assert_allclose(
        sweep.amplitude[:, 0, 0], stable_branch.amplitude[[k, k]], rtol=SAME_ORBIT
    )


def test_a_period_1_shooting_sweep_is_unchanged_by_the_new_key():
    scene = make_scene(sweep={"steady_state": "shooting", "start": 0.95, "stop": 1.0})
    explicit = replace(scene, sweep=replace(scene.sweep, period_multiple=1))
    a, b = run_sweep(scene), run_sweep(explicit)
    np.testing.assert_array_equal(a.amplitude, b.amplitude)


# --------------------------------------------------------------------------- dataset, figure
def test_the_dataset_gains_a_branch_dimension(followed):
    scene, result = followed
    ds = branch_dataset(result, scene).to_xarray()
    assert ds.amplitude.dims == ("sigma", "branch", "point", "harmonic")
    assert ds.period_multiple.values.tolist() == [[1, 2, 2]]
    assert ds.parent.values.tolist() == [[-1, 0, 0]]
    assert ds.parent_bifurcation.values.tolist() == [[-1, 0, 1]]
    starts = [b.frequency_ratio[0] for b in result.family(0)[1:]]
    np.testing.assert_array_equal(ds.parent_frequency_ratio.values[0, 1:], starts)
    plain = run_branch(scene.with_overrides({"branch.follow_period_doubling": False}))
    assert "branch" not in branch_dataset(plain, scene).to_xarray().dims


def test_the_figure_draws_every_branch(followed):
    import matplotlib

    matplotlib.use("Agg")
    from hertzsweep.output.plot import branch_figure

    scene, result = followed
    ds = branch_dataset(result, scene).to_xarray()
    lines = {
        name: len(branch_figure(one).axes[0].get_lines())
        for name, one in (("all", ds), ("primary", ds.isel(branch=[0])))
    }
    assert lines["all"] > lines["primary"] + 2  # two period-2 branches, each a line or more


def test_branch_follow_pd_command_and_rerun(tmp_path, capsys):
    out, again = tmp_path / "pd.nc", tmp_path / "again.nc"
    sets = [f"--set={key}={value}" for key, value in SPAN.items()]
    argv = ["branch", PAPER, "-o", out, "-q", "--follow-pd", f"--set=excitation.sigma={SIGMA}"]
    code, stdout, stderr = run_cli([*argv, *sets], capsys)
    assert code == 0, stderr
    assert "branch 1: period 2 from w = 2.006103" in stdout
    assert run_cli(["rerun", out, "-o", again, "-q"], capsys)[0] == 0
    a, b = open_dataset(out), open_dataset(again)
    assert a.sizes["branch"] == 3 and a.attrs["branch_follow_period_doubling"] == 1
    np.testing.assert_array_equal(a.amplitude.values, b.amplitude.values)
    assert run_cli(["plot", out, "-o", tmp_path / "pd.png"], capsys)[0] == 0


def test_a_period_2_branch_that_returns_to_its_parent_ends_there():
    """Down to w = 0.5 the period-2 branch from w_PD = 2.006103 turns at a fold near
    w = 0.527 and comes back to the period-1 branch at the other period doubling, 1.993025:
    it ends there, on that very point, with no fold reported at that pitchfork, and no
    second branch is started from it."""
    scene = pd_scene(**{"sweep.start": 0.5})
    result = run_branch(scene)
    family = result.family(0)
    primary, child = family[0], family[1]
    assert len(family) == 2 and child.end == "reconnected"
    other = primary.bifurcations[1]
    assert round(other.frequency_ratio, 6) == W_PD[1]
    np.testing.assert_array_equal(child.y[-1], primary.y[other.point])
    # one fold, of an orbit in flight 89 % of the time: where grazing steps make the scheme's
    # branch zigzag, reported once at the extreme w of the cluster, 0.5268 or 0.5279 by path
    assert [f.kind for f in child.bifurcations] == ["fold"]
    assert 0.525 < child.bifurcations[0].frequency_ratio < 0.53
    assert child.stable.any() and not child.stable.all()  # stable until the fold


def test_hs_branch_takes_the_option():
    import hertzsweep as hs

    scene = pd_scene(**{"branch.follow_period_doubling": False})
    ds = hs.branch(scene, follow_period_doubling=True)
    assert ds.sizes["branch"] == 3 and "follow_period_doubling=True" in ds.attrs["history"]
    assert "branch" not in hs.branch(scene).dims
