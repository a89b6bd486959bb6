"""The tangent-linear scheme: one period of the map and its exact derivatives.

The one-period map of the scheme (:mod:`.scheme`) takes the state ``x = (q[-1], q[0])`` at
the start of a period (excitation phase 0) to ``P(x) = (q[N-1], q[N])``. In the compression
``d = 1 + 2 q / 3`` one step is ``d[n+1] = (2 d - d[n-1] (1 - c h / 2) + c0 (F - R)) / D``
with ``D = 1 + c h / 2``, ``c0 = 2 h^2 / 3``, ``R = d^(3/2)``, ``c = c(d)`` (eq. 8, 11).
Differentiating it (``R' = dR/dd``, ``c' = dc/dd`` at ``d[n]``)::

    dd[n+1]/dd[n-1] = -(1 - c h / 2) / D                        (= -b)
    dd[n+1]/dd[n]   = (2 - c0 R' + (h / 2) c' (d[n-1] - d[n+1])) / D
    dd[n+1]/dh      = ((4 h / 3) (F - R) - (c / 2) (d[n+1] - d[n-1])) / D

and carrying these through the period with the chain rule gives the exact 2x2 Jacobian
(the monodromy matrix of the discrete map, whose eigenvalues are the Floquet multipliers;
the same in q as in d, since q is an affine function of d) and ``dP/dh``. The excitation
table does not depend on w (N steps per period whatever w), so
``dP/dw = -(h / w) dP/dh`` is exact too.

The trajectory is computed by :func:`.integrate.step`, the very step of
:func:`.integrate.advance`: ``P(x)`` is one period of ``advance``, bit for bit.
Out of contact ``R' = 0`` and ``c' = 0``; ``R' = 3/2 sqrt(d)`` is continuous through
``d = 0``, so the map is continuously differentiable through loss of contact (for contact
damping with n = 0 the jump of c at ``d = 0`` makes it piecewise smooth; the derivative is
taken on the side the step is on).
"""

from __future__ import annotations

import math

from numba import njit

from .integrate import _finite, step
from .laws import slopes
from .scheme import (
    NON_FINITE,
    OK,
    UNSTABLE,
    constant,
    forcing,
    make_step,
    to_compression,
    to_displacement,
)


@njit(cache=True, error_model="numpy")
def period_map(q_prev, q, h, law, drive, derivative):
    """One period of the scheme (level ``drive.sigma[0]``) with its exact derivatives.

    Parameters
    ----------
    q_prev, q : float
        The state ``x = (q[-1], q[0])`` at excitation phase 0.
    h : float
        Step in tau, ``2 pi / (w N)``.
    law, drive
        The damping law (:mod:`.laws`) and the input (:class:`.integrate.Drive`).
    derivative : float64[2, 3]
        Output: ``d(q[N-1], q[N]) / d(q[-1], q[0], h)``; the first two columns are the
        monodromy matrix, the third is ``dP/dh``.

    Returns
    -------
    tuple
        ``(q_prev, q, status)`` after one period, as :func:`.integrate.advance`.
    """
    s = make_step(law, h)
    sigma = drive.sigma[0]
    table = drive.sin_table
    d_prev = to_compression(q_prev)
    d = to_compression(q)
    # rows: derivative of d[n-1] and of d[n] with respect to d[-1], d[0], h
    a0, a1, a2 = 1.0, 0.0, 0.0
    b0, b1, b2 = 0.0, 1.0, 0.0
    for j in range(table.shape[0]):
        load = forcing(sigma, table[j])
        root, c, d_next = step(law, d_prev, d, load, constant(s))
        if root >= s.limit:
            return to_displacement(d_prev), to_displacement(d), UNSTABLE
        stiffness, dc = slopes(law, d, root)
        inv = 1.0 / (1.0 + c * s.half_h)
        by_prev = -(1.0 - c * s.half_h) * inv
        by_d = (2.0 - s.c0 * stiffness + s.half_h * dc * (d_prev - d_next)) * inv
        by_h = ((4.0 / 3.0) * h * (load - d * root) - 0.5 * c * (d_next - d_prev)) * inv
        a0, a1, a2, b0, b1, b2 = (
            b0,
            b1,
            b2,
            by_prev * a0 + by_d * b0,
            by_prev * a1 + by_d * b1,
            by_prev * a2 + by_d * b2 + by_h,
        )
        d_prev = d
        d = d_next
    derivative[0, 0] = a0
    derivative[0, 1] = a1
    derivative[0, 2] = 1.5 * a2
    derivative[1, 0] = b0
    derivative[1, 1] = b1
    derivative[1, 2] = 1.5 * b2
    if not (_finite(d_prev, d) and math.isfinite(b0 + b1 + b2)):
        return to_displacement(d_prev), to_displacement(d), NON_FINITE
    return to_displacement(d_prev), to_displacement(d), OK


__all__ = ["period_map"]
