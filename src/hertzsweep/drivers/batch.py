"""Many trajectories in one compiled loop: the sweeps of a scene advanced in lockstep.

A scene's stepped-sine sweeps (every direction x sigma) are independent trajectories of
the same scheme (section 4.3 of the paper, eq. 8 and 11) with the same steps per period N
and damping law; they differ only in the input level sigma and, at a given dwell, in the
frequency (up and down walk the grid in opposite orders), hence in the step h. With a
fixed number of settling periods every dwell has the same number of steps, so all
trajectories can dwell together: the kernels below keep one state per trajectory in
contiguous arrays and put the trajectory index innermost, with branch-free selects for
contact / no contact, so that LLVM vectorises across trajectories (the one-trajectory
loop is bound by the latency of a square root and a division per step; T trajectories
hide it).

Each trajectory performs exactly the floating-point operations of
:func:`hertzsweep.integrators.advance` / :func:`~hertzsweep.integrators.measure` in the
same order (no fast-math, no reassociation), so :func:`run_sweep_batched` gives the
numbers of :func:`hertzsweep.sweep.run_sweep` bit for bit.

``settle_periods = "auto"`` (every trajectory settles in its own number of blocks) and
``steady_state = "shooting"`` do not fit lockstep: :func:`run_sweep_batched` then runs
the trajectories one after another with :func:`~hertzsweep.sweep.run_sweep`.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from typing import Any

import numpy as np
from numba import njit

from ..core.config import Scene, scene_from_dict
from ..core.model import (
    CONTACT_GENERAL,
    CONTACT_N0,
    CONTACT_N05,
    CONTACT_N15,
    VISCOUS,
    check_stability,
)
from ..core.model import contact_terms as _contact_terms
from ..errors import HertzsweepError, Interrupted
from ..kernels import integrators
from ..kernels.integrators import NON_FINITE, OK, UNSTABLE, _next, _next_viscous, restart
from .oscillator import Oscillator, Reading, combine_readings, readings_agree
from .sweep import Progress, SweepResult, find_jump, run_sweep, sweep_order

_NOT_VISCOUS = -1  # a law code that is not VISCOUS, for the division form of _next
_SUMS = 7  # per block: total, force_max, force_min, q_prev_last, q_last, q_prev, q
_COUNTS = 4  # per block: loss_steps, longest, lead, trail (flight runs, in steps)


# --------------------------------------------------------------------------- kernels
@njit(cache=True, inline="always")
def _select_terms(q, twozeta, by_contact, by_root, times_root):
    """``(d, sqrt(d), R - 1, c)`` of the contact laws n = 0, 1/2, 1, 3/2 with selects in
    place of branches (vectorisable across trajectories): ``c = 2 zeta m1 m2`` with
    ``m1`` in {H(d), sqrt(d), d} and ``m2`` in {1, sqrt(d)}."""
    d = 1.0 + q * (2.0 / 3.0)
    compression = d if d > 0.0 else 0.0
    sd = math.sqrt(compression)
    contact = 1.0 if d > 0.0 else 0.0
    m1 = contact if by_contact else (sd if by_root else compression)
    m2 = sd if times_root else 1.0
    return d, sd, compression * sd - 1.0, twozeta * m1 * m2


@njit(cache=True, error_model="numpy")
def _advance_viscous(q_prev, q, h2, damp_prev, inv_viscous, peak, sigma, sin_table, periods):
    """Whole periods, viscous law: the update of ``integrators._next_viscous``."""
    trajectories = q.shape[0]
    n = sin_table.shape[0]
    for _ in range(periods):
        for j in range(n):
            s = sin_table[j]
            for t in range(trajectories):
                qt = q[t]
                d = 1.0 + qt * (2.0 / 3.0)
                sd = math.sqrt(d) if d > 0.0 else 0.0
                peak[t] = sd if sd > peak[t] else peak[t]
                q_next = _next_viscous(
                    q_prev[t], qt, sigma[t] * s, d, sd, h2[t], damp_prev[t], inv_viscous[t]
                )
                q_prev[t] = qt
                q[t] = q_next


@njit(cache=True, error_model="numpy")
def _advance_contact(q_prev, q, h2, half_h, peak, sigma, sin_table, periods, zeta, law):
    """Whole periods, contact law n in {0, 1/2, 1, 3/2} (eq. 11) without branches:
    ``c = 2 zeta m1 m2`` with ``(m1, m2)`` = ``(H(d), 1)``, ``(sqrt d, 1)``, ``(d, 1)``,
    ``(d, sqrt d)``, the products of ``model.contact_terms`` in the same order."""
    trajectories = q.shape[0]
    n = sin_table.shape[0]
    twozeta = 2.0 * zeta
    by_contact = law == CONTACT_N0
    by_root = law == CONTACT_N05
    times_root = law == CONTACT_N15
    for _ in range(periods):
        for j in range(n):
            s = sin_table[j]
            for t in range(trajectories):
                qt = q[t]
                d, sd, rm1, c = _select_terms(qt, twozeta, by_contact, by_root, times_root)
                peak[t] = sd if sd > peak[t] else peak[t]
                q_next = _next(
                    q_prev[t], qt, sigma[t] * s, rm1, c, h2[t], half_h[t], _NOT_VISCOUS, 0.0
                )
                q_prev[t] = qt
                q[t] = q_next


@njit(cache=True, error_model="numpy")
def _advance_general(q_prev, q, h2, half_h, peak, sigma, sin_table, periods, zeta, exponent):
    """Whole periods, contact law with any other exponent (one ``pow`` per step)."""
    trajectories = q.shape[0]
    n = sin_table.shape[0]
    for _ in range(periods):
        for j in range(n):
            s = sin_table[j]
            for t in range(trajectories):
                qt = q[t]
                d, sd, rm1, c = _contact_terms(qt, zeta, CONTACT_GENERAL, exponent)
                peak[t] = sd if sd > peak[t] else peak[t]
                q_next = _next(
                    q_prev[t], qt, sigma[t] * s, rm1, c, h2[t], half_h[t], _NOT_VISCOUS, 0.0
                )
                q_prev[t] = qt
                q[t] = q_next


@njit(cache=True)
def _status(q_prev, q, peak, limit):
    """``(status, trajectory)`` after a period: UNSTABLE if ``h^2 omega^2 >= 4`` was
    reached (``omega^2 = sqrt d``), NON_FINITE if the state is not finite."""
    for t in range(q.shape[0]):
        if peak[t] >= limit[t]:
            return UNSTABLE, t
    for t in range(q.shape[0]):
        if not (math.isfinite(q[t]) and math.isfinite(q_prev[t])):
            return NON_FINITE, t
    return OK, -1


@njit(cache=True, error_model="numpy")
def advance_batch(q_prev, q, h, sigma, sin_table, periods, zeta, law, exponent):
    """Integrate whole periods of T trajectories together, without measuring.

    Parameters
    ----------
    q_prev, q : float64[T]
        The states ``(q[n-1], q[n])``, advanced in place.
    h : float64[T]
        Step of each trajectory in tau.
    sigma : float64[T]
        Input level of each trajectory.
    sin_table : float64[N]
        ``sin(2 pi j / N)``: every trajectory has N steps per period.
    periods : int
    zeta, law, exponent
        Damping ratio, law code, exponent n (shared).

    Returns
    -------
    tuple
        ``(status, trajectory)``: OK and -1, or the first trajectory that went
        unstable or non-finite (checked at the end of each period).
    """
    h2 = h * h
    half_h = 0.5 * h
    inv_viscous = 1.0 / (1.0 + 2.0 * zeta * half_h)
    damp_prev = 1.0 - 2.0 * zeta * half_h
    limit = 4.0 / h2  # h^2 omega^2 < 4, omega^2 = sqrt(d)
    peak = np.zeros_like(q)
    for _ in range(periods):
        if law == VISCOUS:
            _advance_viscous(q_prev, q, h2, damp_prev, inv_viscous, peak, sigma, sin_table, 1)
        elif law == CONTACT_GENERAL:
            _advance_general(q_prev, q, h2, half_h, peak, sigma, sin_table, 1, zeta, exponent)
        else:
            _advance_contact(q_prev, q, h2, half_h, peak, sigma, sin_table, 1, zeta, law)
        status, t = _status(q_prev, q, peak, limit)
        if status != OK:
            return status, t
    return OK, -1


@njit(cache=True, error_model="numpy")
def measure_batch(
    q_prev, q, h, sigma, sin_table, cos_table, periods, zeta, law, exponent, harmonics,
    coefficients, sums, counts,
):  # fmt: skip
    """Integrate whole periods of T trajectories and read them like
    :func:`hertzsweep.integrators.measure` reads one.

    Parameters
    ----------
    coefficients : float64[K, 2, T]
        Output: ``sum (N/F_s - 1) cos(k theta_j)``, ``sum (N/F_s - 1) sin(k theta_j)``.
    sums : float64[7, T]
        Output: ``sum (N/F_s - 1)``, ``max N/F_s``, ``min N/F_s``, the state at the start
        of the last period ``(q_prev, q)``, and the state at the end ``(q_prev, q)``.
    counts : int64[4, T]
        Output: steps out of contact, the longest inner flight, the leading and the
        trailing flight run (steps), as ``integrators.measure`` returns them.

    Returns
    -------
    tuple
        ``(status, trajectory)`` as :func:`advance_batch`.
    """
    trajectories = q.shape[0]
    n = sin_table.shape[0]
    n_harm = harmonics.shape[0]
    h2 = h * h
    half_h = 0.5 * h
    inv_viscous = 1.0 / (1.0 + 2.0 * zeta * half_h)
    damp_prev = 1.0 - 2.0 * zeta * half_h
    inv_2h = 1.0 / (2.0 * h)
    limit = 4.0 / h2
    twozeta = 2.0 * zeta
    viscous = law == VISCOUS
    general = law == CONTACT_GENERAL
    by_contact = law == CONTACT_N0
    by_root = law == CONTACT_N05
    times_root = law == CONTACT_N15
    peak = np.zeros(trajectories)
    excess = np.zeros(trajectories)
    index = np.zeros(n_harm, dtype=np.int64)
    cos_k = np.zeros(n_harm)
    sin_k = np.zeros(n_harm)
    coefficients[:, :, :] = 0.0
    total = sums[0]
    force_max = sums[1]
    force_min = sums[2]
    total[:] = 0.0
    force_max[:] = -np.inf
    force_min[:] = np.inf
    loss = counts[0]
    longest = counts[1]
    lead = counts[2]
    run = counts[3]
    loss[:] = 0
    longest[:] = 0
    lead[:] = -1
    run[:] = 0
    sums[3, :] = q_prev
    sums[4, :] = q
    for p in range(periods):
        if p == periods - 1:
            sums[3, :] = q_prev
            sums[4, :] = q
        index[:] = 0
        for j in range(n):
            s = sin_table[j]
            for i in range(n_harm):
                cos_k[i] = cos_table[index[i]]
                sin_k[i] = sin_table[index[i]]
            for t in range(trajectories):
                qt = q[t]
                if viscous:
                    d = 1.0 + qt * (2.0 / 3.0)
                    sd = math.sqrt(d) if d > 0.0 else 0.0
                    rm1 = d * sd - 1.0
                    c = twozeta
                    q_next = _next_viscous(
                        q_prev[t], qt, sigma[t] * s, d, sd, h2[t], damp_prev[t], inv_viscous[t]
                    )
                else:
                    if general:
                        d, sd, rm1, c = _contact_terms(qt, zeta, CONTACT_GENERAL, exponent)
                    else:
                        d, sd, rm1, c = _select_terms(qt, twozeta, by_contact, by_root, times_root)
                    q_next = _next(
                        q_prev[t], qt, sigma[t] * s, rm1, c, h2[t], half_h[t], _NOT_VISCOUS, 0.0
                    )
                peak[t] = sd if sd > peak[t] else peak[t]
                velocity = (q_next - q_prev[t]) * inv_2h[t]
                x = rm1 + c * velocity  # N/F_s - 1
                excess[t] = x
                total[t] += x
                force_max[t] = x if x > force_max[t] else force_max[t]
                force_min[t] = x if x < force_min[t] else force_min[t]
                inside = d > 0.0
                r = run[t]
                first = lead[t]
                lead[t] = r if (inside and first < 0) else first
                longest[t] = r if (inside and first >= 0 and r > longest[t]) else longest[t]
                run[t] = 0 if inside else r + 1
                loss[t] += 0 if inside else 1
                q_prev[t] = qt
                q[t] = q_next
            for i in range(n_harm):
                ck = cos_k[i]
                sk = sin_k[i]
                for t in range(trajectories):
                    coefficients[i, 0, t] += excess[t] * ck
                    coefficients[i, 1, t] += excess[t] * sk
                k = index[i] + harmonics[i]
                index[i] = k - n if k >= n else k
        status, bad = _status(q_prev, q, peak, limit)
        if status != OK:
            return status, bad
    for t in range(trajectories):
        if lead[t] < 0:  # never in contact: one flight over the whole record
            lead[t] = run[t]
        force_max[t] += 1.0
        force_min[t] += 1.0
    sums[5, :] = q_prev
    sums[6, :] = q
    return OK, -1


@njit(cache=True, error_model="numpy")
def dwell_batch(
    q_prev, q, h, h_new, sigma, sin_table, cos_table, settle_periods, blocks, zeta, law,
    exponent, harmonics, coefficients, sums, counts,
):  # fmt: skip
    """One stepped-sine dwell of T trajectories: retune each to its new step ``h_new``
    (``integrators.restart``, where it changed), settle, then measure ``blocks[b]``
    periods into ``coefficients[b]``, ``sums[b]``, ``counts[b]`` for each block b.
    Returns ``(status, trajectory)`` as :func:`advance_batch`."""
    for t in range(q.shape[0]):
        if h_new[t] != h[t]:
            q_prev[t] = restart(q_prev[t], q[t], h[t], h_new[t], zeta, law, exponent)
            h[t] = h_new[t]
    status, bad = advance_batch(q_prev, q, h, sigma, sin_table, settle_periods, zeta, law, exponent)
    if status != OK:
        return status, bad
    for b in range(blocks.shape[0]):
        status, bad = measure_batch(
            q_prev, q, h, sigma, sin_table, cos_table, blocks[b], zeta, law, exponent,
            harmonics, coefficients[b], sums[b], counts[b],
        )  # fmt: skip
        if status != OK:
            return status, bad
    return OK, -1


# --------------------------------------------------------------------------- the sweep
def lockstep(scene: Scene) -> bool:
    """Whether the scene's trajectories can dwell in lockstep (fixed settling, settle
    steady state); otherwise :func:`run_sweep_batched` runs them one by one."""
    return scene.sweep.settle_periods is not None and scene.sweep.steady_state == "settle"


def _blocks(measure_periods: int) -> np.ndarray:
    """The measured blocks of a fixed-settle dwell, as ``Oscillator.dwell`` reads them."""
    if measure_periods < 2:
        return np.array([measure_periods], dtype=np.int64)
    first = measure_periods // 2
    return np.array([first, measure_periods - first], dtype=np.int64)


def _reading(
    oscillator: Oscillator,
    periods: int,
    h: float,
    coefficients: np.ndarray,
    sums: np.ndarray,
    counts: np.ndarray,
) -> Reading:
    """A block's :class:`Reading` from one trajectory's sums, with the arithmetic of
    ``Oscillator.measure``."""
    total, fmax, fmin, qp_last, q_last, q_prev, q = (float(x) for x in sums)
    loss, longest, lead, trail = (int(x) for x in counts)
    return oscillator.reading(
        periods, h, np.array(coefficients), total, fmax, fmin, loss, longest, lead, trail,
        qp_last, q_last, q_prev, q,
    )  # fmt: skip


def _raise_failure(
    scene: Scene, oscillator: Oscillator, status: int, direction: str, w: float
) -> None:
    """Raise the error ``run_sweep`` raises for that trajectory (the oscillator's own
    check, prefixed as :func:`hertzsweep.sweep.run_direction` prefixes it)."""
    try:
        oscillator.check_status(status, w)
    except HertzsweepError as exc:
        raise type(exc)(f"{scene.source}: {direction} sweep: {exc}") from None


def run_sweep_batched(scene: Scene, progress: Progress | None = None) -> SweepResult:
    """Every (direction, sigma) sweep of the scene, advanced together in lockstep.

    The same numbers as :func:`hertzsweep.sweep.run_sweep` (bit for bit): all T
    trajectories dwell at once, trajectory t at its own frequency and input level.
    For ``settle_periods = "auto"`` or ``steady_state = "shooting"`` it is
    :func:`~hertzsweep.sweep.run_sweep` itself (the dwells differ in length).

    Parameters
    ----------
    scene : Scene
    progress : callable, optional
        Called with the number of dwells finished (T after each lockstep dwell).

    Raises
    ------
    StabilityError, IntegrationError
        As :func:`~hertzsweep.sweep.run_sweep` (the first trajectory, in (direction,
        sigma) order, that failed at the dwell where one failed).
    Interrupted
        On SIGINT, with the result so far (lockstep sweeps finish together, so none is
        marked finished).
    """
    if not lockstep(scene):
        return run_sweep(scene, progress)
    check_stability(scene)
    result = SweepResult.empty(scene)
    w = result.frequency_ratio
    pairs = [(d, s) for d in range(len(result.directions)) for s in range(result.sigma.size)]
    count = len(pairs)
    oscillators = [Oscillator(scene, result.sigma[s]) for _, s in pairs]
    first = oscillators[0]
    n = first.steps_per_period
    order = np.array([sweep_order(w, result.directions[d]) for d, _ in pairs], dtype=np.int64)
    sigma = np.array([result.sigma[s] for _, s in pairs])
    steps = np.array([integrators.step_size(x, n) for x in w])
    h = steps[order[:, 0]].copy()
    q_prev = np.zeros(count)
    q = np.zeros(count)
    blocks = _blocks(scene.sweep.measure_periods)
    coefficients = np.zeros((blocks.size, first.harmonics.size, 2, count))
    sums = np.zeros((blocks.size, _SUMS, count))
    counts = np.zeros((blocks.size, _COUNTS, count), dtype=np.int64)
    settle = int(scene.sweep.settle_periods)
    try:
        for i in range(w.size):
            index = order[:, i]
            h_new = steps[index]
            status, bad = dwell_batch(
                q_prev, q, h, h_new, sigma, first.sin_table, first.cos_table, settle, blocks,
                first.zeta, first.law, first.exponent, first.harmonics, coefficients, sums,
                counts,
            )  # fmt: skip
            if status != OK:
                direction = result.directions[pairs[bad][0]]
                _raise_failure(scene, oscillators[bad], status, direction, w[index[bad]])
            for t, (d, s) in enumerate(pairs):
                readings = [
                    _reading(oscillators[t], int(blocks[b]), h[t], coefficients[b, :, :, t],
                             sums[b, :, t], counts[b, :, t])
                    for b in range(blocks.size)
                ]  # fmt: skip
                if len(readings) == 1:
                    reading, settled = readings[0], readings[0].periodic
                else:
                    head, tail = readings
                    reading = combine_readings(head, tail)
                    settled = readings_agree(head, tail, scene.sweep.tolerance)
                result.store(d, s, int(index[t]), reading, settled)
            if progress is not None:
                progress(count)
    except KeyboardInterrupt as exc:
        raise Interrupted(result, getattr(exc, "signal_number", 2)) from None
    result.steps = count * w.size * (settle + int(blocks.sum())) * n
    for d, s in pairs:
        result.jump_frequency_ratio[d, s] = find_jump(
            result.amplitude[d, s, :, 0], w, result.directions[d], scene.sweep.jump_threshold
        )
    result.finished[:] = True
    return result


# --------------------------------------------------------------------------- bench
def bench_scene(trajectories: int) -> Scene:
    """The batch benchmark: ``trajectories`` down sweeps of the Figure 15 kind (contact
    law n = 3/2, zeta = 1 %) from w = 1.00 to 0.90 in 6 dwells, sigma spread from 0.2 % to
    8 % (those above about 3 % lose contact), 256 steps per period, 300 settling + 20
    measured periods per dwell. The kernels are branch-free, so contact loss costs
    nothing extra."""
    sigma = np.round(np.geomspace(0.002, 0.08, trajectories), 6).tolist()
    return scene_from_dict(
        {
            "rig": {"ball_radius": 12.7e-3, "youngs_modulus": 210e9, "poisson_ratio": 0.29,
                    "mass": 11.4, "static_load": 110.0},
            "damping": {"ratio": 0.01, "law": "contact", "exponent": 1.5},
            "excitation": {"sigma": sigma},
            "sweep": {"start": 0.90, "stop": 1.00, "step": 0.02, "directions": ["down"],
                      "settle_periods": 300, "measure_periods": 20},
            "solver": {"steps_per_period": 256},
        },
        source="<bench>",
    )  # fmt: skip


def bench_batch(counts: tuple[int, ...] = (1, 8, 16), repeats: int = 3) -> dict[str, Any]:
    """ns per trajectory-step of the batched kernels (best of ``repeats``) for 1, 8 and
    16 trajectories, for the kernel alone (whole dwells: settle + measure) and for
    :func:`run_sweep_batched` end to end (readings and jumps included)."""
    out: dict[str, Any] = {}
    for count in counts:
        scene = bench_scene(count)
        small = replace(scene, sweep=replace(scene.sweep, start=scene.sweep.stop))
        run_sweep_batched(small)  # compile (or load the cache)
        best = np.inf
        steps = 0
        for _ in range(repeats):
            t0 = time.perf_counter()
            result = run_sweep_batched(scene)
            best = min(best, time.perf_counter() - t0)
            steps = result.steps
        out[f"sweep_ns_per_trajectory_step_{count}"] = best / steps * 1e9
        out[f"ns_per_trajectory_step_{count}"] = _kernel_ns(scene, repeats)
    return out


def _kernel_ns(scene: Scene, repeats: int) -> float:
    """ns per trajectory-step of ``dwell_batch`` alone over the scene's dwells."""
    count = len(scene.excitation.sigma)
    oscillator = Oscillator(scene, scene.excitation.sigma[0])
    n = oscillator.steps_per_period
    w = scene.sweep.frequency_ratios[::-1]
    sigma = np.array(scene.excitation.sigma)
    blocks = _blocks(scene.sweep.measure_periods)
    settle = int(scene.sweep.settle_periods)
    shape = (blocks.size, oscillator.harmonics.size, 2, count)
    best = np.inf
    for _ in range(repeats):
        q_prev, q = np.zeros(count), np.zeros(count)
        h = np.full(count, integrators.step_size(w[0], n))
        coefficients = np.zeros(shape)
        sums = np.zeros((blocks.size, _SUMS, count))
        counts = np.zeros((blocks.size, _COUNTS, count), dtype=np.int64)
        t0 = time.perf_counter()
        for x in w:
            dwell_batch(
                q_prev, q, h, np.full(count, integrators.step_size(x, n)), sigma,
                oscillator.sin_table, oscillator.cos_table, settle, blocks, oscillator.zeta,
                oscillator.law, oscillator.exponent, oscillator.harmonics, coefficients, sums,
                counts,
            )  # fmt: skip
        best = min(best, time.perf_counter() - t0)
    steps = count * w.size * (settle + int(blocks.sum())) * n
    return best / steps * 1e9


__all__ = [
    "advance_batch",
    "bench_batch",
    "dwell_batch",
    "lockstep",
    "measure_batch",
    "run_sweep_batched",
]
