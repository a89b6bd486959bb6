"""The order-2 subharmonic's birth at small amplitude: the Mathieu estimate against shooting.

At ``w = 2`` the level sigma at which the period-1 orbit's Floquet multiplier reaches -1
is located by bisection on Newton's orbits (each continued in sigma from the one below),
and compared with :func:`hertzsweep.core.subharmonic.mathieu_onset_sigma` (derived in that
module's docstring). The estimate neglects terms of second order in the response
amplitude A ~ sigma / 3; the central difference adds its own O(h^2) error. Measured:
1.1e-4 relative at zeta = 0.25 % and 1.4e-4 at 1 % (N = 256), so the tolerance 3e-4; and
halving the step divides the difference at zeta = 0.25 % by 3.5 to 4 (the method's second
order: the estimate's own error is smaller than the method's there).
"""

from __future__ import annotations

import numpy as np
import pytest

from hertzsweep.core.subharmonic import mathieu_onset_sigma, mathieu_tongue
from hertzsweep.drivers.oscillator import Oscillator
from hertzsweep.drivers.shooting import PeriodMap, newton

from .conftest import make_scene

W = 2.0
TOLERANCE = 3e-4  # relative: measured 1.1e-4 to 1.4e-4 at N = 256 (module docstring)


def _smallest_multiplier_plus_one(scene, sigma, start=None):
    """``min Re(mu) + 1`` of the period-1 orbit at w = 2 and ``sigma``, and the orbit."""
    oscillator = Oscillator(scene, sigma)
    orbit = newton(PeriodMap(oscillator), start or oscillator.rest(W), W)
    assert orbit.converged, sigma
    return float(np.linalg.eigvals(orbit.monodromy).real.min()) + 1.0, orbit


def period_doubling_sigma(zeta: float, steps_per_period: int = 256) -> float:
    """The located level of the period doubling at w = 2 (bisection to 1e-9 relative)."""
    scene = make_scene(
        damping={"ratio": zeta, "law": "viscous"},
        solver={"steps_per_period": steps_per_period},
    )
    estimate = mathieu_onset_sigma(W, zeta)
    low, high = 0.9 * estimate, 1.1 * estimate
    below, orbit = _smallest_multiplier_plus_one(scene, low)
    above, _ = _smallest_multiplier_plus_one(scene, high, orbit.state)
    assert below > 0.0 > above  # the bracket holds the crossing
    while high - low > 1e-9 * estimate:
        middle = 0.5 * (low + high)
        value, _ = _smallest_multiplier_plus_one(scene, middle, orbit.state)
        low, high = (middle, high) if value > 0.0 else (low, middle)
    return 0.5 * (low + high)


@pytest.mark.parametrize("zeta", [0.0025, 0.01])
def test_the_period_doubling_level_matches_the_mathieu_estimate(zeta):
    located = period_doubling_sigma(zeta)
    estimate = mathieu_onset_sigma(W, zeta)
    assert abs(located - estimate) / estimate < TOLERANCE


def test_the_difference_falls_with_the_methods_order():
    """At zeta = 0.25 % the difference is the method's: h / 2 divides it by about 4."""
    estimate = mathieu_onset_sigma(W, 0.0025)
    coarse = abs(period_doubling_sigma(0.0025, 256) - estimate)
    fine = abs(period_doubling_sigma(0.0025, 512) - estimate)
    assert 3.0 < coarse / fine < 4.5  # measured 3.8


def test_the_estimate_at_two_is_about_36_zeta():
    zeta = 0.0045  # the paper's
    assert mathieu_onset_sigma(W, zeta) == pytest.approx(12.0 * zeta * np.sqrt(9 + 16 * zeta**2))
    assert mathieu_onset_sigma(W, zeta) == pytest.approx(36.0 * zeta, rel=1e-4)


def test_the_tongue_brackets_two_above_its_tip_only():
    zeta = 0.0045
    low, high = mathieu_tongue(0.3, zeta)
    assert low < W < high
    # on its edges the estimate equals the level
    assert mathieu_onset_sigma(low, zeta) == pytest.approx(0.3, rel=1e-9)
    assert mathieu_onset_sigma(high, zeta) == pytest.approx(0.3, rel=1e-9)
    assert mathieu_tongue(0.1, zeta) is None  # below 36 zeta = 0.162: no tongue
