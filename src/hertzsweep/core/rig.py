"""Derived constants of the rig: eq. (2), (3), (12), (15) of the paper, and Hertz theory.

Notes
-----
Double sphere-plane, identical materials (the paper's rig), eq. (12):
``k = E sqrt(R) / (3 sqrt(2) (1 - nu^2))``: two sphere-plane contacts in series, each
``F = k1 delta^(3/2)`` with ``k1 = 4/3 E* sqrt(R)``, ``E* = E / (2 (1 - nu^2))``, so the
moving mass sees ``z = 2 delta`` and ``k = k1 / 2^(3/2)``.
Single sphere-plane: ``k = k1``.

Eq. (2): ``z_s = (F_s / k)^(2/3)``; eq. (3): ``Omega^2 = 3 k / (2 m) z_s^(1/2)``;
eq. (15): ``f0 = Omega / 2 pi``.

Static Hertz contact (each sphere-plane contact carries F_s): contact radius
``a = sqrt(R delta_s)``, peak pressure ``p0 = 3 F_s / (2 pi a^2)``.

The ball's own mode (the paper's second natural frequency, section 3.1) is the upper
eigenfrequency of the two-degree-of-freedom system linearised about the static load:
moving mass m on the ball (mass m_b), the ball between two contacts of tangent
stiffness ``k_t = 3/2 k1 delta^(1/2)``, the upper one at ``k1 delta^(3/2) = F_s``, the
lower one at ``F_s + m_b g`` (its weight: 0.6 % of F_s on the paper's rig, 0.2 % on its
stiffness). It is not defined for a single sphere-plane.

With the paper's E = 210 GPa, nu = 0.29, R = 12.7 mm this gives k = 6.09e9 N m^-3/2;
the paper prints 5.98e9, which E = 206 GPa gives. We report our value.

A measured natural frequency (``rig.natural_frequency``, f0) replaces the Hertz value:
``Omega = 2 pi f0``, and eq. (2) and (3) are solved for the contact stiffness that gives
that Omega with the rig's m and F_s: ``Omega^2 = 3/(2m) k^(2/3) F_s^(1/3)``, so
``k = (2 m Omega^2 / 3)^(3/2) / F_s^(1/2)`` and ``z_s = (F_s / k)^(2/3) = 3 F_s / (2 m
Omega^2)``. The Hertz values stay available (``hertz_contact_stiffness``,
``hertz_natural_frequency``); the static contact pressure and radius and the ball's mode
remain Hertz estimates from E, nu and R (a measured f0 does not separate them).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .config import GRAVITY, RigConfig


@dataclass(frozen=True)
class RigConstants:
    """Derived constants, SI units.

    Attributes
    ----------
    contact_stiffness : [N m^-3/2] k of eq. (1).
    static_compression : [m] z_s, eq. (2).
    natural_circular_frequency : [rad s^-1] Omega, eq. (3).
    natural_frequency : [Hz] f0, eq. (15).
    static_load : [N] F_s.
    contact_pressure : [Pa] static peak Hertz pressure p0 of one contact.
    contact_radius : [m] static contact radius a of one contact.
    ball_mode_frequency : [Hz] estimate of the ball's own mode (NaN for sphere-plane).
    hertz_contact_stiffness : [N m^-3/2] k of eq. (12) from E, nu and R (equal to
        ``contact_stiffness`` unless the rig gives a measured ``natural_frequency``).
    hertz_natural_frequency : [Hz] f0 of eq. (15) with the Hertz k.
    """

    contact_stiffness: float
    static_compression: float
    natural_circular_frequency: float
    natural_frequency: float
    static_load: float
    contact_pressure: float
    contact_radius: float
    ball_mode_frequency: float
    hertz_contact_stiffness: float
    hertz_natural_frequency: float

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


UNITS = {
    "contact_stiffness": "N m-3/2",
    "static_compression": "m",
    "natural_circular_frequency": "rad s-1",
    "natural_frequency": "Hz",
    "static_load": "N",
    "contact_pressure": "Pa",
    "contact_radius": "m",
    "ball_mode_frequency": "Hz",
    "hertz_contact_stiffness": "N m-3/2",
    "hertz_natural_frequency": "Hz",
}


def effective_modulus(youngs_modulus: float, poisson_ratio: float) -> float:
    """E* [Pa] of two bodies of the same material: ``E / (2 (1 - nu^2))``."""
    return youngs_modulus / (2.0 * (1.0 - poisson_ratio**2))


def sphere_plane_stiffness(rig: RigConfig) -> float:
    """k1 [N m^-3/2] of one sphere-plane contact: ``4/3 E* sqrt(R)``."""
    return (
        4.0
        / 3.0
        * effective_modulus(rig.youngs_modulus, rig.poisson_ratio)
        * math.sqrt(rig.ball_radius)
    )


def contact_stiffness(rig: RigConfig) -> float:
    """k [N m^-3/2] seen by the moving mass: eq. (12) or the single contact's k1."""
    k1 = sphere_plane_stiffness(rig)
    return k1 / 2.0**1.5 if rig.geometry == "double-sphere-plane" else k1


def circular_frequency(k: float, mass: float, load: float) -> float:
    """Omega [rad s^-1] of eq. (3) with z_s of eq. (2): ``sqrt(3 k / (2 m) z_s^(1/2))``."""
    z_s = (load / k) ** (2.0 / 3.0)  # eq. (2)
    return math.sqrt(1.5 * k / mass * math.sqrt(z_s))


def stiffness_for_frequency(frequency: float, mass: float, load: float) -> float:
    """The contact stiffness k [N m^-3/2] whose Omega (eq. 2, 3) is ``2 pi frequency``
    [Hz] for the mass [kg] and static load [N]: ``(2 m Omega^2 / 3)^(3/2) / F_s^(1/2)``."""
    omega = 2.0 * math.pi * frequency
    return (2.0 * mass * omega**2 / 3.0) ** 1.5 / math.sqrt(load)


def derive(rig: RigConfig) -> RigConstants:
    """All derived constants of a rig (eq. 2, 3, 12, 15 and Hertz theory); with a measured
    ``rig.natural_frequency``, k, z_s and Omega are those of that f0 (module notes)."""
    load = float(rig.static_load)
    hertz_k = contact_stiffness(rig)
    hertz_omega = circular_frequency(hertz_k, rig.mass, load)
    if rig.natural_frequency is None:
        k, omega = hertz_k, hertz_omega
        f0 = omega / (2.0 * math.pi)  # eq. (15)
    else:  # the measured f0 itself; k from eq. (2), (3)
        f0 = float(rig.natural_frequency)
        k = stiffness_for_frequency(f0, rig.mass, load)
        omega = 2.0 * math.pi * f0
    z_s = (load / k) ** (2.0 / 3.0)  # eq. (2)
    k1 = sphere_plane_stiffness(rig)
    delta = (load / k1) ** (2.0 / 3.0)  # compression of one sphere-plane contact
    radius = math.sqrt(rig.ball_radius * delta)
    pressure = 3.0 * load / (2.0 * math.pi * radius**2)
    if rig.geometry == "double-sphere-plane":
        m, mb = rig.mass, float(rig.ball_mass)
        upper = 1.5 * k1 * math.sqrt(delta)
        # the lower contact carries the ball's weight too: F_s + m_b g
        lower = 1.5 * k1 * math.sqrt(((load + mb * GRAVITY) / k1) ** (2.0 / 3.0))
        stiffness = np.array([[upper, -upper], [-upper, upper + lower]])
        inv_sqrt_mass = np.diag([1.0 / math.sqrt(m), 1.0 / math.sqrt(mb)])
        eig = np.linalg.eigvalsh(inv_sqrt_mass @ stiffness @ inv_sqrt_mass)
        ball_mode = math.sqrt(eig[-1]) / (2.0 * math.pi)
    else:
        ball_mode = math.nan
    return RigConstants(
        contact_stiffness=k,
        static_compression=z_s,
        natural_circular_frequency=omega,
        natural_frequency=f0,
        static_load=load,
        contact_pressure=pressure,
        contact_radius=radius,
        ball_mode_frequency=ball_mode,
        hertz_contact_stiffness=hertz_k,
        hertz_natural_frequency=hertz_omega / (2.0 * math.pi),
    )
