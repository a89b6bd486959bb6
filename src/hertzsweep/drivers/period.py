"""The response's period: after how many excitation periods a dwell's state returns.

``periodic`` says whether the state returns after one period (:meth:`.oscillator.Block.read`).
Where it does not, the response may still be periodic with a longer period: a period
doubling (n = 2), a subharmonic of order n, or not periodic at all (quasi-periodic or
chaotic motion, or a transient still running). :func:`response_periods` finds the smallest
``n <= MAX_RESPONSE_PERIOD`` after which the state at the end of the dwell returns, 0 where
there is none: from a copy of that state, advanced one period at a time with the method's
own kernels (every trajectory of a block at once), compared with it with the relative
tolerance of ``periodic``. The state a sweep carries on and the readings are untouched: a
dwell that is periodic is n = 1 at no cost; the others cost at most
2 x :data:`MAX_RESPONSE_PERIOD` periods each. ``integration_steps`` counts the dwells' steps
only (what ``validate`` foresees and the budget bounds), not these: a run whose dwells all
repeat every period costs nothing more, one with N non-periodic dwells at most 16 N periods
more.
"""

from __future__ import annotations

import numpy as np

from ..kernels import scheme
from .oscillator import Block, Oscillator, drive

MAX_RESPONSE_PERIOD = 8  # the longest period looked for, in excitation periods
NONE = 0  # response_period where the state does not return within MAX_RESPONSE_PERIOD
APART = 10.0  # a period n > 1 is read only where the state after one period lies at least
# this many times the tolerance of ``periodic`` from its start: nearer, the dwell is a
# period-1 response still settling (a decaying transient whose frequency is commensurate
# with the excitation's, as from rest, returns within the tolerance after a few periods)


def response_periods(
    oscillator: Oscillator, block: Block, sigma: np.ndarray, h: np.ndarray
) -> np.ndarray:
    """int8[T]: the response period of each trajectory of ``block`` (1 where ``periodic``).

    Parameters
    ----------
    oscillator : Oscillator
        Of the scene (its method, law and the tolerance of ``periodic``).
    block : Block
        The readings of T dwells and their end states ``end``.
    sigma, h : float[T]
        The input level and the step of each dwell.

    The state ``x_0`` at the end of a dwell is advanced up to 16 periods (fewer once every
    trajectory's answer is known); it returns after
    k periods where ``max |x_k - x_0|`` (over the state's members, the ball's too) lies
    below ``tolerance`` times the scale of ``periodic`` (the larger of ``|q|``, ``|q_prev|``
    and half the force's peak-to-peak range). n is the smallest n = 2 ... 8 for which it
    returns after n and after 2n periods (a decaying transient may come back once by the
    chance of its phase, a periodic response comes back every n). A dwell that is not
    ``periodic`` yet returns after one period here, or lies within :data:`APART` times the
    tolerance after one period, is a period-1 response still settling: 0, as for none.

    Raises
    ------
    Interrupted
        A stop was requested (SIGINT) while advancing.
    """
    periodic = np.asarray(block.periodic, dtype=bool)
    out = np.where(periodic, 1, NONE).astype(np.int8)
    check = np.flatnonzero(~periodic & np.all(np.isfinite(_flat(block.end)), axis=1))
    if check.size == 0:
        return out
    start = np.asarray(block.end[check], dtype=float)  # (T, 2[, 2]): (q_prev, q)[, body]
    main = start[:, :, 0] if start.ndim == 3 else start
    half_range = 0.5 * (block.force_max[check] - block.force_min[check])
    scale = np.maximum(np.abs(main).max(axis=1), np.maximum(half_range, 1e-300))
    q_prev, q = start[:, 0].copy(), start[:, 1].copy()
    steps = np.asarray(h, dtype=float)[check].copy()
    kernels = drive(oscillator.scene, np.asarray(sigma, dtype=float)[check])
    returns = np.zeros((2 * MAX_RESPONSE_PERIOD + 1, check.size), dtype=bool)
    found = np.zeros(check.size, dtype=np.int8)  # the smallest n returning at n and 2n
    settling = np.ones(check.size, dtype=bool)  # until one period is read: no period known
    for p in range(1, 2 * MAX_RESPONSE_PERIOD + 1):
        status, _ = oscillator.method.advance_batch(q_prev, q, steps, oscillator.law, kernels, 1)
        if status == scheme.STOPPED:
            scheme.check_status(status, oscillator.sigma, float("nan"), 0)
        if status != scheme.OK:  # beyond the dwell's reach: no return to read
            break
        now = np.stack([q_prev, q], axis=1)
        relative = _flat(np.abs(now - start)).max(axis=1) / scale
        returns[p] = relative < oscillator.periodic_tolerance
        if p == 1:  # after one period: clearly not period 1, or a transient (NONE)
            settling = returns[1] | (relative < APART * oscillator.periodic_tolerance)
        elif p % 2 == 0:
            found[(found == 0) & returns[p // 2] & returns[p]] = p // 2
        if np.all(settling | (found > 0)):
            break  # every trajectory's answer is known
    found[settling] = NONE  # near period 1, not periodic when read: a transient
    out[check] = found
    return out


def _flat(states: np.ndarray) -> np.ndarray:
    """States float[T, 2(, 2)] as rows float[T, 2 or 4]."""
    states = np.asarray(states, dtype=float)
    return states.reshape(states.shape[0], -1)


__all__ = ["MAX_RESPONSE_PERIOD", "NONE", "response_periods"]
