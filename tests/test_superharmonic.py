"""The order-2 superharmonic resonance (w ~ 1/2): the sweep's H2 peak against the branch's.

``configs/paper/superharmonic.toml`` at the levels without a fold (5 % and 10 %). The
branch's H2 maximum is the vertex of the parabola through the continued orbits' largest
point and its neighbours (about 5e-5 apart there). The sweep's peak dwell lies within
one step of it, and its H2 within 1e-3 of the maximum. The tolerance: the dwell reads the
orbit at a grid point at most half a step (7.5e-5) from the top of a peak whose
half-power half-width is zeta / 2 = 2.25e-3 in w, where a resonance is lower by at most
(7.5e-5 / 2.25e-3)^2 / 2 = 6e-4; a settled dwell (300 periods, 17 decay times at w = 1/2) reads
the orbit itself to better than 1e-7. Both directions read the same peak.
"""

from __future__ import annotations

import numpy as np
import pytest

import hertzsweep.api as hs

from .conftest import CONFIGS

SCENE = CONFIGS / "paper" / "superharmonic.toml"
LEVELS = [0.05, 0.1]  # single-valued peaks (20 % folds: a jump, not a peak)


@pytest.fixture(scope="module")
def runs():
    scene = hs.load_scene(SCENE, overrides={"excitation.sigma": LEVELS})
    return hs.sweep(scene), hs.branch(scene)


def _branch_maximum(branch, sigma):
    """(w, H2) of the branch's H2 maximum: the vertex of the parabola through the largest
    point and its two neighbours (the points are close to the peak's top)."""
    one = branch.sel(sigma=sigma)
    w = one.frequency_ratio.values
    h2 = one.amplitude.sel(harmonic=2).values
    i = int(np.nanargmax(h2))
    a, b, c = np.polyfit(w[i - 1 : i + 2], h2[i - 1 : i + 2], 2)
    top = -b / (2 * a)
    return top, np.polyval([a, b, c], top)


@pytest.mark.parametrize("sigma", LEVELS)
def test_the_sweeps_h2_peak_is_the_branchs_maximum(runs, sigma):
    sweep, branch = runs
    step = float(sweep.attrs["sweep_step"])
    w_top, h2_top = _branch_maximum(branch, sigma)
    for direction in ("up", "down"):
        h2 = sweep.amplitude.sel(direction=direction, sigma=sigma, harmonic=2)
        i = int(np.argmax(h2.values))
        assert abs(float(h2.frequency_ratio[i]) - w_top) <= step
        assert abs(float(h2[i]) - h2_top) / h2_top < 1e-3
