"""The two-degree-of-freedom model: the moving mass on the ball, the ball between two
Hertz contacts (``[model] kind = "ball"``).

Dimensional model (z1: the moving mass m, z2: the ball m_b, both downward)::

    m   z1'' = F_s + F(t) - P_u - D_u
    m_b z2'' = m_b g + P_u + D_u - P_l - D_l
    P = k1 [H(delta) delta]^(3/2),  delta_u = delta_u0 + z1 - z2,  delta_l = delta_l0 + z2

with ``k1 delta_u0^(3/2) = F_s`` and ``k1 delta_l0^(3/2) = F_s + m_b g``. The transducer
under the lower disc reads ``N = P_l + D_l``.

Scaling. Time is the single model's ``tau = Omega t`` (Omega of eq. 3 with the double
contact's k of eq. 12, or of a measured f0), so w = f / f0 is the same frequency ratio.
Each contact carries its own compression over its static one, ``u = delta_u /
delta_u0`` and ``l = delta_l / delta_l0``, so that its force is ``F_s u^(3/2)`` and
``F_s L l^(3/2)`` with ``L = 1 + m_b g / F_s``; displacements are reported in the single
model's q (``q = 3 z / (2 z_s)``, z_s of eq. 2). The contacts' k1 is the one the scene's
k implies, ``k1 = 2^(3/2) k`` (eq. 12), so ``delta_u0 = z_s / 2``: the geometric factors
are ``a_u = delta_u0 / z_s = 1/2`` and ``a_l = delta_l0 / z_s = L^(2/3) / 2``. Dividing
the equations by F_s (``m z_s Omega^2 / F_s = 3/2``)::

    3/2 (a_u u'' + a_l l'')  = 1 + sigma sin(w tau) - R(u) - 3 a_u c(u) u'
    3/2 mu a_l l''            = L - 1 + R(u) + 3 a_u c(u) u' - L R(l) - 3 a_l c(l) l'

with ``R(d) = [H(d) d]^(3/2)``, ``mu = m_b / m`` and c(d) the scene's damping law as in
the single model (``2 zeta`` viscous, ``2 zeta d^n H(d)`` contact), each contact on its
own compression rate.

Damping. Each contact is a Hertz spring with a dashpot ``c_c`` (times ``(delta /
delta_0)^n H(delta)`` under the contact law). With m_b -> 0 the two contacts are in
series and carry the same force; two equal Kelvin-Voigt elements (same spring k_c, same
dashpot c_c) in series are exactly one element of spring ``k_c / 2`` and dashpot ``c_c /
2`` (the same ratio c / k), so the single model's dashpot c, whose damping ratio is zeta
on eq. (8), is ``c_c / 2``: ``c_c = 2 c``. In the scaled equations that is the factor
``3 a_u c(u)`` above, which with ``a_u = 1/2`` and ``u = d`` is the single model's
``3/2 c(d) d' = c(d) q'``. As m_b -> 0 the equations reduce to eq. (8)/(11) exactly
(``l = u = d``, both contacts carrying N).

Linearised about the static state (u = l = 1) the undamped stiffnesses, in units of
``m Omega^2``, are ``kappa_u = sqrt(u) / a_u`` and ``kappa_l = L sqrt(l) / a_l``, and the
squared circular frequencies (over Omega^2) solve ``mu W^2 - (kappa_u (1 + mu) + kappa_l)
W + kappa_u kappa_l = 0``; the larger root is the ball's own mode, the same
linearisation as :func:`hertzsweep.core.rig.derive`'s ``ball_mode_frequency`` (with
Hertz's k). The explicit scheme is stable while ``h W_max^(1/2) < 2``; W_max grows with
both compressions, so the kernels check it at the largest ``sqrt(u)`` and ``sqrt(l)``
reached (a bound: they need not peak together), and :func:`stability_frequency` gives the
preflight's estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .config import GRAVITY, Scene
from .rig import derive


@dataclass(frozen=True)
class BallModel:
    """The scaled constants of the ball model (module docstring)."""

    upper: float  # a_u = delta_u0 / z_s
    lower: float  # a_l = delta_l0 / z_s
    load: float  # L = (F_s + m_b g) / F_s, the lower contact's static load over F_s
    mass_ratio: float  # mu = m_b / m

    @classmethod
    def of(cls, scene: Scene) -> BallModel:
        """The ball model of a scene's rig."""
        rig = scene.rig
        load = 1.0 + float(rig.ball_mass) * GRAVITY / float(rig.static_load)
        return cls(0.5, 0.5 * load ** (2.0 / 3.0), load, float(rig.ball_mass) / rig.mass)

    def stiffnesses(self, root_u: float, root_l: float) -> tuple[float, float]:
        """``(kappa_u, kappa_l)`` at ``sqrt(u)``, ``sqrt(l)``, in units of ``m Omega^2``."""
        return root_u / self.upper, self.load * root_l / self.lower

    def squared_frequencies(self, root_u: float = 1.0, root_l: float = 1.0):
        """``(W_1, W_2)``: the squared circular frequencies over Omega^2, linearised at the
        compressions whose roots are given (default: static)."""
        ku, kl = self.stiffnesses(root_u, root_l)
        mu = self.mass_ratio
        b = ku * (1.0 + mu) + kl
        disc = math.sqrt(b * b - 4.0 * mu * ku * kl)
        high = (b + disc) / (2.0 * mu)
        return ku * kl / (mu * high), high

    def ball_mode(self) -> float:
        """The ball's own mode over f0 (the linearised second frequency at rest)."""
        return math.sqrt(self.squared_frequencies()[1])

    def stability_frequency(self, force: float) -> float:
        """The largest local circular frequency over Omega with both contacts compressed
        to carry ``force`` times their static load (``sqrt(d) = force^(1/3)``)."""
        root = max(force, 0.0) ** (1.0 / 3.0)
        return math.sqrt(self.squared_frequencies(root, root)[1])


def ball_mode_hertz(scene: Scene) -> float:
    """The ball model's own mode [Hz] on the scene's rig: ``f0`` times
    :meth:`BallModel.ball_mode`."""
    return derive(scene.rig).natural_frequency * BallModel.of(scene).ball_mode()


__all__ = ["BallModel", "ball_mode_hertz"]
