"""A fourth-order method that keeps its order through loss of contact and impacts.

The classical Runge-Kutta method (RK4) on the state ``(q, q')`` of eq. (8)/(11), N fixed
steps a period (``solver.method = "rk4"``), with three additions at the contact crossings:

1. **Crossings located and split.** The force ``[H(d) d]^(3/2)`` is smooth while ``d > 0``
   but not at ``d = 0``, and the contact law's damping may jump there (n = 0). When the sign
   of ``d`` differs at the two ends of a step, the crossing is located on the step's cubic
   Hermite interpolant of q (bisection to round-off) and the step is taken again as two RK4
   steps, to the crossing and from it, each with the law held on its own side of ``d = 0``
   (a stage predicted across it does not switch law). A contact or a flight shorter than
   one step, entered and left within it, is not seen.
2. **Singular terms integrated exactly.** On the contact side of a crossing at ``tau_e``,
   with ``s = |tau - tau_e|``, the compression is ``d = A s + B s^2 + ...`` with
   ``A = 2 |q'_e| / 3`` and ``B = q''_e / 3``; the contact force then holds the terms
   ``A^(3/2) s^(3/2)`` (Hertz) and, under the contact law, ``2 zeta A^n q'_e s^n`` and
   ``2 zeta A^n (n B q'_e / A +- q''_e) s^(n+1)``. A fractional power below 5/2 leaves RK4's
   quadrature an error of order ``h^(p+1)`` on every step near the crossing (their sum
   converges to the same order), so the order would fall to 2.5. At each crossing the
   difference between the exact integrals of these terms and RK4's quadrature of them over
   the steps within :data:`WINDOW` on the contact side (the grid's steps, the split step's
   part included) is added at once to ``(q, q')`` and to the lock-in's integrals. The
   next terms (``s^(5/2)``) leave ``h^(7/2)``: the method's order through impacts is 3.5,
   and 4 while the contact holds.
3. **The lock-in as integrals.** The Fourier integrals of ``x = N/F_s - 1``
   (``int x cos(k w tau)``, ``int x sin(k w tau)``) and its mean are extra states of the same
   RK4 steps: each (sub)step adds Simpson's rule over its stages' values of x, the
   substeps' phases from ``math`` (with the period's offset ``2 pi k p`` for an order k
   that is not whole), the whole steps' from tables of ``sin``, ``cos(pi m / (N L))``
   (step ends and midpoints; L the orders' common denominator, 1 for whole orders). They
   are reported divided by h, so that the readings are formed exactly as the central
   difference's step sums (``2 / (P N)`` times the sum).
   The time out of contact and the flights are measured between located crossings; the
   extremes of N/F_s are read at the step ends and the crossings (second order in h at a
   smooth extremum, as the central difference's).

Without the event handling (``events = False`` in the drive, for tests) every step is
taken whole: the order drops (to 2.5 for the Hertz force alone, to 1 where the damping
jumps).

The state crossing the boundary is ``(q', q)``: it does not depend on the step, so a
frequency change needs no restart. :func:`period_map` is one period of :func:`advance`
with its exact derivatives (forward mode through the stages, the crossing's fraction,
the split and the correction), for shooting and continuation. A lift-off's correction
reaches back to the impact before it, or :data:`WINDOW` when the run started in contact
(it does not know when that contact began); an impact's reaches WINDOW ahead. A step of
the window that is in fact in flight (a contact of duration c < WINDOW) is corrected
for a term it does not have: ``h^5 s^(p-4)`` for a step at s from the crossing, ``h^4
c^(p-3)`` summed from c on, below the method's own ``h^(7/2)`` unless c is a few steps.

Stability of the explicit method (undamped, linearised): ``h omega < 2 sqrt(2)`` (RK4's
interval on the imaginary axis), with ``omega^2 = sqrt(d)`` at the largest compression:
1.41 times the central difference's ``h omega < 2``.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import literally, njit

from . import CACHE
from .integrate import (
    COUNT_FIELDS,
    SUM_FIELDS,
    TALLY_START,
    Readout,
    _finish,
    _sample,
    _status,
    denominator,
)
from .integrate import (
    new_readout as new_readout,  # the readout every method of the single model fills
)
from .laws import singular_exponent, slopes, terms
from .scheme import NON_FINITE, OK, to_compression
from .stop import REQUEST

Drive = namedtuple(
    "Drive",
    [
        "sigma",
        "sin_table",
        "cos_table",
        "harmonics",
        "stop",
        "events",
        "lockin_sin",
        "lockin_cos",
        "orders",
    ],
)
"""The input and the lock-in of the RK4 kernels: as :class:`.integrate.Drive`, with tables
of ``sin``/``cos(pi m / N)``, m = 0 .. 2N - 1 (the step ends and midpoints of a period of
N steps), the lock-in's of ``pi i / (N L)``, i = 0 .. 2 N L - 1, and ``events`` (bool:
locate and split the crossings, integrate their singular terms; False only to show what
that buys)."""

WINDOW = 1.0  # tau on the contact side of a crossing over which its singular terms are
# integrated exactly: the steps beyond contribute O(h^4 WINDOW^(-3/2)) together, below the
# method's own error; a longer window costs more steps of arithmetic at every crossing
TINY = 1e-300  # a compression on the contact side of d = 0 whose force is nothing
SIXTH = 1.0 / 6.0  # Simpson's weight, multiplied by (a division per use costs the divider)


def tables(steps_per_period: int) -> tuple[np.ndarray, np.ndarray]:
    """``sin``, ``cos`` of ``pi m / N``, m = 0 .. 2N - 1."""
    angle = np.pi * np.arange(2 * steps_per_period) / steps_per_period
    return np.sin(angle), np.cos(angle)


@njit(cache=CACHE)
def _acceleration(law, q, v, load, side):
    """``(q'', x = N/F_s - 1, sqrt(d))`` at a state; ``side`` +1 (-1) holds the law on the
    contact (flight) side of ``d = 0`` whatever side the state is on; 0 takes its side."""
    d = to_compression(q)
    if side > 0 and d <= 0.0:
        d = TINY
    elif side < 0 and d > 0.0:
        d = 0.0
    root, c = terms(law, d)
    force = d * root + c * v
    return load - force, force - 1.0, root


@njit(cache=CACHE, inline="always")
def _rk4(law, q, v, h, loads, side):
    """One RK4 step of ``h`` with the loads ``1 + sigma sin`` at its start, middle and end:
    ``(q, q', (x1, x2, x3, x4), sqrt(d) at the start)``, x the stages' N/F_s - 1."""
    a1, x1, root = _acceleration(law, q, v, loads[0], side)
    q2, v2 = q + 0.5 * h * v, v + 0.5 * h * a1
    a2, x2, _ = _acceleration(law, q2, v2, loads[1], side)
    q3, v3 = q + 0.5 * h * v2, v + 0.5 * h * a2
    a3, x3, _ = _acceleration(law, q3, v3, loads[1], side)
    q4, v4 = q + h * v3, v + h * a3
    a4, x4, _ = _acceleration(law, q4, v4, loads[2], side)
    q_new = q + h / 6.0 * (v + 2.0 * (v2 + v3) + v4)
    v_new = v + h / 6.0 * (a1 + 2.0 * (a2 + a3) + a4)
    return q_new, v_new, (x1, x2, x3, x4), root


ZERO = (0.0, 0.0, 0.0)  # the tangent of a constant (see :func:`period_map`)


@njit(cache=CACHE, inline="always")
def _axpy(a, x, y):
    """``a x + y`` of two tangents (3-tuples: derivatives by q'[0], q[0], h)."""
    return (a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2])


@njit(cache=CACHE)
def _stage_tangent(law, q, v, dq, dv, dload, side):
    """The tangent of :func:`_acceleration`'s q'' at a stage ``(q, q')`` with tangents
    ``dq``, ``dv`` and load tangent ``dload``: ``dload - k dq - c dv`` with
    ``k = d(force)/dq`` (none where ``side`` holds d across 0)."""
    d = to_compression(q)
    if side > 0 and d <= 0.0:
        d = TINY
    elif side < 0 and d > 0.0:
        d = 0.0
    held = d != to_compression(q)
    root, c = terms(law, d)
    stiffness, dc = slopes(law, d, root)
    k = (2.0 / 3.0) * (stiffness + dc * v)
    return _axpy(0.0 if held else -k, dq, _axpy(-c, dv, dload))


@njit(cache=CACHE)
def _stage(law, start, previous, c, h, load, side):
    """A stage of :func:`_rk4_tangent` at ``start + c h (previous stage's slope)``:
    ``start = (q, q', dq, dq', dh)``, ``previous = (q', q'', dq', dq'')`` of the stage
    before, ``load = (load, dload)``. Returns ``(q', q'', x, dq', dq'')`` of this stage."""
    q, v, dq, dv, dh = start
    v_before, a_before, dv_before, da_before = previous
    q_stage, v_stage = q + c * h * v_before, v + c * h * a_before
    dq_stage = _axpy(c * v_before, dh, _axpy(c * h, dv_before, dq))
    dv_stage = _axpy(c * a_before, dh, _axpy(c * h, da_before, dv))
    a, x, _ = _acceleration(law, q_stage, v_stage, load[0], side)
    da = _stage_tangent(law, q_stage, v_stage, dq_stage, dv_stage, load[1], side)
    return v_stage, a, x, dv_stage, da


@njit(cache=CACHE)
def _rk4_tangent(law, y, tangents, h, loads, side):
    """:func:`_rk4` (the same arithmetic) with the tangents of its result: ``y = (q, q')``,
    ``tangents = (dq, dq', dh, (dload1, dload2, dload3))`` (3-tuples; ``dh`` the tangent of
    the step's length). Returns ``(q, q', x, dq, dq')``."""
    q, v = y
    dq, dv, dh, dloads = tangents
    start = (q, v, dq, dv, dh)
    first = (v, 0.0, dv, ZERO)
    v1, a1, x1, dv1, da1 = _stage(law, start, first, 0.0, h, (loads[0], dloads[0]), side)
    second = (v1, a1, dv1, da1)
    v2, a2, x2, dv2, da2 = _stage(law, start, second, 0.5, h, (loads[1], dloads[1]), side)
    third = (v2, a2, dv2, da2)
    v3, a3, x3, dv3, da3 = _stage(law, start, third, 0.5, h, (loads[1], dloads[1]), side)
    fourth = (v3, a3, dv3, da3)
    v4, a4, x4, dv4, da4 = _stage(law, start, fourth, 1.0, h, (loads[2], dloads[2]), side)
    sum_v = v1 + 2.0 * (v2 + v3) + v4
    sum_a = a1 + 2.0 * (a2 + a3) + a4
    q_new = q + h / 6.0 * sum_v
    v_new = v + h / 6.0 * sum_a
    dsum_v = _axpy(1.0, dv1, _axpy(2.0, dv2, _axpy(2.0, dv3, dv4)))
    dsum_a = _axpy(1.0, da1, _axpy(2.0, da2, _axpy(2.0, da3, da4)))
    dq_new = _axpy(sum_v / 6.0, dh, _axpy(h / 6.0, dsum_v, dq))
    dv_new = _axpy(sum_a / 6.0, dh, _axpy(h / 6.0, dsum_a, dv))
    return q_new, v_new, (x1, x2, x3, x4), dq_new, dv_new


NEWTON_STEPS = 4  # Newton steps from the chord's root that :func:`_crossing` takes
# without a test: the chord's root is off by about the curvature of H over the step
# (1e-2 and below), so the third step lands at round-off and the fourth shows it


@njit(cache=CACHE)
def _crossing(q0, v0, q1, v1, h):
    """The fraction of a step where its cubic Hermite interpolant of q crosses
    ``q = -3/2`` (d = 0), to round-off: :data:`NEWTON_STEPS` Newton steps from the
    chord's root with no test between them (no branch to mispredict: a crossing costs
    the steps' arithmetic alone), accepted when the last one is below 1e-9 and inside
    the step; otherwise (a grazing crossing, a flat slope) :func:`_bracketed`."""
    c0 = q0 + 1.5  # H(s) + 3/2 = c0 + c1 s + c2 s^2 + c3 s^3
    c1 = h * v0
    c2 = 3.0 * (q1 - q0) - h * (2.0 * v0 + v1)
    c3 = 2.0 * (q0 - q1) + h * (v0 + v1)
    chord = c0 / (c0 - (q1 + 1.5))
    s = chord
    step = 1.0
    for _ in range(NEWTON_STEPS):
        f = c0 + s * (c1 + s * (c2 + s * c3))
        step = f / (c1 + s * (2.0 * c2 + 3.0 * s * c3))
        s -= step
    if abs(step) <= 1e-9 and 0.0 < s < 1.0:  # False with a NaN
        return s
    return _bracketed((c0, c1, c2, c3), chord)


@njit(cache=CACHE)
def _bracketed(c, s):
    """The root in (0, 1) of the cubic ``c = (c0, c1, c2, c3)``, ``c0 + c1 s + c2 s^2 + c3
    s^3``, whose values at 0 and 1 differ in sign: Newton's method from ``s``, kept inside
    the bracket by bisection where a step would leave it, to round-off."""
    c0, c1, c2, c3 = c
    lo, hi = 0.0, 1.0
    rising = c0 < 0.0  # the sign of H + 3/2 at s = 0 is c0's; at s = 1 the other
    for _ in range(100):
        f = c0 + s * (c1 + s * (c2 + s * c3))
        if (f < 0.0) == rising:
            lo = s
        else:
            hi = s
        slope = c1 + s * (2.0 * c2 + 3.0 * s * c3)
        step = f / slope if slope != 0.0 else np.inf
        trial = s - step
        if not (lo < trial < hi):  # outside the bracket (or no slope): bisect
            trial = 0.5 * (lo + hi)
        elif abs(step) <= 1e-9:  # quadratic convergence: after this step, ~1e-18 is left
            return trial
        if trial == s or hi - lo <= 4e-16:
            return s
        s = trial
    return s


@njit(cache=CACHE, inline="always")
def _load(sigma, w, tau):
    return 1.0 + sigma * math.sin(w * tau)


@njit(cache=CACHE, inline="always")
def _scale(a, x):
    return (a * x[0], a * x[1], a * x[2])


@njit(cache=CACHE)
def _crossing_tangent(ends, h, s, tangents):
    """The tangent of the fraction ``s`` of :func:`_crossing`, implicit in ``H(s) = -3/2``
    (H the Hermite interpolant of the ends ``(q0, q'0, q1, q'1)``, whose tangents are
    ``tangents``): ``-dH / (dH/ds)``."""
    q0, v0, q1, v1 = ends
    dq0, dv0, dq1, dv1 = tangents
    s2 = s * s
    s3 = s2 * s
    slope = (
        (6.0 * s2 - 6.0 * s) * q0
        + (3.0 * s2 - 4.0 * s + 1.0) * h * v0
        + (6.0 * s - 6.0 * s2) * q1
        + (3.0 * s2 - 2.0 * s) * h * v1
    )
    h10, h11 = s3 - 2.0 * s2 + s, s3 - s2
    change = _axpy(2.0 * s3 - 3.0 * s2 + 1.0, dq0, _scale(3.0 * s2 - 2.0 * s3, dq1))
    change = _axpy(h10 * h, dv0, _axpy(h11 * h, dv1, change))
    change = (change[0], change[1], change[2] + h10 * v0 + h11 * v1)  # by h
    return _scale(-1.0 / slope, change)


@njit(cache=CACHE)
def _singular_terms(law, crossing):
    """The fractional powers of ``s = |tau - tau_e|`` below 5/2 in the contact force near a
    crossing ``(tau_e, v_e, a_e, direction, w, dv_e, da_e)``: speed ``v_e`` and contact-side
    acceleration ``a_e`` there (with their tangents), ``direction`` +1 where the contact
    follows (an impact), -1 where it precedes (a lift-off). Returns three terms
    ``(beta, p, dbeta)``, each ``beta s^p`` with the tangent of beta (beta = 0 for a term
    the law does not have)."""
    _, v_e, a_e, direction, _, dv_e, da_e = crossing
    a = (2.0 / 3.0) * abs(v_e)
    da = _scale((2.0 / 3.0) * (1.0 if v_e > 0.0 else -1.0), dv_e)
    b = a_e / 3.0
    root = math.sqrt(a)
    hertz = (a * root, 1.5, _scale(1.5 * root, da))
    none = (0.0, 1.0, ZERO)
    n = singular_exponent(law)
    if n < 0.0 or a <= 0.0:  # viscous: c q' is smooth
        return hertz, none, none
    an = _power(a, n)
    dan = _scale(n * an / a, da)  # of a^n
    first = none
    if n != math.floor(n) and n < 2.5:
        dfirst = _axpy(law.twozeta * an, dv_e, _scale(law.twozeta * v_e, dan))
        first = (law.twozeta * an * v_e, n, dfirst)
    p = n + 1.0
    second = none
    if p != math.floor(p) and p < 2.5:
        g = n * b * v_e / a + direction * a_e
        dg = _axpy(n * v_e / (3.0 * a), da_e, _axpy(n * b / a, dv_e, _scale(direction, da_e)))
        dg = _axpy(-n * b * v_e / (a * a), da, dg)
        second = (
            law.twozeta * an * g,
            p,
            _axpy(law.twozeta * an, dg, _scale(law.twozeta * g, dan)),
        )
    if first[1] == 1.5:  # n = 3/2: one power with the Hertz term, integrated once
        hertz = (hertz[0] + first[0], 1.5, _axpy(1.0, hertz[2], first[2]))
        first = none
    return hertz, first, second


@njit(cache=CACHE, inline="always")
def _power(s, p):
    """``s^p`` (s >= 0), the half-integer powers by a square root (no ``pow``)."""
    if p == 1.5:
        return s * math.sqrt(s)
    if p == 0.5:
        return math.sqrt(s)
    if p == 1.0:
        return s
    return s**p


@njit(cache=CACHE, inline="always")
def _inverses(p):
    """``(1 / (p + 1), 1 / (p + 2), 1 / (p + 3))``: what :func:`_defects` divides by for
    ``s^p`` (the first two) and for ``s^(p + 1)`` (the last two), formed once a crossing
    (a division costs the divider as much as a square root)."""
    return 1.0 / (p + 1.0), 1.0 / (p + 2.0), 1.0 / (p + 3.0)


@njit(cache=CACHE, inline="always")
def _defects(inverses, span, powers, impact):
    """For ``g = s^p`` over one step spanning ``span = (lo, hi)`` in s, ``powers = (g(lo),
    g(mid), g(hi))``, ``inverses = (1 / (p + 1), 1 / (p + 2))``: ``(D, Dq)``, the exact
    integral of g minus RK4's quadrature of it (Simpson's rule) and the exact double
    integral (the displacement it adds at the step's end) minus RK4's. ``impact``: s
    grows with tau (the step starts at lo), else it falls (the step starts at hi)."""
    lo, hi = span
    g_lo, g_mid, g_hi = powers
    step = hi - lo
    sixth = step * SIXTH
    one = (hi * g_hi - lo * g_lo) * inverses[0]
    two = (hi * hi * g_hi - lo * lo * g_lo) * inverses[1]
    defect = one - sixth * (g_lo + 4.0 * g_mid + g_hi)
    if impact:  # int (tau_b - tau) g: tau_b at hi
        return defect, hi * one - two - step * sixth * (g_lo + 2.0 * g_mid)
    return defect, two - lo * one - step * sixth * (g_hi + 2.0 * g_mid)


@njit(cache=CACHE, inline="always")
def _defect_slopes(p, span, powers, of):
    """The derivatives of :func:`_defects`' ``D`` and ``Dq`` by ``(lo, hi)``; ``of =
    (D, impact)``."""
    lo, hi = span
    g_lo, g_mid, g_hi = powers
    _, impact = of
    mid = 0.5 * (lo + hi)
    s_lo = p * g_lo / lo if lo > 0.0 else 0.0  # lo = 0 only at the crossing itself
    s_hi = p * g_hi / hi if hi > 0.0 else 0.0
    s_mid = p * g_mid / mid if mid > 0.0 else 0.0
    step = hi - lo
    one = (hi * g_hi - lo * g_lo) / (p + 1.0)
    simpson = g_lo + 4.0 * g_mid + g_hi
    by_defect = (
        -g_lo + simpson / 6.0 - step / 6.0 * (s_lo + 2.0 * s_mid),
        g_hi - simpson / 6.0 - step / 6.0 * (2.0 * s_mid + s_hi),
    )
    if impact:
        inner = g_lo + 2.0 * g_mid
        by_shift = (
            -step * g_lo + step / 3.0 * inner - step * step / 6.0 * (s_lo + s_mid),
            one - step / 3.0 * inner - step * step / 6.0 * s_mid,
        )
        return by_defect, by_shift
    inner = g_hi + 2.0 * g_mid
    by_shift = (
        -one + step / 3.0 * inner - step * step / 6.0 * s_mid,
        step * g_hi - step / 3.0 * inner - step * step / 6.0 * (s_hi + s_mid),
    )
    return by_defect, by_shift


@njit(cache=CACHE, inline="always")
def _set(values, index, value):
    """``values`` (a 3-tuple) with ``values[index] = value``."""
    return (
        value if index == 0 else values[0],
        value if index == 1 else values[1],
        value if index == 2 else values[2],
    )


@njit(cache=CACHE)
def _correct(law, drive, h, crossing, span, sums, fourier, period):
    """The exact integrals of the singular terms of a crossing minus RK4's quadrature of
    them (see the module docstring), over the steps from the crossing to the window's end
    (or ``reach``, tau from the crossing to the previous crossing): returned as
    ``(dq, dv)`` for the state at the crossing with their tangents, and added to the
    integral of x (``sums[0]``) and to its Fourier integrals (``fourier``, when it has
    rows), all divided by h.

    ``crossing = (tau_e, v_e, a_e, direction, w, dv_e, da_e)``; ``span = (first, reach,
    dfirst, dreach, derivatives)``: the length of the split step's part on the contact
    side, ``reach``, their tangents, and whether to carry the tangents at all (the
    returned ones are zero where not); ``period``: the measured period the crossing lies
    in (the phase offset of an order that is not whole, :func:`_reference`)."""
    tau_e, v_e, a_e, direction, w, _, _ = crossing
    first, reach, dfirst, dreach, derivatives = span
    impact = direction > 0.0
    dq = 0.0
    dv = 0.0
    ddq = ZERO
    ddv = ZERO
    terms3 = _singular_terms(law, crossing)
    inverses = (_inverses(terms3[0][1]), _inverses(terms3[1][1]), _inverses(terms3[2][1]))
    k = fourier.shape[0]
    per_h = 1.0 / h
    total = 0.0  # the defect of the integral of x, added to sums[0] at the end
    lo, hi = 0.0, first
    dlo, dhi = ZERO, dfirst
    limit = min(WINDOW, reach)
    at_lo = (0.0, 0.0, 0.0)  # each term's s^p at lo (the last piece's hi)
    while True:
        mid = 0.5 * (lo + hi)
        at_hi = (0.0, 0.0, 0.0)
        for t in range(3):
            beta, p, dbeta = terms3[t]
            if beta == 0.0:
                continue
            g_mid, g_hi = _power(mid, p), _power(hi, p)
            at_hi = _set(at_hi, t, g_hi)
            powers = (at_lo[t], g_mid, g_hi)
            inverse = inverses[t]
            defect, shift = _defects((inverse[0], inverse[1]), (lo, hi), powers, impact)
            arm = hi if impact else -lo  # tau_b - tau_e
            moment = shift - defect * arm
            dv -= beta * defect
            dq -= beta * moment
            if derivatives:
                by_defect, by_shift = _defect_slopes(p, (lo, hi), powers, (defect, impact))
                ddefect = _axpy(by_defect[0], dlo, _scale(by_defect[1], dhi))
                dshift = _axpy(by_shift[0], dlo, _scale(by_shift[1], dhi))
                darm = dhi if impact else _scale(-1.0, dlo)
                dmoment = _axpy(-defect, darm, _axpy(-arm, ddefect, dshift))
                ddv = _axpy(-defect, dbeta, _axpy(-beta, ddefect, ddv))
                ddq = _axpy(-moment, dbeta, _axpy(-beta, dmoment, ddq))
            total += beta * defect
            if k > 0:
                next_powers = (lo * powers[0], mid * g_mid, hi * g_hi)  # s^(p + 1)
                slope = _defects((inverse[1], inverse[2]), (lo, hi), next_powers, impact)[0]
                for i in range(k):
                    kw, offset = _reference(drive, i, w, period)
                    c, s = math.cos(kw * tau_e + offset), math.sin(kw * tau_e + offset)
                    # x cos(k w tau) with cos(k w (tau_e + direction s)) to first order in s
                    fourier[i, 0] += beta * (c * defect - direction * kw * s * slope) * per_h
                    fourier[i, 1] += beta * (s * defect + direction * kw * c * slope) * per_h
        at_lo = at_hi
        if not hi < limit:  # hi >= limit, or a crossing of a state already non-finite (NaN
            # compares false: the loop ends, and the NaN it returns is the caller's to flag)
            sums[0] += total * per_h
            return dq, dv, ddq, ddv
        if hi + h < reach:
            lo, hi, dlo, dhi = hi, hi + h, dhi, (dhi[0], dhi[1], dhi[2] + 1.0)
        else:
            lo, hi, dlo, dhi = hi, reach, dhi, dreach


@njit(cache=CACHE, inline="always")
def _reference(drive, i, w, period):
    """``(k w, offset)`` of harmonic i: its phase ``k w tau + offset`` at tau in period p of
    a measured record, ``offset = 2 pi (m p mod L) / L`` (``m = k L``; 0 for a whole
    order, so that its phase is ``k w tau`` to the last bit)."""
    common = denominator(drive)
    turns = (drive.orders[i] * period) % common
    return drive.harmonics[i] * w, 2.0 * math.pi * turns / common


@njit(cache=CACHE, inline="always")
def _simpson(fourier, index, shift, drive, x, weight):
    """Add Simpson's rule over a whole step's stages to the Fourier integrals (``weight`` =
    1/6: integral / h), the phases at positions ``index``, ``+shift``, ``+2 shift`` of the
    lock-in's tables."""
    n2 = drive.lockin_sin.shape[0]
    for i in range(index.shape[0]):
        i0 = index[i]
        im = i0 + shift[i]
        im = im - n2 if im >= n2 else im
        i1 = im + shift[i]
        i1 = i1 - n2 if i1 >= n2 else i1
        xm = x[1] + x[2]
        fourier[i, 0] += weight * (
            x[0] * drive.lockin_cos[i0]
            + 2.0 * xm * drive.lockin_cos[im]
            + x[3] * drive.lockin_cos[i1]
        )
        fourier[i, 1] += weight * (
            x[0] * drive.lockin_sin[i0]
            + 2.0 * xm * drive.lockin_sin[im]
            + x[3] * drive.lockin_sin[i1]
        )
        index[i] = i1


@njit(cache=CACHE, inline="always")
def _simpson_at(fourier, drive, x, span, weight):
    """Simpson's rule over a substep ``span = (tau, step, w, period)`` from ``tau`` in the
    measured period ``period`` (phases from ``math``, :func:`_reference`)."""
    tau, step, w, period = span
    for i in range(fourier.shape[0]):
        kw, offset = _reference(drive, i, w, period)
        t0 = kw * tau + offset
        tm = kw * (tau + 0.5 * step) + offset
        t1 = kw * (tau + step) + offset
        c0, cm, c1 = math.cos(t0), math.cos(tm), math.cos(t1)
        s0, sm, s1 = math.sin(t0), math.sin(tm), math.sin(t1)
        xm = 2.0 * (x[1] + x[2])
        fourier[i, 0] += weight * (x[0] * c0 + xm * cm + x[3] * c1)
        fourier[i, 1] += weight * (x[0] * s0 + xm * sm + x[3] * s1)


@njit(cache=CACHE, inline="always")
def _substep(law, y, tangents, h, loads, side):
    """One RK4 (sub)step of ``h`` from ``y = (q, q', dq, dq', derivatives)``: with the
    tangents (``tangents = (dh, dloads)``) where ``derivatives``, else :func:`_rk4` alone
    (the same values) and the tangents left as they are. Returns ``(q, q', x, dq, dq')``."""
    q, v, dq, dv, derivatives = y
    if derivatives:
        dh, dloads = tangents
        return _rk4_tangent(law, (q, v), (dq, dv, dh, dloads), h, loads, side)
    q, v, x, _ = _rk4(law, q, v, h, loads, side)
    return q, v, x, dq, dv


@njit(cache=CACHE)
def _split(law, drive, step, y, sums, fourier):
    """The step of ``step = (h, w, sigma, j, fraction, inside, reach, dfraction, dreach,
    grid, period)`` (``grid``: the loads at the step's ends, from the tables; ``period``:
    the measured period the step lies in, for the lock-in's phases) from ``y = (q, q',
    dq, dq', derivatives)`` taken as two RK4 steps, to the crossing at
    ``fraction`` of it and from it, the singular terms' correction (:func:`_correct`) added
    at the crossing; each part's quadrature added to ``sums`` and ``fourier`` (when it has
    rows). Returns ``(q, q', x at the crossing, dq, dq')``: the tangents as
    :func:`period_map`'s (those of ``fraction`` and ``reach`` given) where
    ``derivatives``, else the ones given (an advance needs none)."""
    h, w, sigma, j, fraction, inside, reach, dfraction, dreach, grid, period = step
    derivatives = y[4]
    side = 1 if inside else -1
    first = fraction * h
    second = h - first
    dfirst = _axpy(h, dfraction, (0.0, 0.0, fraction))
    dsecond = _axpy(-1.0, dfirst, (0.0, 0.0, 1.0))
    t0 = j * h
    tau_e = t0 + first
    middle = t0 + 0.5 * first
    loads = (grid[0], _load(sigma, w, middle), _load(sigma, w, tau_e))
    # w tau = 2 pi (j + fraction c) / N at tau = t0 + c first: its tangent is w h c dfraction
    rate = sigma * w * h if derivatives else 0.0
    dloads = (
        ZERO,
        _scale(0.5 * rate * math.cos(w * middle), dfraction) if derivatives else ZERO,
        _scale(rate * math.cos(w * tau_e), dfraction) if derivatives else ZERO,
    )
    q, v, x, dq, dv = _substep(law, y, (dfirst, dloads), first, loads, side)
    _quadrature(sums, fourier, drive, x, (t0, first, w, h, period))
    # the contact side's acceleration at the crossing (there the force is c(0+) q')
    a_e, x_e, _ = _acceleration(law, -1.5, v, loads[2], 1)
    da_e = _stage_tangent(law, -1.5, v, ZERO, dv, dloads[2], 1) if derivatives else ZERO
    direction = -1.0 if inside else 1.0
    crossing = (tau_e, v, a_e, direction, w, dv, da_e)
    contact = (
        (second, reach, dsecond, dreach, derivatives)
        if direction > 0.0
        else (first, reach, dfirst, dreach, derivatives)
    )
    cq, cv, dcq, dcv = _correct(law, drive, h, crossing, contact, sums, fourier, period)
    middle = tau_e + 0.5 * second
    loads = (loads[2], _load(sigma, w, middle), grid[1])
    dmiddle = _scale(0.5 * rate * math.cos(w * middle), dfraction) if derivatives else ZERO
    y = (q + cq, v + cv, _axpy(1.0, dcq, dq), _axpy(1.0, dcv, dv), derivatives)
    q, v, x, dq, dv = _substep(law, y, (dsecond, (dloads[2], dmiddle, ZERO)), second, loads, -side)
    _quadrature(sums, fourier, drive, x, (tau_e, second, w, h, period))
    return q, v, x_e, dq, dv


@njit(cache=CACHE, inline="always")
def _quadrature(sums, fourier, drive, x, span):
    """Simpson's rule over the stages x of a part ``span = (tau, step, w, h, period)`` of
    a step, added (divided by h) to the integral of x and to its Fourier integrals."""
    tau, step, w, h, period = span
    weight = step / (6.0 * h)
    sums[0] += weight * (x[0] + 2.0 * (x[1] + x[2]) + x[3])
    _simpson_at(fourier, drive, x, (tau, step, w, period), weight)


@njit(cache=CACHE, inline="always")
def _flight(flights, now, lift_off):
    """A crossing at ``now`` into ``flights`` = (start of the current flight or -1, 0 if
    the periods started in flight else -1, end of that first flight or -1, the longest
    flight within the periods, the time in flight)."""
    if lift_off:
        flights[0] = now
    elif flights[0] >= 0.0:  # an impact, after a flight of now - start
        flights[4] += now - flights[0]
        if flights[0] == flights[1] and flights[2] < 0.0:
            flights[2] = now  # may join the flight the periods end in
        else:
            flights[3] = max(flights[3], now - flights[0])
        flights[0] = -1.0


@njit(cache=CACHE)
def _flight_counts(flights, end, h, samples):
    """``(loss, longest, lead, trail)`` of :data:`.integrate.COUNT_FIELDS` (in steps h) of
    the flights over periods ending at ``end``: the central difference's contract."""
    start, initial, lead, longest, loss = flights
    trail = (end - start) / h if start >= 0.0 else 0.0
    loss += end - start if start >= 0.0 else 0.0
    if initial < 0.0:
        lead = 0.0
    elif lead < 0.0:  # never in contact
        return loss / h, longest / h, float(samples), float(samples)
    else:
        lead = lead / h
    return loss / h, longest / h, lead, trail


@njit(cache=CACHE, error_model="numpy", nogil=True)
def _run(law, drive, t, h, state, periods, out, measuring):
    """Whole periods of trajectory t (``drive.sigma[t]``, step h) from ``state[:, t]`` =
    ``(q', q)`` at phase 0, in place; when ``measuring``, read into column t of ``out``
    (:class:`.integrate.Readout`, flight times and sums divided by h). Returns the status
    (:data:`.scheme.STATUS`)."""
    literally(measuring)  # compiled once reading and once not: no dead branch in the loop
    n = drive.sin_table.shape[0] // 2
    w = 2.0 * math.pi / (n * h)
    sigma = drive.sigma[t]
    v, q = state[0, t], state[1, t]
    limit = 8.0 / (h * h)  # (h omega)^2 < 8 with omega^2 = sqrt(d): core.model.STABILITY
    peak = 0.0
    k = drive.orders.shape[0] if measuring else 0
    fourier = np.zeros((k, 2))
    index = np.zeros(k, dtype=np.int64)  # the first measured step at reference phase 0
    shift = np.empty(k, dtype=np.int64)
    references = drive.lockin_sin.shape[0]  # 2 N L: the index runs on over the periods
    for i in range(k):
        shift[i] = drive.orders[i] % references
    sums = np.zeros(1)  # the integral of x, divided by h
    acc = TALLY_START  # only its extremes are used: the flights are timed here
    start = 0.0 if to_compression(q) <= 0.0 else -1.0
    flights = np.array([start, start, -1.0, 0.0, 0.0])  # see _flight
    last_crossing = -np.inf
    history = (np.nan, np.nan)  # x at the two grid points before (NaN: none on this side)
    sample = 0
    for p in range(periods):
        if measuring and p == periods - 1:
            out.sums[3, t], out.sums[4, t] = v, q
        for j in range(n):
            loads = (
                1.0 + sigma * drive.sin_table[2 * j],
                1.0 + sigma * drive.sin_table[2 * j + 1],
                1.0 + sigma * drive.sin_table[2 * j + 2 if j < n - 1 else 0],
            )
            inside = to_compression(q) > 0.0
            q1, v1, x, root = _rk4(law, q, v, h, loads, (1 if inside else -1) * drive.events)
            peak = root if root > peak else peak
            if measuring:
                acc = _extremes(acc, history, x[0])
                history = (history[1], x[0])
                if out.stride > 0 and (p * n + j) % out.stride == 0:
                    _sample(out.record[sample, :, t], to_compression(q), v, x[0])
                    sample += 1
            crossed = (to_compression(q1) > 0.0) != inside
            if not crossed or not drive.events:
                if measuring:
                    sums[0] += (x[0] + 2.0 * (x[1] + x[2]) + x[3]) / 6.0
                    _simpson(fourier, index, shift, drive, x, 1.0 / 6.0)
                q, v, q_old, v_old = q1, v1, q, v
                if not crossed:
                    continue
                fraction = _crossing(q_old, v_old, q1, v1, h)
            else:
                fraction = _crossing(q, v, q1, v1, h)
                reach = p * n * h + (j + fraction) * h - last_crossing if inside else np.inf
                grid = (loads[0], loads[2])
                step = (h, w, sigma, j, fraction, inside, reach, ZERO, ZERO, grid, p)
                given = (q, v, ZERO, ZERO, False)  # no derivatives: an advance
                q, v, x_e, _, _ = _split(law, drive, step, given, sums, fourier)
                acc = _extremes(acc, (np.nan, np.nan), x_e)
                ahead = (2 * (p * n + j + 1)) % references  # half steps to the next step
                for i in range(k):  # the table positions of the next step
                    index[i] = (shift[i] * ahead) % references
            last_crossing = p * n * h + (j + fraction) * h
            _flight(flights, last_crossing, inside)
            history = (np.nan, np.nan)  # no parabola across the kink
        status = _status(to_compression(v), to_compression(q), peak, limit, drive.stop)
        if status != OK:
            state[0, t], state[1, t] = v, q
            return status
    state[0, t], state[1, t] = v, q
    if measuring:
        loss, longest, lead, trail = _flight_counts(flights, periods * n * h, h, periods * n)
        acc = (sums[0], acc[1], acc[2], loss, longest, lead, trail)
        _finish(out, t, acc, fourier[:, 0], fourier[:, 1])
        out.sums[5, t], out.sums[6, t] = v, q
    return OK


@njit(cache=CACHE, inline="always")
def _extremes(acc, history, x):
    """The running sums of :func:`.integrate.tally` with only the extremes of x updated: by
    x, and where the grid point before (``history[1]``) is a local extremum, by the vertex
    of the parabola through it and its neighbours (third order in h, where the samples
    alone are second)."""
    a, b = history
    high, low = max(acc[1], x), min(acc[2], x)
    curvature = a - 2.0 * b + x
    if (b >= a and b >= x) or (b <= a and b <= x):  # False with a NaN
        if curvature != 0.0:
            vertex = b - (a - x) * (a - x) / (8.0 * curvature)
            high, low = max(high, vertex), min(low, vertex)
    return (acc[0], high, low, acc[3], acc[4], acc[5], acc[6])


@njit(cache=CACHE, error_model="numpy", nogil=True)
def _each(v, q, h, law, drive, periods, readout, measuring):
    """:func:`_run` for trajectory after trajectory, in place on ``v`` and ``q`` (left as
    they were when one fails). Returns ``(status, trajectory)``."""
    state = np.empty((2, q.shape[0]))
    state[0, :] = v
    state[1, :] = q
    for t in range(q.shape[0]):
        status = _run(law, drive, t, h[t], state, periods, readout, measuring)
        if status != OK:
            return status, t
    v[:] = state[0]
    q[:] = state[1]
    return OK, -1


@njit(cache=CACHE, error_model="numpy", nogil=True)
def measure(v, q, h, law, drive, periods, readout):
    """Whole periods of T trajectories, in place on ``v`` (q') and ``q``, read into
    ``readout``: :func:`.integrate.measure`'s contract (one trajectory after another, each
    the numbers of a batch of one). Returns ``(status, trajectory)``."""
    return _each(v, q, h, law, drive, periods, readout, True)


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance_batch(v, q, h, law, drive, periods):
    """Whole periods of T trajectories without reading them
    (:func:`.integrate.advance_batch`'s contract)."""
    return _each(v, q, h, law, drive, periods, _no_readout(q.shape[0]), False)


@njit(cache=CACHE, error_model="numpy", nogil=True)
def advance(v, q, h, law, drive, periods):
    """Whole periods of one trajectory (``drive.sigma[0]``): ``(v, q, status)``, as
    :func:`.integrate.advance`."""
    state = np.empty((2, 1))
    state[0, 0] = v
    state[1, 0] = q
    status = _run(law, drive, 0, h, state, periods, _no_readout(1), False)
    return state[0, 0], state[1, 0], status


@njit(cache=CACHE, error_model="numpy", nogil=True)
def period_map(v, q, h, law, drive, derivative):
    """One period of the method (level ``drive.sigma[0]``) from ``(q', q)`` at phase 0,
    with its exact derivatives: the same arithmetic as :func:`advance` over one period
    (bit for bit), differentiated in forward mode through every stage, the crossing's
    fraction (implicit in the Hermite interpolant), the split and the singular terms'
    correction. ``derivative`` (float64[2, 3]) receives ``d(q'[N], q[N]) / d(q'[0], q[0],
    h)``: the monodromy matrix and ``dP/dh`` (the loads of the grid do not depend on h; a
    split step's do, through its fraction). Returns ``(q', q, status)`` as :func:`advance`.
    """
    n = drive.sin_table.shape[0] // 2
    w = 2.0 * math.pi / (n * h)
    sigma = drive.sigma[0]
    limit = 8.0 / (h * h)
    peak = 0.0
    dv, dq, dh = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)
    none = np.zeros(1)
    nothing = np.zeros((0, 2))
    last_crossing, dlast = -np.inf, ZERO
    for j in range(n):
        loads = (
            1.0 + sigma * drive.sin_table[2 * j],
            1.0 + sigma * drive.sin_table[2 * j + 1],
            1.0 + sigma * drive.sin_table[2 * j + 2 if j < n - 1 else 0],
        )
        d = to_compression(q)
        inside = d > 0.0
        peak = max(peak, math.sqrt(d) if inside else 0.0)
        side = (1 if inside else -1) * drive.events
        tangents = (dq, dv, dh, (ZERO, ZERO, ZERO))
        q1, v1, _, dq1, dv1 = _rk4_tangent(law, (q, v), tangents, h, loads, side)
        if (to_compression(q1) > 0.0) == inside or not drive.events:
            q, v, dq, dv = q1, v1, dq1, dv1
            continue
        fraction = _crossing(q, v, q1, v1, h)
        dfraction = _crossing_tangent((q, v, q1, v1), h, fraction, (dq, dv, dq1, dv1))
        now = 0.0 + (j + fraction) * h  # as _run's crossing time in its first period
        dnow = _axpy(h, dfraction, (0.0, 0.0, j + fraction))
        reach, dreach = (
            (now - last_crossing, _axpy(-1.0, dlast, dnow)) if inside else (np.inf, ZERO)
        )
        grid = (loads[0], loads[2])
        step = (h, w, sigma, j, fraction, inside, reach, dfraction, dreach, grid, 0)
        q, v, _, dq, dv = _split(law, drive, step, (q, v, dq, dv, True), none, nothing)
        last_crossing, dlast = now, dnow
    for i in range(3):
        derivative[0, i] = dv[i]
        derivative[1, i] = dq[i]
    status = _status(to_compression(v), to_compression(q), peak, limit, drive.stop)
    if status == OK and not math.isfinite(dv[0] + dv[1] + dv[2] + dq[0] + dq[1] + dq[2]):
        status = NON_FINITE
    return v, q, status


@njit(cache=CACHE)
def _no_readout(trajectories):
    """A readout with no harmonics and no record (advancing without reading)."""
    return Readout(
        np.zeros((0, 2, trajectories)),
        np.zeros((len(SUM_FIELDS), trajectories)),
        np.zeros((len(COUNT_FIELDS), trajectories)),
        np.zeros((0, 4, trajectories)),
        0,
        np.zeros((0, trajectories)),
    )


measure_one = measure  # one trajectory is a batch of one (the same numbers)


def inputs(sigma, sin_table, cos_table, harmonics, lockin=None):
    """The :class:`Drive` of the levels ``sigma`` with the events handled; ``lockin =
    (lockin_sin, lockin_cos, orders)`` as :func:`.integrate.inputs`'s."""
    harmonics = np.asarray(harmonics, dtype=np.float64)
    if lockin is None:
        lockin = (sin_table, cos_table, np.rint(harmonics).astype(np.int64))
    return Drive(sigma, sin_table, cos_table, harmonics, REQUEST, True, *lockin)


def start(q, velocity, h, law):
    """The state's other member at ``(q, q')``: q' itself."""
    return velocity


@njit(cache=CACHE)
def restart(v, q, h_old, h_new, law):
    """q' is the same at any step."""
    return v


def retune_batch(v, q, h, h_new, law):
    """Every trajectory's step becomes ``h_new``; the state ``(q', q)`` is unchanged."""
    h[:] = h_new
