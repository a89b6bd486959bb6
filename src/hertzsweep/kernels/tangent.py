"""The tangent-linear central-difference scheme: one period of the map and its exact
derivatives, compiled.

The one-period map of the scheme (section 4.3 of the paper, see
:mod:`hertzsweep.integrators`) takes the state ``x = (q[-1], q[0])`` at the start of a
period (excitation phase 0) to ``P(x) = (q[N-1], q[N])``. One step is

    q[n+1] = (h^2 (f_n - (R(q_n) - 1)) + 2 q_n - q[n-1] (1 - c_n h / 2)) / (1 + c_n h / 2)

with ``c_n = c(q_n)`` (eq. 8, 11), ``f_n = sigma sin(2 pi n / N)`` and ``h = 2 pi / (w N)``.
Differentiating it (``D = 1 + c_n h / 2``, ``R' = dR/dq``, ``c' = dc/dq`` at ``q_n``)::

    dq[n+1]/dq[n-1] = -(1 - c_n h / 2) / D
    dq[n+1]/dq[n]   = (2 - h^2 R' - (h / 2) c' (q[n+1] - q[n-1])) / D
    dq[n+1]/dh      = (2 h (f_n - (R(q_n) - 1)) - (c_n / 2) (q[n+1] - q[n-1])) / D  (explicit)

and carrying these through the period with the chain rule gives the exact 2x2 Jacobian
``dP/dx`` (the monodromy matrix of the discrete map, whose eigenvalues are the Floquet
multipliers) and the exact ``dP/dh``; the excitation table does not depend on w (N steps
per period whatever w), so ``dP/dw = dP/dh dh/dw = -(h / w) dP/dh`` is exact too.

Out of contact ``R' = 0`` and ``c' = 0`` (:func:`~hertzsweep.model.contact_derivatives`);
``R' = sqrt(d)`` is continuous through ``d = 0``, so the map is continuously
differentiable through loss of contact (for ``contact`` damping with n = 0 the jump of c at
``d = 0`` makes the map piecewise smooth; its derivative is taken on the side the step is on).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..core.model import VISCOUS, contact_derivatives, contact_terms
from .integrators import NON_FINITE, OK, UNSTABLE, _next


@njit(cache=True)
def period_map(q_prev, q, h, sigma, sin_table, zeta, law, exponent, derivative):
    """One period of the scheme with its exact derivatives.

    Parameters
    ----------
    q_prev, q : float
        The state ``x = (q[-1], q[0])`` at excitation phase 0.
    h : float
        Step in tau, ``2 pi / (w N)``.
    sigma : float
        Input level F/F_s.
    sin_table : float64[N]
        ``sin(2 pi j / N)``.
    zeta, law, exponent
        Damping ratio, law code and exponent (:mod:`hertzsweep.model`).
    derivative : float64[2, 3]
        Output: ``d(q[N-1], q[N]) / d(q[-1], q[0], h)``; the first two columns are the
        monodromy matrix, the third is ``dP/dh``.

    Returns
    -------
    tuple
        ``(q_prev, q, status)`` after one period; ``status`` as in
        :mod:`hertzsweep.integrators`.
    """
    n = sin_table.shape[0]
    h2 = h * h
    half_h = 0.5 * h
    limit = 4.0 / h2
    inv_viscous = 1.0 / (1.0 + 2.0 * zeta * half_h)
    # rows: derivative of q[n-1] (a_*) and q[n] (b_*) with respect to q[-1], q[0], h
    a0 = 1.0
    a1 = 0.0
    a2 = 0.0
    b0 = 0.0
    b1 = 1.0
    b2 = 0.0
    for j in range(n):
        d, sd, rm1, c = contact_terms(q, zeta, law, exponent)
        if sd >= limit:
            return q_prev, q, UNSTABLE
        stiffness, dc = contact_derivatives(q, zeta, law, exponent)
        excess = sigma * sin_table[j] - rm1
        inv_den = inv_viscous if law == VISCOUS else 1.0 / (1.0 + c * half_h)
        # the scheme's update in its division form (integrators.advance rearranges the
        # viscous one): P(x) equals one period of advance to round-off
        q_next = _next(q_prev, q, sigma * sin_table[j], rm1, c, h2, half_h, law, inv_viscous)
        span = q_next - q_prev
        by_prev = -(1.0 - c * half_h) * inv_den
        by_q = (2.0 - h2 * stiffness - half_h * dc * span) * inv_den
        by_h = (2.0 * h * excess - 0.5 * c * span) * inv_den
        n0 = by_prev * a0 + by_q * b0
        n1 = by_prev * a1 + by_q * b1
        n2 = by_prev * a2 + by_q * b2 + by_h
        a0 = b0
        a1 = b1
        a2 = b2
        b0 = n0
        b1 = n1
        b2 = n2
        q_prev = q
        q = q_next
    derivative[0, 0] = a0
    derivative[0, 1] = a1
    derivative[0, 2] = a2
    derivative[1, 0] = b0
    derivative[1, 1] = b1
    derivative[1, 2] = b2
    if not (math.isfinite(q) and math.isfinite(q_prev) and math.isfinite(b0 + b1 + b2)):
        return q_prev, q, NON_FINITE
    return q_prev, q, OK


def warm_up() -> None:
    """Compile (or load from cache) the kernel on a tiny problem, e.g. before timing."""
    sin_table = np.sin(2.0 * np.pi * np.arange(8) / 8)
    period_map(0.0, 0.0, 0.8, 0.01, sin_table, 0.01, 0, 1.5, np.zeros((2, 3)))


__all__ = ["period_map", "warm_up"]
