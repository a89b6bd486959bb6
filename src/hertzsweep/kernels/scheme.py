"""The paper's explicit central-difference scheme: one step, written once.

Scheme (section 4.3 of the paper) for eq. (8)/(11), step h in tau, ``c_n = c(q_n)``::

    (q[n+1] - 2 q[n] + q[n-1]) / h^2 + c_n (q[n+1] - q[n-1]) / (2 h) + R(q[n]) = 1 + f_n

The damping term is centred, so the update stays explicit (linear in ``q[n+1]``) and
second order where the force is smooth. The kernels carry the compression
``d = 1 + 2 q / 3`` rather than q: with ``R = d sqrt(d)`` the update multiplied by
``2 h^2 / 3`` reads

    d[n+1] = a d[n] - b d[n-1] + k F_n - k d[n] sqrt(d[n])
    a = 2 / D,  b = (1 - c h / 2) / D,  k = (2 h^2 / 3) / D,  D = 1 + c h / 2,  F_n = 1 + f_n

evaluated as ``fma(-(k d), sqrt(d), fma(d, a, k F - b d[n-1]))``: the square root and one
FMA are all that lies on the step-to-step dependency chain (everything else is computed
alongside the root); a, b, k are computed once per step size for a law with a constant
c (viscous, :func:`make_step`). Where c varies with the state, the numerator is formed first
and divided once, last (:func:`update`).

Every path (one trajectory, many trajectories, the tangent-linear map) calls
:func:`update` with the same operands in the same order, so they agree bit for bit.

Kernel status codes and their messages are the one table :data:`STATUS`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic, overload

from ..errors import IntegrationError, Interrupted, StabilityError
from . import CACHE
from .laws import Viscous, _law_class
from .stop import REQUEST

OK = 0
NON_FINITE = 1
UNSTABLE = 2
STOPPED = 3  # a signal asked the run to stop (:mod:`.stop`); raised as Interrupted
STATUS = {  # code -> (error raised, message; {sigma}, {w}, {steps} are filled in)
    NON_FINITE: (IntegrationError, "the state became non-finite at sigma = {sigma:g}, w = {w:g}"),
    UNSTABLE: (
        StabilityError,
        "solver.steps_per_period: {steps} is beyond the stability limit at the compression "
        "reached (sigma = {sigma:g}, w = {w:g}); raise it",
    ),
}


def check_status(status: int, sigma: float, frequency_ratio: float, steps: int) -> None:
    """Raise the error that a kernel status means (nothing for :data:`OK`)."""
    if status == STOPPED:
        raise Interrupted(None, int(REQUEST[0]) or 2)  # SIGINT when not known
    if status != OK:
        error, message = STATUS[status]
        raise error(message.format(sigma=sigma, w=frequency_ratio, steps=steps))


Step = namedtuple("Step", ["h", "half_h", "c0", "rate", "limit", "fixed"])
"""Constants of one step size h (floats, or arrays of one per trajectory): ``h / 2``,
``c0 = 2 h^2 / 3``, ``rate = 3 / (4 h)`` (``q' = rate (d[n+1] - d[n-1])``), the stability
``limit = 4 / h^2`` on ``sqrt(d) = omega^2`` (``h omega < 2``), and ``fixed = (a, b, k)``
for a law with a constant c."""


@intrinsic
def fma(typingctx, a, b, c):
    """``a b + c`` rounded once (LLVM's ``llvm.fma``: one instruction where the CPU has
    FMA, and the same in scalar and vector code)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        double = ir.DoubleType()
        fnty = ir.FunctionType(double, [double, double, double])
        fn = builder.module.declare_intrinsic("llvm.fma", [double], fnty)
        return builder.call(fn, args)

    return sig, codegen


@njit(cache=CACHE, inline="always")
def to_compression(q):
    """``d = 1 + 2 q / 3``."""
    return 1.0 + q * (2.0 / 3.0)


@njit(cache=CACHE, inline="always")
def to_displacement(d):
    """``q = 3 (d - 1) / 2``."""
    return (d - 1.0) * 1.5


@njit(cache=CACHE)
def coefficients(c, half_h, c0):
    """``(a, b, k)`` of the update for a constant damping coefficient c (see the module
    docstring)."""
    inv = 1.0 / (1.0 + c * half_h)
    return 2.0 * inv, (1.0 - c * half_h) * inv, c0 * inv


def update(law, d_prev, d, root, c, load, constants):
    """``d[n+1]`` from ``d[n-1]``, ``d[n]``, ``sqrt(d[n])``, ``c(d[n])``, the load
    ``F_n = 1 + f_n`` and the step's ``constants = (h/2, c0, a, b, k)`` (:func:`constants`):
    the one update of the scheme."""
    raise NotImplementedError("compiled only")


@overload(update, inline="always")
def _update(law, d_prev, d, root, c, load, constants):
    if _law_class(law) is Viscous:

        def constant(law, d_prev, d, root, c, load, constants):
            # a, b, k computed once per step size: the root and one FMA on the chain
            _, _, a, b, k = constants
            return fma(-(k * d), root, fma(d, a, k * load - d_prev * b))

        return constant

    def varying(law, d_prev, d, root, c, load, constants):
        # (2 d - d[n-1] (1 - c h/2) + c0 (F - d sqrt d)) / (1 + c h/2): one division, last
        half_h, c0, _, _, _ = constants
        ch = c * half_h
        return fma(ch, d_prev, fma(-(c0 * d), root, 2.0 * d - d_prev + c0 * load)) / (1.0 + ch)

    return varying


@njit(cache=CACHE)
def make_step(law, h):
    """The :class:`Step` of step size h."""
    half_h = 0.5 * h
    c0 = h * h * (2.0 / 3.0)
    return Step(h, half_h, c0, 0.75 / h, 4.0 / (h * h), coefficients(law.twozeta, half_h, c0))


@njit(cache=CACHE, inline="always")
def constants(s, t):
    """The update's ``(h/2, c0, a, b, k)`` of trajectory t of a :class:`Step` of arrays."""
    a, b, k = s.fixed
    return s.half_h[t], s.c0[t], a[t], b[t], k[t]


@njit(cache=CACHE, inline="always")
def constant(s):
    """The update's ``(h/2, c0, a, b, k)`` of a :class:`Step` of floats."""
    a, b, k = s.fixed
    return s.half_h, s.c0, a, b, k


@njit(cache=CACHE)
def make_steps(law, h):
    """The :class:`Step` of T trajectories (a field per column of ``float[8, T]``)."""
    out = np.empty((8, h.shape[0]))
    for t in range(h.shape[0]):
        s = make_step(law, h[t])
        a, b, k = s.fixed
        out[0, t], out[1, t], out[2, t], out[3, t] = s.h, s.half_h, s.c0, s.rate
        out[4, t], out[5, t], out[6, t], out[7, t] = s.limit, a, b, k
    return Step(out[0], out[1], out[2], out[3], out[4], (out[5], out[6], out[7]))


@njit(cache=CACHE)
def compressions(q):
    """``d = 1 + 2 q / 3`` of every trajectory (a new array)."""
    d = np.empty_like(q)
    for t in range(q.shape[0]):
        d[t] = to_compression(q[t])
    return d


@njit(cache=CACHE)
def displacements(d, out):
    """``q = 3 (d - 1) / 2`` of every trajectory, into ``out``."""
    for t in range(d.shape[0]):
        out[t] = to_displacement(d[t])


@njit(cache=CACHE, inline="always")
def forcing(sigma, sin_phase):
    """``F_n = 1 + sigma sin(w tau_n)``: the load over F_s."""
    return 1.0 + sigma * sin_phase


def period_tables(steps_per_period: int) -> tuple[np.ndarray, np.ndarray]:
    """``sin(2 pi j / N)`` and ``cos(2 pi j / N)`` for j = 0 .. N-1."""
    phase = 2.0 * np.pi * np.arange(steps_per_period) / steps_per_period
    return np.sin(phase), np.cos(phase)


def step_size(frequency_ratio: float, steps_per_period: int) -> float:
    """h in tau for N steps per excitation period ``2 pi / w``."""
    return 2.0 * math.pi / (frequency_ratio * steps_per_period)


__all__ = [
    "NON_FINITE",
    "OK",
    "STATUS",
    "STOPPED",
    "UNSTABLE",
    "Step",
    "check_status",
    "compressions",
    "constant",
    "constants",
    "displacements",
    "make_steps",
    "coefficients",
    "fma",
    "forcing",
    "make_step",
    "period_tables",
    "step_size",
    "to_compression",
    "to_displacement",
    "update",
]
