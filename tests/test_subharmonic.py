"""The order-2 subharmonic (w ~ 2): the sweep's jumps against the branch's bifurcations.

``configs/paper/subharmonic.toml``: the paper's rig, viscous zeta = 0.45 %, sigma = 20, 25
and 30 %, w from 0.34 to 2.03 in steps of 0.0025. ``hertzsweep branch --follow-pd`` finds
the two period doublings of each level and the period-2 branch born at the upper one,
which leans to low w, folds there and comes back to the lower one. The stepped sine:

- up: leaves the period-1 orbit at the lower period doubling (``subharmonic_onset``) and
  rides the period-2 response up to the upper one, where it merges back (``end``);
- down: leaves at the upper period doubling and stays on the period-2 response down to
  its fold (``end``): within one step of it at 25 and 30 %; at 20 %, where grazing makes
  the branch zigzag through a cluster of folds 2e-3 wide, inside that cluster.

By the jump convention (the last frequency before the jump, in sweep order) each
reported frequency lies within one step (0.0025) of its bifurcation (but one, above).
That takes dwells long enough for the period-1 orbit to leave: one step past a period doubling its
multiplier is -1.0021, -1.0036 and -1.0048 at sigma = 20, 25 and 30 % (Newton's orbit),
growing a perturbation e^7-fold in 3300, 1900 and 1500 periods; the scene settles 3000
periods, and the dwells one and two steps past add up. At the default 300, the onsets
come 1.5 to 4 steps late (checked below; 2 to 3.5 measured).
"""

from __future__ import annotations

import numpy as np
import pytest

import hertzsweep.api as hs
from hertzsweep.drivers.continuation import ContinuationParameters, run_branch

from .conftest import CONFIGS

SCENE = CONFIGS / "paper" / "subharmonic.toml"
STEP = 0.0025  # the scene's sweep step


@pytest.fixture(scope="module")
def branch():
    return hs.branch(hs.load_scene(SCENE), follow_period_doubling=True)


@pytest.fixture(scope="module")
def sweep():
    return hs.sweep(hs.load_scene(SCENE))


def landmarks(branch, sigma):
    """``(w_low, w_high, w_fold, w_stable_end)``: the period-1 branch's two period
    doublings; the fold of the period-2 branch born at the upper one (its lowest-w fold);
    and where that branch, followed from its start, first stops being stable (the middle
    of its first unstable point and the one before). In the heavy loss of contact near
    the fold grazing makes the branch zigzag through a cluster of folds; the
    continuation reports where the cluster turns back."""
    one = branch.sel(sigma=sigma)

    def bifurcations(b, kind):
        part = one.isel(branch=b)
        w = part.bifurcation_frequency_ratio.values
        return np.sort(w[part.bifurcation_kind.values == kind])

    doublings = bifurcations(0, "period-doubling")
    assert doublings.size == 2, (sigma, doublings)
    child = one.isel(branch=1)
    assert int(child.period_multiple) == 2
    assert float(child.parent_frequency_ratio) == pytest.approx(doublings[1], abs=1e-9)
    folds = bifurcations(1, "fold")
    assert folds.size >= 1, sigma
    stable, w = child.stable.values, child.frequency_ratio.values
    first_unstable = 1 + int(np.argmax(stable[1:] == 0))  # point 0 is the doubling itself
    return doublings[0], doublings[1], folds[0], 0.5 * (w[first_unstable - 1] + w[first_unstable])


@pytest.mark.slow
@pytest.mark.parametrize("sigma", [0.2, 0.25, 0.3])
def test_the_sweeps_subharmonic_jumps_are_the_branchs_bifurcations(sweep, branch, sigma):
    w_low, w_high, w_fold, w_stable_end = landmarks(branch, sigma)
    onset = sweep.subharmonic_onset_frequency_ratio.sel(sigma=sigma)
    end = sweep.subharmonic_end_frequency_ratio.sel(sigma=sigma)
    assert abs(float(onset.sel(direction="up")) - w_low) <= STEP
    assert abs(float(end.sel(direction="up")) - w_high) <= STEP
    assert abs(float(onset.sel(direction="down")) - w_high) <= STEP
    down_end = float(end.sel(direction="down"))
    if sigma > 0.2:
        assert abs(down_end - w_fold) <= STEP  # 0.0018 and 0.0015 measured
    else:
        # At 20 % the branch's stable part ends at 0.5289 and the grazing cluster of folds
        # reaches down to 0.5268 (or 0.5279, by the continuation's path): the sweep's last
        # period-2 dwell is 0.53, 1.3 steps from the cluster's end, and its first dwell off
        # it (0.5275) lies inside the cluster.
        assert w_fold <= down_end - STEP <= w_stable_end


@pytest.mark.slow
def test_at_the_default_300_periods_the_onsets_come_late(branch):
    """The sweep leaves the period-1 orbit 2 to 3.5 steps past its period doubling."""
    scene = hs.load_scene(SCENE, overrides={"sweep.settle_periods": 300, "sweep.start": 1.9})
    short = hs.sweep(scene)
    for sigma in (0.2, 0.25, 0.3):
        w_low, w_high, _, _ = landmarks(branch, sigma)
        onset = short.subharmonic_onset_frequency_ratio.sel(sigma=sigma)
        late_up = (float(onset.sel(direction="up")) - w_low) / STEP
        late_down = (w_high - float(onset.sel(direction="down"))) / STEP
        assert 1.5 < late_up < 4.0, (sigma, late_up)
        assert 1.5 < late_down < 4.0, (sigma, late_down)


def test_a_narrow_period_doubling_bubble_is_not_stepped_over(branch):
    """At sigma = 20 % the period-1 orbit is unstable over 0.013 in w only, less than the
    continuation's largest step (0.02): the steps shrink as a multiplier nears -1
    (:attr:`ContinuationParameters.doubling_proximity`), so both doublings are found
    across the whole span; without that, neither is."""
    assert len(landmarks(branch, 0.2)) == 4
    scene = hs.load_scene(SCENE, overrides={"excitation.sigma": [0.2]})
    result = run_branch(scene, parameters=ContinuationParameters(doubling_proximity=0.0))
    kinds = [b.kind for b in result.branches[0].bifurcations]
    assert "period-doubling" not in kinds


def test_the_onset_study_figure_draws_the_estimate_beside_the_sweeps(tmp_path):
    """``plot --view subharmonic`` of a study: one curve of onsets per damping law and the
    small-amplitude estimate's lower band edge at the study's zeta."""
    from hertzsweep.core.subharmonic import mathieu_tongue

    study = tmp_path / "onset.toml"
    scene = (CONFIGS / "studies" / "subharmonic-onset-scene.toml").as_posix()
    study.write_text(
        f'kind = "sweep"\nscene = "{scene}"\n[grid]\n'
        '"damping.exponent" = [0, 1.5]\n"excitation.sigma" = [0.3, 0.5]\n'
    )
    ds = hs.study(study, workers=1)
    onset = ds.subharmonic_onset_frequency_ratio.sel(direction="up")
    assert np.isnan(onset.sel(sigma=0.3)).all()  # below 36 %: no period doubling
    low, _ = mathieu_tongue(0.5, 0.01)
    assert np.all(np.abs(onset.sel(sigma=0.5).values - low) <= STEP)  # 1.9775 and 1.9793
    ax = hs.plot(ds, view="subharmonic").axes[0]
    estimate = next(line for line in ax.lines if "estimate" in line.get_label())
    sigma, edge = estimate.get_data()
    assert edge[-1] == pytest.approx(low, abs=1e-9) and sigma[-1] == pytest.approx(50.0)
    assert len([line for line in ax.lines if line.get_label().startswith("n = ")]) == 2


def test_a_phase_without_amplitude_is_not_drawn():
    """A half order read on a period-1 response is round-off, and so is its phase."""
    import xarray as xr

    from hertzsweep.output.plot import defined_phase

    amplitude = xr.DataArray([1e-12, 0.4, 0.0, np.nan])
    phase = xr.DataArray([10.0, 20.0, 30.0, 40.0])
    np.testing.assert_array_equal(
        defined_phase(phase, amplitude).values, [np.nan, 20, np.nan, np.nan]
    )
