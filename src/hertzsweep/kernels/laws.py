"""Damping laws as data: one small record type per law, its terms written once.

Eq. (8) and (11) of the paper, in the compression ``d = 1 + 2 q / 3`` the kernels
integrate (loss of contact when ``d <= 0``)::

    N/F_s = R(d) + c(d) q',   R(d) = [H(d) d]^(3/2),   c(d) = 2 zeta       (viscous)
                                                       c(d) = 2 zeta d^n H(d)  (contact)

A law is a module-level namedtuple; numba specialises every kernel on the law's type, so
the branches below are resolved at compile time (the viscous kernel has no branch on the
law and its ``1 / (1 + c h / 2)`` is a loop invariant) and the compiled kernels are cached
across processes. A new law is one more namedtuple and one more case in :func:`terms`,
:func:`slopes` and :func:`singular_exponent`.
"""

from __future__ import annotations

import math
from collections import namedtuple

from numba import types
from numba.extending import overload

Viscous = namedtuple("Viscous", ["twozeta"])
"""``f_d = 2 zeta q'`` at all times (eq. 8)."""

Contact = namedtuple("Contact", ["twozeta", "exponent", "by_contact", "by_root", "times_root"])
"""``f_d = 2 zeta d^n H(d) q'`` for n in {0, 1/2, 1, 3/2} (eq. 11), without ``pow``:
``c = 2 zeta m1 m2`` with ``m1`` in {H(d), sqrt(d), d} (``by_contact``, ``by_root``, else d)
and ``m2`` in {1, sqrt(d)} (``times_root``), written as selects so that many trajectories
vectorise."""

ContactPower = namedtuple("ContactPower", ["twozeta", "exponent"])
"""``f_d = 2 zeta d^n H(d) q'`` for any other n >= 0 (one ``pow`` per step)."""

LAWS = (Viscous, Contact, ContactPower)
SPECIAL_EXPONENTS = (0.0, 0.5, 1.0, 1.5)  # the paper's n: no pow


def make_law(law: str, zeta: float, exponent: float):
    """The record of a damping law: ``law`` is ``"viscous"`` or ``"contact"``."""
    twozeta = 2.0 * float(zeta)
    n = float(exponent)
    if law == "viscous":
        return Viscous(twozeta)
    if n in SPECIAL_EXPONENTS:
        return Contact(twozeta, n, n == 0.0, n == 0.5, n == 1.5)
    return ContactPower(twozeta, n)


def _law_class(law) -> type | None:
    """The namedtuple class of a numba type (None if it is none of :data:`LAWS`)."""
    if isinstance(law, types.BaseNamedTuple):
        cls = law.instance_class
        return cls if cls in LAWS else None
    return None


def terms(law, d):
    """``(sqrt(max(d, 0)), c(d))``: the root of the compression (``omega^2``, the local
    tangent stiffness, so ``R = d sqrt(d)``) and the damping coefficient (``f_d = c q'``)."""
    raise NotImplementedError("compiled only")


def slopes(law, d, root):
    """``(dR/dd, dc/dd)`` for the tangent-linear scheme; zero out of contact (the jump of
    c at d = 0 for n = 0 has measure zero along a trajectory)."""
    raise NotImplementedError("compiled only")


def singular_exponent(law):
    """The exponent n of the contact law's ``d^n`` (whose fractional powers are singular at
    ``d = 0``); -1 for a law whose damping does not depend on d."""
    raise NotImplementedError("compiled only")


@overload(singular_exponent, inline="always")
def _singular_exponent(law):
    cls = _law_class(law)
    if cls is Viscous:
        return lambda law: -1.0
    if cls is Contact or cls is ContactPower:
        return lambda law: law.exponent
    return None


@overload(terms, inline="always")
def _terms(law, d):
    cls = _law_class(law)
    if cls is Viscous:

        def viscous(law, d):
            # the root first, then the select: nothing but the root on the dependency
            # chain (one trajectory), no branch across trajectories (many); the root of a
            # negative d is a NaN that the select drops
            root = math.sqrt(d)
            return (root if d > 0.0 else 0.0), law.twozeta

        return viscous
    if cls is Contact:

        def contact(law, d):
            inside = d > 0.0
            compression = d if inside else 0.0
            root = math.sqrt(compression)
            m1 = (
                (1.0 if inside else 0.0)
                if law.by_contact
                else (root if law.by_root else compression)
            )
            m2 = root if law.times_root else 1.0
            return root, law.twozeta * m1 * m2

        return contact
    if cls is ContactPower:

        def power(law, d):
            if d > 0.0:
                return math.sqrt(d), law.twozeta * d**law.exponent
            return 0.0, 0.0

        return power
    return None


@overload(slopes, inline="always")
def _slopes(law, d, root):
    cls = _law_class(law)
    if cls is Viscous:

        def viscous(law, d, root):
            return 1.5 * root, 0.0

        return viscous
    if cls is Contact or cls is ContactPower:

        def contact(law, d, root):
            if d <= 0.0:
                return 0.0, 0.0
            n = law.exponent
            if n == 0.0:
                dc = 0.0
            elif n == 1.0:
                dc = law.twozeta
            elif n == 1.5:
                dc = law.twozeta * 1.5 * root
            elif n == 0.5:
                dc = law.twozeta * 0.5 / root
            else:
                dc = law.twozeta * n * d ** (n - 1.0)
            return 1.5 * root, dc

        return contact
    return None


__all__ = [
    "LAWS",
    "Contact",
    "ContactPower",
    "Viscous",
    "make_law",
    "singular_exponent",
    "slopes",
    "terms",
]
