"""Pseudo-arclength continuation: the linear limit, folds against sweeps' jumps, loss of
contact, period doubling, and the branch command end to end."""

from __future__ import annotations

import numpy as np
import pytest

from hertzsweep.core.config import load_scene
from hertzsweep.core.lockin import complex_amplitude
from hertzsweep.drivers.continuation import (
    ContinuationParameters,
    continue_branch,
    run_branch,
    start_end,
)
from hertzsweep.drivers.oscillator import Oscillator, State
from hertzsweep.drivers.shooting import PeriodMap, newton
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.output.dataset import branch_dataset, open_dataset

from .analytic import linear_response
from .conftest import CONFIGS, make_scene, run_cli

LOCATED = 1e-6  # required accuracy in w of a located bifurcation
MAX_STEP = ContinuationParameters().max_step  # the default cap on an arclength step


def _segments(stable: np.ndarray) -> list[tuple[int, int, bool]]:
    """Runs of equal stability: (first index, last index, stable)."""
    edges = np.flatnonzero(np.diff(stable.astype(int))) + 1
    starts = np.concatenate(([0], edges))
    ends = np.concatenate((edges - 1, [stable.size - 1]))
    return [(int(a), int(b), bool(stable[a])) for a, b in zip(starts, ends, strict=True)]


# --------------------------------------------------------------------------- linear limit
@pytest.fixture(scope="module")
def linear():
    def branch(steps_per_period):
        scene = make_scene(
            excitation={"sigma": 1e-4}, solver={"steps_per_period": steps_per_period}
        )
        return scene, run_branch(scene).branches[0]

    return {n: branch(n) for n in (256, 512)}


def test_linear_branch_is_one_stable_curve(linear):
    scene, branch = linear[256]
    assert branch.complete and not branch.bifurcations
    assert branch.stable.all()
    assert (branch.frequency_ratio[0], branch.frequency_ratio[-1]) == start_end(scene)
    assert np.all(np.diff(branch.frequency_ratio) > 0)  # no fold: w increases throughout


def test_linear_branch_matches_the_analytic_response(linear):
    """sigma = 1e-4: H1 (complex: amplitude and phase) against the linear oscillator
    (:func:`tests.analytic.linear_response`, continuous and of the scheme).

    Against the continuous response the error is the scheme's: its natural frequency is
    1 + h^2/24 + O(h^4) (2.5e-5 at N = 256), which moves the response by about
    (h^2/24) / zeta = 0.6 % on the flanks of the resonance; tolerance 1 % at N = 256, and
    the error must shrink at N = 512 (by 4 at a given w; the points differ, and the
    nonlinear part below does not shrink, so only "at least 2x" is asserted). Against the
    exact steady state of the linear scheme only the Hertz nonlinearity remains: relative
    O(a^2) with a = sigma / (2 zeta) = 0.011 at the peak (5e-4 measured; 5e-6 at
    sigma = 1e-5); tolerance 2e-3."""
    errors = {}
    for n, (scene, branch) in linear.items():
        w = branch.frequency_ratio
        h1 = complex_amplitude(branch.amplitude[:, 0], branch.phase[:, 0])
        zeta = scene.damping.ratio
        exact = 1e-4 * linear_response(w, zeta)
        errors[n] = np.max(np.abs(h1 - exact) / np.abs(exact))
        discrete = 1e-4 * linear_response(w, zeta, n)
        assert np.max(np.abs(h1 - discrete) / np.abs(discrete)) < 2e-3
    assert errors[256] < 1e-2
    assert errors[256] / errors[512] > 2.0


def test_linear_multipliers_have_modulus_exp_minus_2_pi_zeta_over_w(linear):
    """|mu| = exp(-2 pi zeta / w) for the continuous oscillator. The scheme's multipliers
    differ from the continuous ones by O(h^2) in argument (measured 2e-4 rad), but their
    modulus is sqrt(det M) = ((1 - zeta h)/(1 + zeta h))^(N/2) exactly (viscous damping),
    which is exp(-2 pi zeta / w) (1 - (2 pi / w) zeta^3 h^2 / 3 + ...): a relative
    difference of 2e-10 at zeta = 0.45 %; tolerance 1e-8."""
    scene, branch = linear[256]
    w = branch.frequency_ratio
    zeta = scene.damping.ratio
    assert np.all(branch.multipliers[:, 0].imag > 0)  # a complex pair everywhere
    modulus = np.abs(branch.multipliers)
    expected = np.exp(-2 * np.pi * zeta / w)
    np.testing.assert_allclose(modulus, np.stack([expected, expected], axis=1), rtol=1e-8)


# --------------------------------------------------------------------------- sigma = 1 %
@pytest.fixture(scope="module")
def one_percent():
    scene = load_scene(CONFIGS / "default.toml", ["excitation.sigma=[0.01]"])
    return scene, run_branch(scene).branches[0]


def test_one_percent_has_two_folds_and_an_unstable_segment_between(one_percent):
    _, branch = one_percent
    assert branch.complete
    assert [b.kind for b in branch.bifurcations] == ["fold", "fold"]
    first, second = branch.folds
    # stable, unstable between the two fold points, stable again (the fold points
    # themselves have a multiplier of 1 to round-off and may fall on either side)
    inner = slice(first.point + 1, second.point)
    assert not branch.stable[inner].any()
    assert branch.stable[: first.point].all() and branch.stable[second.point + 1 :].all()
    assert len(_segments(branch.stable[first.point + 1 : second.point])) == 1
    # the unstable branch lies between the two folds in w
    w_low, w_high = sorted((first.frequency_ratio, second.frequency_ratio))
    assert np.all(
        (branch.frequency_ratio[inner] > w_low) & (branch.frequency_ratio[inner] < w_high)
    )
    for fold in branch.folds:
        # a real multiplier at +1 (round-off of M: 1e-12)
        assert abs(fold.multipliers[0] - 1.0) < 1e-9


def test_one_percent_folds_are_the_sweeps_jumps(one_percent):
    """Up sweep: the lower branch ends at the larger fold w_R and the response jumps up
    after the last dwell below it; down sweep: the upper branch ends at w_L. A narrow grid
    around the jumps (0.96 .. 1.0) has one orbit at each end, so it starts from rest as
    the full grid does; the jumps are at 0.985 and 0.9725 as on the default grid."""
    scene, branch = one_percent
    narrow = make_scene(excitation={"sigma": 0.01}, sweep={"start": 0.96, "stop": 1.0})
    sweep = run_sweep(narrow)
    up, down = sweep.jump_frequency_ratio[:, 0]
    assert (up, down) == (0.985, 0.9725)
    w_left, w_right = sorted(fold.frequency_ratio for fold in branch.folds)
    step = narrow.sweep.step
    assert abs(w_right - up) < step and up < w_right < up + step
    assert abs(w_left - down) < step and down - step < w_left < down


def test_folds_are_located_to_1e_6(one_percent):
    """A different step-size cap puts the points elsewhere; the folds stay put."""
    scene, branch = one_percent
    shorter = ContinuationParameters(max_step=0.0037)
    other = continue_branch(Oscillator(scene, 0.01), *start_end(scene), parameters=shorter)
    assert other.size > 3 * branch.size
    steps = np.diff(other.arclength)[1:]  # after the first step, first_step = 0.005
    assert np.max(steps) <= 0.0037 * (1 + 1e-9) and np.median(steps) == pytest.approx(0.0037)
    for a, b in zip(branch.folds, other.folds, strict=True):
        assert abs(a.frequency_ratio - b.frequency_ratio) < LOCATED


def test_max_points_cuts_the_same_branch_short(one_percent):
    """A knob of ContinuationParameters takes effect and changes nothing else: with
    ``max_points = 20`` the branch ends there ("max-points"), before the first fold, on
    the very points of the default run, bit for bit."""
    scene, branch = one_percent
    cut = continue_branch(
        Oscillator(scene, 0.01), *start_end(scene), parameters=ContinuationParameters(max_points=20)
    )
    assert cut.size == 20 and cut.end == "max-points" and not cut.complete
    assert not cut.bifurcations and branch.folds[0].point > 20
    np.testing.assert_array_equal(cut.frequency_ratio, branch.frequency_ratio[:20])
    np.testing.assert_array_equal(cut.arclength, branch.arclength[:20])
    np.testing.assert_array_equal(cut.amplitude, branch.amplitude[:20])


# --------------------------------------------------------------------------- loss of contact
def test_loss_of_contact_branch_and_its_folds_against_the_sweep():
    """sigma = 7.8 %, zeta = 1 %, contact damping n = 3/2, span 0.5 .. 1.0: the branch
    runs through loss of contact without breaking (one curve, no gap), and its folds are
    the sweep's jumps within one step."""
    tables = {
        "damping": {"ratio": 0.01, "law": "contact", "exponent": 1.5},
        "excitation": {"sigma": 0.078},
        "sweep": {"start": 0.5, "stop": 1.0, "settle_periods": 150},
    }
    scene = make_scene(**tables)
    branch = run_branch(scene).branches[0]
    assert branch.complete
    assert [b.kind for b in branch.bifurcations] == ["fold", "fold"]
    loss = branch.contact_loss_fraction
    assert loss.max() > 0.5 and (loss == 0).sum() > 10  # in and out of loss of contact
    # unbroken: every step of the continuation is at most MAX_STEP of arclength in the
    # scaled coordinates, so consecutive points are close (H1 moves by < 0.1 per step,
    # against the jumps' 0.7 and 1.3)
    assert np.max(np.diff(branch.arclength)) <= MAX_STEP * (1 + 1e-9)
    assert np.max(np.abs(np.diff(branch.amplitude[:, 0]))) < 0.1
    inner = slice(branch.folds[0].point + 1, branch.folds[1].point)
    assert not branch.stable[inner].any() and loss[inner].max() > 0.4  # unstable, impacting
    sweep = run_sweep(scene)
    up, down = sweep.jump_frequency_ratio[:, 0]
    w_left, w_right = sorted(fold.frequency_ratio for fold in branch.folds)
    step = scene.sweep.step
    assert up < w_right < up + step
    assert down - step < w_left < down


def test_grazing_zigzag_is_reported_as_one_fold():
    """sigma = 7 %, n = 3/2: near the lower fold the orbit loses contact over 65 % of the
    period and the scheme's branch (N = 256) zigzags where time steps graze d = 0: w has
    more than two turning points along the branch, within 1e-3 of each other near 0.614,
    but the oscillator has one fold there, reported at the zigzag's lowest w."""
    scene = make_scene(
        damping={"ratio": 0.01, "law": "contact", "exponent": 1.5},
        excitation={"sigma": 0.07},
        sweep={"start": 0.5, "stop": 1.05},
    )
    branch = run_branch(scene).branches[0]
    assert branch.complete and [b.kind for b in branch.bifurcations] == ["fold", "fold"]
    w = branch.frequency_ratio
    turns = np.flatnonzero(np.diff(np.sign(np.diff(w))) != 0) + 1  # local extrema of w
    lower = branch.folds[1]
    near = turns[np.abs(w[turns] - lower.frequency_ratio) < 1e-3]
    assert near.size >= 3 and near.size % 2 == 1
    assert lower.frequency_ratio == pytest.approx(w[near].min(), abs=1e-9)
    assert branch.contact_loss_fraction[lower.point] > 0.6


def test_branch_leaving_the_span_where_it_began_is_kept_and_flagged():
    """n = 1, sigma = 7 %: the unstable branch from the upper fold reaches w = 0.5 before
    its lower fold (at 0.461, from a span starting at 0.3): the branch ends there,
    incomplete, and says so."""
    scene = make_scene(
        damping={"ratio": 0.01, "law": "contact", "exponent": 1.0},
        excitation={"sigma": 0.07},
        sweep={"start": 0.5, "stop": 1.05},
    )
    result = run_branch(scene)
    branch = result.branches[0]
    assert not branch.complete and branch.end == "start"
    assert branch.frequency_ratio[-1] == 0.5 and not branch.stable[-1]
    assert [b.kind for b in branch.bifurcations] == ["fold"]
    ds = branch_dataset(result, scene).to_xarray()
    assert ds.branch_complete.values.tolist() == [0]
    assert ds.branch_end.values.tolist() == ["start"]


# --------------------------------------------------------------------------- period doubling
def test_period_doubling_of_the_half_subharmonic_resonance():
    """sigma = 0.3, w near 2: the stiffness, modulated at w, pumps the contact's own mode
    at w / 2 (the 2-subharmonic resonance): the T-periodic orbit loses stability through
    two period doublings. Checked by direct simulation: a 1e-6 perturbation of the orbit
    decays over 2000 periods outside them (|mu| <= 0.986: to 1e-18; what is left, below
    1e-9, is the distance from Newton's fixed point to the scheme's attractor, measured
    1.5e-12) and grows inside
    (|mu| >= 1.005: above 1e-3, to the period-2 attractor); and a sweep dwell between them
    does not repeat every period."""
    scene = make_scene(
        excitation={"sigma": 0.3},
        sweep={"start": 1.95, "stop": 2.05, "step": 0.01, "settle_periods": 1000},
    )
    branch = run_branch(scene).branches[0]
    assert [b.kind for b in branch.bifurcations] == ["period-doubling"] * 2
    for found in branch.bifurcations:
        assert abs(found.multipliers[0] + 1.0) < 1e-9
    low, high = sorted(b.frequency_ratio for b in branch.bifurcations)
    between = (branch.frequency_ratio > low) & (branch.frequency_ratio < high)
    assert not branch.stable[between].any() and branch.stable[~between].sum() >= 2
    assert np.all(branch.multipliers[between, 0].real < -1.0)
    oscillator = Oscillator(scene, 0.3)
    for w in (1.98, 1.99, 2.0, 2.01, 2.02):
        orbit = newton(PeriodMap(oscillator), oscillator.rest(w), w).state
        perturbed = State(orbit.q_prev + 1e-6, orbit.q + 1e-6, orbit.h)
        later = oscillator.advance(perturbed, w, 2000)
        growth = abs(later.q - orbit.q)
        assert (growth > 1e-3) if low < w < high else (growth < 1e-9)
    sweep = run_sweep(scene)
    middle = int(np.argmin(np.abs(scene.sweep.frequency_ratios - 2.0)))
    assert not sweep.periodic[:, 0, middle].any()


# --------------------------------------------------------------------------- command and dataset
def test_branch_command_writes_the_agreed_layout(tmp_path, capsys):
    out = tmp_path / "branch.nc"
    code, stdout, stderr = run_cli(
        ["branch", CONFIGS / "default.toml", "-o", out, "--quiet",
         "--set", "sweep.start=0.95", "--set", "sweep.stop=1.0"],
        capsys,
    )  # fmt: skip
    assert code == 0, stderr
    assert "fold" in stdout and "wrote" in stdout
    ds = open_dataset(out)
    assert ds.attrs["hertzsweep_kind"] == "branch"
    assert ds.attrs["branch_start_frequency_ratio"] == 0.95
    assert dict(ds.sizes)["multiplier"] == 2 and list(ds.sigma.values) == [0.006, 0.01]
    for name in ("frequency_ratio", "frequency", "amplitude", "phase", "force_max", "force_min",
                 "contact_loss_fraction", "multiplier_real", "multiplier_imag", "stable",
                 "arclength", "bifurcation_frequency_ratio", "bifurcation_kind",
                 "bifurcation_amplitude"):  # fmt: skip
        label = ds[name].dtype.kind in "OUS"  # CF labels carry no units
        assert ds[name].attrs["long_name"] and ("units" in ds[name].attrs) != label
    assert ds.frequency.attrs["units"] == "Hz" and ds.phase.attrs["units"] == "degree"
    scene = load_scene(CONFIGS / "default.toml", ["sweep.start=0.95", "sweep.stop=1.0"])
    result = run_branch(scene)
    for s, branch in enumerate(result.branches):
        sel = ds.isel(sigma=s)
        size = branch.size
        np.testing.assert_array_equal(sel.frequency_ratio.values[:size], branch.frequency_ratio)
        assert np.all(np.isnan(sel.frequency_ratio.values[size:]))
        assert np.all(sel.stable.values[size:] == -1)
        assert list(sel.bifurcation_kind.values) == ["fold", "fold"]
        np.testing.assert_array_equal(
            sel.bifurcation_frequency_ratio.values, [b.frequency_ratio for b in branch.folds]
        )
        fold = branch.folds[0]
        np.testing.assert_allclose(sel.multiplier_real.values[fold.point, 0], 1.0, atol=1e-9)
        assert sel.bifurcation_amplitude.values[0] == sel.amplitude.values[fold.point, 0]


def test_branch_command_rejects_bad_input(tmp_path, capsys):
    out = tmp_path / "bad.nc"
    for override, key in [("sweep.bogus=1", "sweep.bogus"),
                          ("solver.steps_per_period=3", "solver.steps_per_period")]:  # fmt: skip
        code, stdout, stderr = run_cli(
            ["branch", CONFIGS / "default.toml", "-o", out, "--set", override], capsys
        )
        assert code == 2
        assert len(stderr.strip().splitlines()) == 1 and key in stderr
        assert not out.exists()


def test_single_frequency_span_gives_one_point():
    scene = make_scene(excitation={"sigma": [0.01, 0.02]}, sweep={"start": 0.9, "stop": 0.9})
    result = run_branch(scene)
    ds = branch_dataset(result, scene).to_xarray()
    assert dict(ds.sizes)["point"] == 1 and dict(ds.sizes)["bifurcation"] == 1
    assert ds.branch_complete.values.tolist() == [1, 1]
    assert list(ds.bifurcation_kind.values[:, 0]) == ["", ""]
    np.testing.assert_array_equal(ds.frequency_ratio.values[:, 0], [0.9, 0.9])
