"""Where the order-2 subharmonic is born: the small-amplitude (Mathieu) estimate.

Near ``w = 2`` the Hertz law's quadratic term turns the forced response into a parametric
excitation of the contact's own mode at ``w / 2``. Expanding the restoring force of
eq. (8) about the static equilibrium (``d = 1 + 2 q / 3``)::

    (1 + 2 q / 3)^(3/2) = 1 + q + q^2 / 6 - q^3 / 54 + ...

the equation of motion is, to second order in q,

    q'' + 2 zeta q' + q + q^2 / 6 = sigma sin(w tau).

Its small forced response is the linear one, ``q0 = A sin(w tau - phi)`` with
``A = sigma / |1 - w^2 + 2 i zeta w|``. A perturbation u of it obeys the variational
equation ``u'' + 2 zeta u' + (1 + q0 / 3) u = 0``: a damped Mathieu equation with
pumping depth ``e = A / 3`` at the frequency w. Its first instability tongue borders
``w = 2``; on the border the perturbation is periodic with period ``2 T`` (a Floquet
multiplier of the forced orbit at -1: a period doubling). Harmonic balance at ``w / 2``,
``u = a cos(w tau / 2) + b sin(w tau / 2)``, keeping the first harmonics of
``cos(w tau) u`` (``cos(w tau) cos(w tau / 2) = (cos(w tau / 2) + cos(3 w tau / 2)) / 2``),
gives with ``s = w / 2``

    | 1 - s^2 + e/2      2 zeta s     | (a)
    |  -2 zeta s      1 - s^2 - e/2   | (b)  = 0,

whose determinant vanishes on the border:

    e^2 / 4 = (1 - s^2)^2 + 4 zeta^2 s^2.

At ``w = 2`` this is ``e = 4 zeta``. With ``e = A / 3`` the level at which the period-1
response first loses stability to the period-2 one is

    sigma_PD(w) = 6 |1 - w^2 + 2 i zeta w| sqrt((1 - w^2 / 4)^2 + zeta^2 w^2),

``sigma_PD(2) = 12 zeta sqrt(9 + 16 zeta^2)``, about ``36 zeta``: 0.162 at the paper's
zeta = 0.45 %. Both damping laws of eq. (11) give ``2 zeta q'`` to first order about
``d = 1``, so the estimate holds for every exponent n.

What it leaves out: the mean shift and the 2 w harmonic of ``q0`` (second order in A,
with ``A ~ sigma / 3``), the cubic term, and the method's own error. Against the
period-doubling level located by shooting (the Floquet multiplier at -1) at ``w = 2`` the
relative difference is 1.1e-4 at zeta = 0.25 % and 1.4e-4 at 1 % with the central
difference at N = 256, and falls as ``h^2`` (8.6e-6 at N = 1024 and zeta = 0.25 %): the
estimate's own error is below the method's there (``tests/test_subharmonic_onset.py``).
"""

from __future__ import annotations

import math


def mathieu_onset_sigma(frequency_ratio: float, zeta: float) -> float:
    """The input level sigma above which the period-1 response at ``w`` loses stability
    to an order-2 subharmonic, at the small-amplitude limit (see the module docstring)."""
    w = float(frequency_ratio)
    forced = abs(complex(1.0 - w * w, 2.0 * zeta * w))
    tongue = math.sqrt((1.0 - 0.25 * w * w) ** 2 + (zeta * w) ** 2)
    return 6.0 * forced * tongue


def mathieu_tongue(sigma: float, zeta: float) -> tuple[float, float] | None:
    """The band ``(w_low, w_high)`` of frequency ratios near 2 where the estimate makes the
    period-1 response at ``sigma`` unstable, or None below the tongue's tip.

    Solved on ``w`` in [1, 3] by bisection on each side of the tongue's lowest level
    (:func:`mathieu_onset_sigma` falls then rises across w = 2)."""
    low, high = 1.0, 3.0
    for _ in range(200):  # golden-section search of the tip (the function is unimodal here)
        a = high - (high - low) / 1.618033988749895
        b = low + (high - low) / 1.618033988749895
        if mathieu_onset_sigma(a, zeta) < mathieu_onset_sigma(b, zeta):
            high = b
        else:
            low = a
    tip = 0.5 * (low + high)
    if mathieu_onset_sigma(tip, zeta) >= sigma:
        return None

    def edge(inside: float, outside: float) -> float:
        for _ in range(200):
            middle = 0.5 * (inside + outside)
            if mathieu_onset_sigma(middle, zeta) < sigma:
                inside = middle
            else:
                outside = middle
        return 0.5 * (inside + outside)

    return edge(tip, 1.0), edge(tip, 3.0)


__all__ = ["mathieu_onset_sigma", "mathieu_tongue"]
