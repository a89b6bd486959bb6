"""The dimensionless model: Hertz restoring force with loss of contact and damping laws.

Eq. (8) and (11) of the paper::

    q'' + f_d(q, q') + [H(d) d]^(3/2) = 1 + sigma sin(w tau),   d = 1 + 2 q / 3

``viscous``: ``f_d = 2 zeta q'`` at all times (eq. 8).
``contact``: ``f_d = 2 zeta d^n H(d) q'``, only in contact (eq. 11), any n >= 0.

The damping force is ``c(q) q'``; the compiled kernels take the law as an integer code
(:data:`LAW_CODES`) so that the paper's exponents 0, 1/2, 1, 3/2 cost no ``pow``.

Stability of the explicit scheme (central difference, undamped): ``h omega_max < 2``
with ``omega_max^2 = dR/dq = d^(1/2)`` at the largest compression the scene reaches.
"""

from __future__ import annotations

import math

from numba import njit

from .config import DampingConfig, Scene

VISCOUS = 0  # 2 zeta always
CONTACT_N0 = 1  # 2 zeta H(d)
CONTACT_N05 = 2  # 2 zeta sqrt(d) H(d)
CONTACT_N1 = 3  # 2 zeta d H(d)
CONTACT_N15 = 4  # 2 zeta d^(3/2) H(d)
CONTACT_GENERAL = 5  # 2 zeta d^n H(d), pow per step
_SPECIAL_EXPONENTS = {0.0: CONTACT_N0, 0.5: CONTACT_N05, 1.0: CONTACT_N1, 1.5: CONTACT_N15}


def law_code(damping: DampingConfig) -> int:
    """The integer code of a damping law for the compiled kernels."""
    if damping.law == "viscous":
        return VISCOUS
    return _SPECIAL_EXPONENTS.get(float(damping.exponent), CONTACT_GENERAL)


@njit(cache=True, inline="always")
def contact_terms(q: float, zeta: float, law: int, exponent: float):
    """``(d, sqrt(d), R(q) - 1, c(q))``: compression, its root, excess restoring force
    and damping coefficient ``f_d = c q'`` (eq. 8, 11). ``sqrt(d)`` is ``omega^2``, the
    local tangent stiffness, used for the stability check; it is 0 out of contact."""
    d = 1.0 + q * (2.0 / 3.0)
    if d > 0.0:
        sd = math.sqrt(d)
        rm1 = d * sd - 1.0
        if law == VISCOUS or law == CONTACT_N0:
            c = 2.0 * zeta
        elif law == CONTACT_N15:
            c = 2.0 * zeta * d * sd
        elif law == CONTACT_N1:
            c = 2.0 * zeta * d
        elif law == CONTACT_N05:
            c = 2.0 * zeta * sd
        else:
            c = 2.0 * zeta * d**exponent
    else:
        sd = 0.0
        rm1 = -1.0
        c = 2.0 * zeta if law == VISCOUS else 0.0
    return d, sd, rm1, c


@njit(cache=True, inline="always")
def contact_derivatives(q: float, zeta: float, law: int, exponent: float):
    """``(dR/dq, dc/dq)`` for the tangent-linear scheme (zero out of contact; the jump of
    c at d = 0 for n = 0 has measure zero along a trajectory)."""
    d = 1.0 + q * (2.0 / 3.0)
    if d <= 0.0:
        return 0.0, 0.0
    sd = math.sqrt(d)
    if law == VISCOUS or law == CONTACT_N0:
        dc = 0.0
    elif law == CONTACT_N15:
        dc = 2.0 * zeta * 1.5 * sd * (2.0 / 3.0)
    elif law == CONTACT_N1:
        dc = 2.0 * zeta * (2.0 / 3.0)
    elif law == CONTACT_N05:
        dc = 2.0 * zeta * 0.5 / sd * (2.0 / 3.0)
    else:
        dc = 2.0 * zeta * exponent * d ** (exponent - 1.0) * (2.0 / 3.0)
    return sd, dc


# --------------------------------------------------------------------------- stability
def force_bound(sigma: float, zeta: float) -> float:
    """A documented estimate of the largest N/F_s a scene reaches.

    The linear resonance peak ``1 + sigma / (2 zeta)`` (with zeta floored at 1e-3, the
    lowest damping for which the estimate is meaningful over a finite dwell), never less
    than ``1 + sigma``. The limit depends on it only through ``N^(1/6)``, so a factor 10
    error moves the limit by 47 %; the kernels also check the real compression at
    every step and stop with a :class:`~hertzsweep.errors.StabilityError` if it is passed.
    """
    return 1.0 + sigma * max(1.0, 1.0 / (2.0 * max(zeta, 1e-3)))


def omega_max(sigma: float, zeta: float) -> float:
    """Largest local circular frequency (dimensionless) at the compression of
    :func:`force_bound`: ``omega^2 = d^(1/2)`` with ``d = N^(2/3)``, so ``N^(1/6)``."""
    return force_bound(sigma, zeta) ** (1.0 / 6.0)


def stability_limit(scene: Scene) -> float:
    """The fewest steps per period that keep ``h omega_max < 2`` over the scene.

    ``h = 2 pi / (w N)``, so ``N > pi omega_max / w``; the worst case is the lowest
    frequency of the grid and the largest sigma.
    """
    w_min = float(scene.sweep.frequency_ratios.min())
    om = omega_max(max(scene.excitation.sigma), scene.damping.ratio)
    return math.pi * om / w_min


def check_stability(scene: Scene) -> None:
    """Refuse a scene whose time step is at or beyond the stability limit."""
    from ..errors import StabilityError

    limit = stability_limit(scene)
    if scene.solver.steps_per_period <= limit:
        raise StabilityError(
            f"{scene.source}: solver.steps_per_period: {scene.solver.steps_per_period} is at or "
            f"below the stability limit {limit:.1f} (h omega_max >= 2 at w = "
            f"{scene.sweep.frequency_ratios.min():g}); use at least {math.floor(limit) + 1}"
        )
