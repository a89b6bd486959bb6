"""The dimensionless model: Hertz restoring force with loss of contact and damping laws.

Eq. (8) and (11) of the paper::

    q'' + f_d(q, q') + [H(d) d]^(3/2) = 1 + sigma sin(w tau),   d = 1 + 2 q / 3

``viscous``: ``f_d = 2 zeta q'`` at all times (eq. 8).
``contact``: ``f_d = 2 zeta d^n H(d) q'``, only in contact (eq. 11), any n >= 0.

The damping force is ``c(q) q'``; the compiled kernels write the laws once, as data
(:mod:`hertzsweep.kernels.laws`). This module holds what needs no compiler: the stability
limit of the explicit scheme, checked before any run.

Stability of the explicit methods (undamped, linearised): ``h omega_max < b`` with
``omega_max^2 = dR/dq = d^(1/2)`` at the largest compression the scene reaches, and the
method's bound b on the imaginary axis (:data:`STABILITY`): 2 for the central difference,
``2 sqrt(2)`` for RK4. The ball model's omega_max is its second (the ball's own) mode at
that compression of both contacts
(:meth:`~hertzsweep.core.ballmodel.BallModel.stability_frequency`).
"""

from __future__ import annotations

import math

from .ballmodel import BallModel
from .config import Scene

STABILITY = {"central-difference": 2.0, "rk4": 2.0 * math.sqrt(2.0)}
"""The bound on ``h omega`` of each ``solver.method`` (its stability interval on the
imaginary axis); the kernels check the same bound on the compression they reach."""


# --------------------------------------------------------------------------- stability
def force_bound(sigma: float, zeta: float) -> float:
    """A documented estimate of the largest N/F_s a scene reaches.

    The linear resonance peak ``1 + sigma / (2 zeta)`` (with zeta floored at 1e-3, the
    lowest damping for which the estimate is meaningful over a finite dwell), never less
    than ``1 + sigma``. The limit depends on it only through ``N^(1/6)``, so a factor 10
    error moves the limit by 47 %; the kernels also check the real compression at
    every step and stop with a :class:`~hertzsweep.errors.StabilityError` if it is passed.

    Measured against the force the runs reach (default scene, N = 256): sigma = 2 with
    zeta = 1e-5 reaches 413 (up) and 392 (down) against the bound 1001 (zeta floored), so
    the preflight and the run both accept it. The bound is an estimate, not a proof: in
    the vibro-impact regime the impacts can pass the linear peak (sigma = 0.1, zeta = 0.01
    reaches 7.5 against 6 over 0.3 <= w <= 1.5; the contact law with n = 0 at sigma = 2,
    zeta = 0.05, w = 0.5 reaches 48 against 21), where only the kernels' check refuses.
    """
    return 1.0 + sigma * max(1.0, 1.0 / (2.0 * max(zeta, 1e-3)))


def omega_max(sigma: float, zeta: float) -> float:
    """Largest local circular frequency (dimensionless) at the compression of
    :func:`force_bound`: ``omega^2 = d^(1/2)`` with ``d = N^(2/3)``, so ``N^(1/6)``."""
    return force_bound(sigma, zeta) ** (1.0 / 6.0)


def stability_limit(scene: Scene, lowest: float | None = None) -> float:
    """The fewest steps per period that keep ``h omega_max < b`` over the scene
    (:data:`STABILITY`).

    ``h = 2 pi / (w N)``, so ``N > 2 pi omega_max / (b w)``; the worst case is the lowest
    frequency run (the grid's, or ``lowest`` when given: a trace below the grid) and the
    largest sigma.
    """
    w_min = float(scene.sweep.frequency_ratios.min()) if lowest is None else float(lowest)
    force = force_bound(max(scene.excitation.sigma), scene.damping.ratio)
    if scene.model.kind == "ball":  # the ball's own mode, the stiffer, sets it
        om = BallModel.of(scene).stability_frequency(force)
    else:
        om = omega_max(max(scene.excitation.sigma), scene.damping.ratio)
    return 2.0 * math.pi * om / (STABILITY[scene.solver.method] * w_min)


def stability_reason(scene: Scene, lowest: float | None = None) -> str | None:
    """Why the scene's time step is at or beyond the stability limit (None when it is
    within it): the reason of :func:`check_stability` and of the preflight's check."""
    limit = stability_limit(scene, lowest)
    steps = scene.solver.steps_per_period
    if steps > limit:
        return None
    w_min = scene.sweep.frequency_ratios.min() if lowest is None else lowest
    advice = f"use at least {math.floor(limit) + 1}" if math.isfinite(limit) else "none is"
    of = "the ball's own mode, " if scene.model.kind == "ball" else ""
    return (
        f"{steps} is at or below the stability limit {limit:.1f} of {of}{scene.solver.method} "
        f"(h omega_max >= {STABILITY[scene.solver.method]:.3g} at w = {w_min:g}); {advice}"
    )


def check_stability(scene: Scene, lowest: float | None = None) -> None:
    """Refuse a scene whose time step is at or beyond the stability limit (at the lowest
    frequency run: the grid's, or ``lowest``)."""
    from ..errors import StabilityError

    reason = stability_reason(scene, lowest)
    if reason is not None:
        raise StabilityError(f"{scene.source}: solver.steps_per_period: {reason}")
