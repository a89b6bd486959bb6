"""Periodic orbits of the two-degree-of-freedom model: Newton on its 4-dimensional
one-period map, shooting sweeps and branches with its four Floquet multipliers."""

import numpy as np
import pytest
import xarray as xr

from hertzsweep.core.config import load_scene
from hertzsweep.drivers.continuation import run_branch
from hertzsweep.drivers.oscillator import Oscillator
from hertzsweep.drivers.shooting import PeriodMap, newton
from hertzsweep.drivers.sweep import run_sweep

from .conftest import CONFIGS, run_cli
from .test_ballmodel import scene as ball_scene

NEWTON = 1e-10  # shooting.NEWTON_TOLERANCE: the residual of a converged orbit


def default(*overrides):
    """The default scene with the ball model (the paper's 70 g ball)."""
    return load_scene(CONFIGS / "default.toml", ["model.kind=ball", *overrides])


def test_newton_converges_quadratically_on_the_ball_orbit():
    """From the state a settled dwell ends at, Newton on the 4 x 4 system reaches the
    tolerance in a few iterations, each residual at most about the square of the one
    before (relative to the first): the Jacobian is exact."""
    scene = default("excitation.sigma=[0.01]")
    osc = Oscillator(scene, 0.01)
    w = 0.97
    state = osc.advance(osc.rest(w), w, 40)  # 40 periods: a transient still 1e-2 of Q
    orbit = newton(PeriodMap(osc), state, w)
    assert orbit.converged
    residuals = np.array(orbit.residuals)
    assert residuals[-1] <= NEWTON and len(residuals) <= 5
    first = residuals[0]
    for before, after in zip(residuals[:-2], residuals[1:-1], strict=True):
        # quadratic: r_{k+1} / r_0 <= C (r_k / r_0)^2 with a modest C (here below 10)
        assert after / first <= 10.0 * (before / first) ** 2
    assert orbit.multipliers.shape == (4,)
    assert orbit.stable


def test_ball_multipliers_in_the_massless_limit_are_the_single_models():
    """m_b = 1e-4 m (N = 2048, as the massless-limit sweep test): the two multipliers of
    the moving mass's mode are the single model's to 1e-3 (the same residual as H1 in
    that test); the ball's own mode, stiff and damped by the contacts' dashpots, leaves
    two multipliers far inside the unit circle."""
    tables = dict(
        excitation={"sigma": [0.01]},
        solver={"steps_per_period": 2048},
        sweep={"start": 0.9, "stop": 0.9},
    )
    mass = 1e-4 * 11.4
    w = 0.9
    found = {}
    for kind in ("ball", "single"):
        osc = Oscillator(ball_scene(kind, mass, **tables), 0.01)
        state = osc.advance(osc.rest(w), w, 300)
        orbit = newton(PeriodMap(osc), state, w)
        assert orbit.converged
        found[kind] = orbit.multipliers
    assert found["ball"].shape == (4,) and found["single"].shape == (2,)
    assert np.max(np.abs(found["ball"][:2] - found["single"])) < 1e-3
    assert np.max(np.abs(found["ball"][2:])) < 0.5 * np.min(np.abs(found["single"]))


def test_shooting_sweep_is_the_settled_sweep():
    """Up and down sweeps of the ball model by shooting against settling (1000 periods,
    whose transient has decayed to exp(-2 pi zeta w 1000) = 1e-12): the same jumps and H1
    within 1e-6 (the settled orbit differs from the periodic one by its round-off and what
    is left of the transient), every dwell settled."""
    common = ["excitation.sigma=[0.01]", "sweep.start=0.96", "sweep.stop=1.0"]
    settled = run_sweep(default(*common, "sweep.settle_periods=1000"))
    shot = run_sweep(default(*common, "sweep.steady_state=shooting"))
    assert np.array_equal(shot.jump_frequency_ratio, settled.jump_frequency_ratio)
    assert np.all(np.isfinite(shot.jump_frequency_ratio))  # both directions jump
    assert shot.settled.all()
    h1 = (slice(None),) * 3 + (0,)
    relative = np.abs(shot.amplitude[h1] / settled.amplitude[h1] - 1.0)
    assert np.max(relative) < 1e-6
    assert shot.steps < settled.steps / 10  # what shooting buys: >10x fewer periods


@pytest.fixture(scope="module")
def ball_branch():
    scene = default("excitation.sigma=[0.01]")
    return scene, run_branch(scene).branches[0]


def test_ball_branch_folds_are_the_ball_sweeps_jumps(ball_branch):
    """The ball model's branch at sigma = 1 % has two folds with an unstable segment
    between, and each fold lies within one sweep step beyond the ball sweep's jump (up:
    above the last dwell before it; down: below it), as the single model's do."""
    scene, branch = ball_branch
    assert branch.complete
    assert [b.kind for b in branch.bifurcations] == ["fold", "fold"]
    first, second = branch.folds
    assert not branch.stable[first.point + 1 : second.point].any()
    assert branch.stable[: first.point].all() and branch.stable[second.point + 1 :].all()
    assert branch.multipliers.shape == (branch.size, 4)
    for fold in branch.folds:
        assert abs(fold.multipliers[0] - 1.0) < 1e-9  # a real multiplier at +1
    narrow = default("excitation.sigma=[0.01]", "sweep.start=0.96", "sweep.stop=1.0")
    up, down = run_sweep(narrow).jump_frequency_ratio[:, 0]
    w_left, w_right = sorted(fold.frequency_ratio for fold in branch.folds)
    step = narrow.sweep.step
    assert up < w_right < up + step
    assert down - step < w_left < down


def test_ball_branch_stable_points_are_the_orbits_runs_reach(ball_branch):
    """Outside the folds the orbit is unique: there a branch point is the orbit a run
    from rest reaches (settled, then Newton), H1 to 1e-8 relative (both converged to a
    residual of 1e-10 of Q, with the corrector's tolerance between them)."""
    scene, branch = ball_branch
    w_left, w_right = sorted(fold.frequency_ratio for fold in branch.folds)
    w = branch.frequency_ratio
    outside = np.flatnonzero(branch.stable & ((w < w_left - 0.005) | (w > w_right + 0.005)))
    picked = outside[:: max(1, outside.size // 8)]
    assert picked.size >= 6
    for i in picked:
        osc = Oscillator(scene, 0.01)
        state = osc.advance(osc.rest(w[i]), w[i], 300)
        orbit = newton(PeriodMap(osc), state, w[i])
        assert orbit.converged and orbit.stable
        _, reading = osc.measure(orbit.state, w[i], 1)
        assert reading.amplitude[0] == pytest.approx(branch.amplitude[i, 0], rel=1e-8)


def test_branch_command_writes_four_multipliers_for_the_ball(tmp_path, capsys):
    out = tmp_path / "ball-branch.nc"
    argv = ["branch", CONFIGS / "default.toml", "--set", "model.kind=ball"]
    argv += ["--set", "excitation.sigma=[0.01]", "-o", out]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    with xr.open_dataset(out) as ds:
        assert ds.sizes["multiplier"] == 4
        assert ds.attrs["model_kind"] == "ball"
        modulus = np.hypot(ds.multiplier_real, ds.multiplier_imag)
        stable = ds.stable.values == 1
        assert np.all(modulus.values[stable].max(axis=-1) < 1.0)
