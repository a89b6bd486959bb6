"""How far a response reaches the ball's own mode, which the one-degree-of-freedom model
leaves out (eq. 1 treats the ball between the two discs as massless).

The ball of mass m_b sits between the upper contact (the moving mass m above) and the
lower one (the transducer below), each of tangent stiffness k_t and, with the scene's
damping law linearised at the static load, each with the same dashpot c. With the moving
mass's motion z1 imposed (m >> m_b), the ball's equation ``m_b z2'' = k_t (z1 - z2) + c
(z1' - z2') - k_t z2 - c z2'`` makes the lower contact transmit, at frequency f,

    N(f) = N0(f) H(f),   H(f) = 1 / (1 - r^2 / (1 + 2 i zeta_b r)),   r = f / f_b,

where ``N0 = (k_t z1 + c z1') / 2`` is what the massless ball transmits (the model's force:
two contacts in series) and ``f_b^2 = 2 k_t / m_b / (2 pi)^2`` the ball's mode
(``hertzsweep.core.rig``'s ``ball_mode_frequency``, the same linearisation with m finite
and the ball's weight on the lower contact, whose stiffness it raises by 0.2 % on the
paper's rig: the figure takes the rig's f_b).
The two dashpots in series are the model's one (``c / 2`` on ``k_t / 2`` gives the scene's
zeta on the first mode), so the ball's mode has ``zeta_b = zeta f_b / f0``: the damping
is proportional to the stiffness, and the higher mode is the more damped one.

The figure is the relative RMS change of the oscillating part of N/F_s that the ball's
mode makes, over the lines of the response's spectrum (amplitudes A_k at f_k > 0):

    e = sqrt( sum_k A_k^2 |H(f_k) - 1|^2 / sum_k A_k^2 ),   |H - 1| = r^2 for r << 1.

A smooth response at f has ``e = (f / f_b)^2`` (1.5e-3 at f0 on the paper's rig);
impacts spread force towards f_b, where ``|H - 1| = 1 / (2 zeta_b)``. It is a linear,
first-order estimate: it says where the model stops being justified, not what the ball
would do there.

:data:`THRESHOLD`: the one-degree-of-freedom model is taken as justified while e <= 0.5 %,
the agreement asked of the two models on a response without loss of contact (H1 within
0.5 %).
"""

from __future__ import annotations

import numpy as np

from .config import Scene

THRESHOLD = 0.005  # relative RMS change of N/F_s beyond which a run warns


def has_ball_mode(scene: Scene) -> bool:
    """Whether a run of the scene reads the ball's mode: the single model of a double
    sphere-plane (where :func:`~hertzsweep.core.rig.derive` gives the mode; a single
    sphere-plane has none, and the ball model integrates the mode itself)."""
    return scene.rig.geometry == "double-sphere-plane" and scene.model.kind == "single"


def check_periods(scene: Scene) -> int:
    """The periods a sweep integrates per dwell for the check: one from each dwell's end
    state where it reads the ball's mode (``hertzsweep.drivers.ballmode``), else none."""
    return 1 if has_ball_mode(scene) else 0


def ball_damping(zeta: float, natural_frequency: float, ball_mode_frequency: float) -> float:
    """The damping ratio of the ball's mode: the scene's zeta scaled by ``f_b / f0``
    (stiffness-proportional damping, module notes)."""
    return zeta * ball_mode_frequency / natural_frequency


def transmission_change(frequency: np.ndarray, ball_mode: float, zeta_ball: float) -> np.ndarray:
    """``H(f) - 1`` of the module notes at each frequency [Hz] (complex)."""
    r = np.asarray(frequency, dtype=float) / ball_mode
    with np.errstate(invalid="ignore", divide="ignore"):  # r = 1 without damping: inf
        return r**2 / (1.0 + 2j * zeta_ball * r - r**2)


def power_sums(
    amplitude: np.ndarray, frequency: np.ndarray, ball_mode: float, zeta_ball: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(sum_k A_k^2, sum_k A_k^2 |H(f_k) - 1|^2)`` over the lines of spectra ``amplitude``
    (float[..., L], peak) at ``frequency`` (broadcast, Hz) above 0 Hz: the sums of the
    figure e, which add up over parts of a long spectrum (:func:`error_of`)."""
    amplitude = np.asarray(amplitude, dtype=float)
    frequency = np.broadcast_to(np.asarray(frequency, dtype=float), amplitude.shape)
    power = np.where(frequency > 0.0, amplitude**2, 0.0)
    change = np.abs(transmission_change(frequency, ball_mode, zeta_ball)) ** 2
    return power.sum(axis=-1), (power * change).sum(axis=-1)


def error_of(total: np.ndarray, changed: np.ndarray) -> np.ndarray:
    """The figure e from the two sums of :func:`power_sums`: NaN where ``total`` is 0 (no
    oscillation) or NaN (no ball mode: ``ball_mode`` NaN, a single sphere-plane)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.where(total > 0.0, changed / total, np.nan))


def warning_text(error: float, where: str, ball_mode: float) -> str:
    """The one line a run prints when its largest figure passes :data:`THRESHOLD`."""
    return (
        f"the response reaches the ball's own mode ({ball_mode / 1e3:.3g} kHz): its "
        f"estimated change of N/F_s is {100.0 * error:.2g} % at {where} (above "
        f"{100.0 * THRESHOLD:.2g} %); the one-degree-of-freedom model neglects it there"
    )


__all__ = [
    "THRESHOLD",
    "ball_damping",
    "check_periods",
    "error_of",
    "has_ball_mode",
    "power_sums",
    "transmission_change",
    "warning_text",
]
