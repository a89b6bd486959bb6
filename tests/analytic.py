"""Analytic results the tests check the scheme against (not used by the package).

- :func:`linear_response`: the steady-state response of N/F_s to a sine in the linear
  limit (sigma -> 0, viscous damping), of the continuous equation and of the discrete
  central-difference scheme exactly;
- :func:`modified_energy`: the shadow energy the undamped, unforced scheme conserves;
- :func:`potential`: the potential of the excess restoring force (eq. 8).
"""

from __future__ import annotations

import numpy as np


def potential(q: np.ndarray) -> np.ndarray:
    """Potential of the excess restoring force ``R(q) - 1`` (eq. 8), zero at rest:
    ``V(q) = 3/5 (d^(5/2) - 1) - q`` in contact, continued linearly in flight."""
    q = np.asarray(q, float)
    d = np.maximum(1.0 + q * (2.0 / 3.0), 0.0)
    return 0.6 * (d**2.5 - 1.0) - q


def modified_energy(q: np.ndarray, velocity: np.ndarray, h: float) -> np.ndarray:
    """The energy the undamped, unforced central-difference scheme conserves.

    Parameters
    ----------
    q : array
        Displacements q[n].
    velocity : array
        Centred velocities ``(q[n+1] - q[n-1]) / (2 h)``, as the kernels record them.
    h : float
        The step in tau.

    Notes
    -----
    Unforced and undamped, the scheme ``q[n+1] - 2 q[n] + q[n-1] = -h^2 V'(q[n])`` is the
    Stormer-Verlet method, with ``p[n]`` the centred velocity. A symplectic method
    conserves a modified Hamiltonian; to order h^2 it is (Hairer, Lubich & Wanner,
    *Geometric Numerical Integration*, IX.8)::

        H~ = p^2/2 + V(q) + h^2 (V''(q) p^2 / 12 - V'(q)^2 / 24) + O(h^4)

    with ``V' = d^(3/2) - 1``, ``V'' = d^(1/2)`` (in contact). The plain energy
    ``p^2/2 + V`` oscillates by O(h^2) around it without drift; H~ varies only by O(h^4).
    For the linear spring (V = q^2/2) the scheme conserves ``p^2/2 + (1 - h^2/4) q^2/2``
    exactly, which is H~ / (1 + h^2/6) to that order. Valid while in contact: the expansion
    needs V smooth along the orbit.
    """
    q, p = np.asarray(q, float), np.asarray(velocity, float)
    d = np.maximum(1.0 + q * (2.0 / 3.0), 0.0)
    force = d**1.5 - 1.0  # V'
    stiffness = np.sqrt(d)  # V''
    return 0.5 * p**2 + potential(q) + h * h * (stiffness * p**2 / 12.0 - force**2 / 24.0)


def linear_response(
    frequency_ratio: float | np.ndarray,
    zeta: float,
    steps_per_period: int | None = None,
) -> np.ndarray:
    """Complex response of N/F_s - 1 to ``sin(w tau)`` in the linear limit (sigma -> 0,
    viscous damping): amplitude ``abs``, phase lag ``-angle``.

    Continuous: ``(1 + 2 i zeta w) / (1 - w^2 + 2 i zeta w)``. With ``steps_per_period``
    N, the exact steady state of the scheme instead (h = 2 pi / (w N)), from
    ``q[n] = Q exp(i w h n)``::

        (1 + 2 i zeta s / h) / (1 - 4 sin^2(w h / 2) / h^2 + 2 i zeta s / h),  s = sin(w h)

    (the kernels' N/F_s uses the centred velocity ``(q[n+1] - q[n-1]) / 2h``).
    """
    w = np.asarray(frequency_ratio, float)
    if steps_per_period is None:
        return (1 + 2j * zeta * w) / (1 - w**2 + 2j * zeta * w)
    h = 2.0 * np.pi / (w * steps_per_period)
    damping = 2j * zeta * np.sin(w * h) / h
    return (1 + damping) / (1 - 4.0 * np.sin(0.5 * w * h) ** 2 / h**2 + damping)
