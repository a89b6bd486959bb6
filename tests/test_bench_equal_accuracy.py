"""The machinery of ``bench``'s comparison at equal accuracy (not its timings): the
reference is converged, and the settings chosen on the ladders are the loosest meeting
each target."""

from __future__ import annotations

import math

import pytest

from hertzsweep.cli.bench import equal_accuracy_lines
from hertzsweep.drivers import bench

DWELL = bench.DWELLS[0]  # sigma = 1 %, w = 0.975, viscous: 300 + 20 periods from rest
RICHARDSON_TOLERANCE = 1e-8  # reference against central difference N = 4096 + 8192
DENSE_TOLERANCE = 1e-9  # quadrature states against the DFT of the dense output


@pytest.fixture(scope="module")
def ref():
    return bench.reference(DWELL)


def test_reference_agrees_with_the_richardson_limit_of_central_difference(ref):
    """Two independent routes to H1 (DOP853 at rtol 1e-13 with quadrature states; the
    kernels' lock-in at N = 4096 and 8192, extrapolated) agree far below 1e-6."""
    assert ref["h1"] == pytest.approx(0.2054, abs=1e-4)  # the lower branch at w = 0.975
    assert abs(ref["richardson_difference"]) <= RICHARDSON_TOLERANCE
    # the H1 extraction: quadrature states against the rectangle rule on dense output
    assert abs(ref["dense_difference"]) <= DENSE_TOLERANCE


@pytest.mark.parametrize(
    ("h1", "ladder"),
    [(bench.rk4_h1, bench.RK4_LADDER), (bench.cd_h1, bench.CD_LADDER)],
    ids=["rk4", "central-difference"],
)
def test_chosen_setting_is_the_loosest_meeting_each_target(ref, h1, ladder):
    """The walk stops at a setting within the target whose next looser setting is not;
    both errors recomputed here from fresh dwells."""
    run = lambda setting: h1(DWELL, setting)  # noqa: E731
    errors, _ = bench._walk(run, ladder, ref["h1"], min(bench.TARGETS))
    for target in bench.TARGETS:
        i = bench._loosest(errors, target, len(errors) == len(ladder))
        assert i is not None and i > 0, (target, errors)
        chosen = abs(run(ladder[i]) - ref["h1"])
        looser = abs(run(ladder[i - 1]) - ref["h1"])
        assert chosen <= target < looser, (target, ladder[i], chosen, looser)
        assert chosen == errors[i]  # the same dwell gives the same bits


def test_errors_fall_at_each_scheme_s_order(ref):
    """Against the reference, RK4 converges at order 4 and central difference at order 2:
    a reference off by more than the errors measured would break both ratios."""
    rk4 = [abs(bench.rk4_h1(DWELL, m) - ref["h1"]) for m in (64, 128)]
    cd = [abs(bench.cd_h1(DWELL, n) - ref["h1"]) for n in (1024, 2048)]
    assert math.log2(rk4[0] / rk4[1]) == pytest.approx(4.0, abs=0.3)
    assert math.log2(cd[0] / cd[1]) == pytest.approx(2.0, abs=0.05)
    assert cd[1] < 1e-5 and rk4[1] < 1e-6  # well above the reference's 1e-8


def test_loosest_skips_a_setting_that_meets_the_target_alone():
    errors = [2e-4, 5e-5, 3e-4, 8e-5, 2e-5]  # the second crosses zero by luck
    assert bench._loosest(errors, 1e-4, walked_all=False) == 3
    assert bench._loosest(errors[:4], 1e-4, walked_all=False) is None
    assert bench._loosest(errors[:4], 1e-4, walked_all=True) == 3  # the ladder's last rung
    assert bench._loosest([math.inf, 1e-7, 1e-8], 1e-6, walked_all=False) == 1


def test_numbalsoda_missing_is_said(monkeypatch):
    monkeypatch.setattr(bench, "_numbalsoda", lambda: None)
    (soda,) = [c for c in bench.competitors() if c.name == "numbalsoda DOP853"]
    assert soda.h1 is None
    row = bench._row(DWELL, 1e-4, soda)
    assert row["setting"] == "not installed" and row["ms_per_dwell"] is None
    lines = equal_accuracy_lines([], [row])
    assert lines[-1] == (
        "| sigma 1 %, w 0.975 | 1e-04 | numbalsoda DOP853 | not installed | - | - | - | - |"
    )


def test_table_prints_setting_error_time_and_ratio():
    row = {
        "scene": "s",
        "target": 1e-6,
        "method": "RK4, fixed step (numba)",
        "setting": "128 steps/period",
        "error": 4.17e-7,
        "looser": "96 steps/period",
        "looser_error": 1.31e-6,
        "ms_per_dwell": 1.605,
        "ratio_to_central_difference": 0.155,
    }
    ref = {
        "scene": "s",
        "h1": 0.2054032785286284,
        "seconds": 2.5,
        "dense_difference": 8.6e-11,
        "richardson_difference": 5.6e-11,
        "richardson_steps": 4096,
    }
    lines = equal_accuracy_lines([ref], [row])
    assert "| s | 0.205403278529 | 2.5 | 8.6e-11 | 5.6e-11 (N 4096 + 8192) |" in lines
    assert lines[-1] == (
        "| s | 1e-06 | RK4, fixed step (numba) | 128 steps/period | 4.2e-07 "
        "| 96 steps/period: 1.3e-06 | 1.60 | 0.155 |"
    )
