"""The project's own speed figures (``hertzsweep bench``); not timed tests.

Every ratio is measured in the same run, never typed in:

- ns per integration step of the compiled loop on one trajectory, for each damping law,
  against the *floor*: the bare recurrence of the viscous update (state in
  ``d = 1 + 2q/3``, a square root then one FMA per step, nothing else) compiled the same
  way on this CPU;
- ns per trajectory-step of many trajectories in lockstep (8 and 16), against the bare
  recurrence vectorised across 16 trajectories (the throughput floor of the CPU's vector
  square root), and the contact law's also against its own bare update (a square root and
  a division per step, which share the CPU's divider);
- wall time of a 121-point up + down sweep (w 0.90 to 1.05, 256 steps per period,
  300 settle + 20 measured periods, sigma = 1 %);
- time per dwell at equal accuracy (:func:`equal_accuracy`): one dwell (:class:`Dwell`)
  integrated by hertzsweep's central difference, the same combined by Richardson, a
  fixed-step RK4 written here, scipy's ``solve_ivp`` (DOP853, LSODA) and numbalsoda's
  DOP853 (when installed), each at the loosest setting of its ladder whose H1 is within
  1e-4, and within 1e-6, of a converged reference;
- shooting-accelerated vs settled sweep (steps and time, the same jumps);
- random excitation (:func:`random_figures`): ns per realisation-step of a random run of 16
  realisations in lockstep (forcing, tallies and Welch spectra included), of its compiled
  steps with their tallies, of the steps alone, of the forcing and of the Welch sums,
  against the lockstep sweep's trajectory-step of 16 trajectories measured in the same
  run; and the wall time of the paper's random scene.
"""

from __future__ import annotations

import math
import time
from collections import namedtuple
from dataclasses import dataclass, replace
from functools import lru_cache, partial
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit, types
from numba.extending import overload

from ..core.config import Scene, scene_from_dict
from ..core.model import check_stability
from ..errors import HertzsweepError
from ..kernels import CACHE, integrate, scheme
from ..kernels.laws import make_law
from ..kernels.scheme import fma
from .oscillator import Oscillator, drive
from .sweep import run_sweep

PAPER_RIG = {
    "ball_radius": 12.7e-3,
    "youngs_modulus": 210e9,
    "poisson_ratio": 0.29,
    "mass": 11.4,
    "static_load": 110.0,
}
LAWS = {  # figure name -> (law, exponent)
    "viscous": ("viscous", 1.5),
    "contact_n1.5": ("contact", 1.5),
    "contact_general_n": ("contact", 1.3),
}


def bench_scene(points: int = 121) -> Scene:
    """The benchmark sweep: sigma = 1 %, zeta = 0.45 % viscous, w 0.90..1.05."""
    return scene_from_dict(
        {
            "rig": dict(PAPER_RIG),
            "damping": {"ratio": 0.0045, "law": "viscous"},
            "excitation": {"sigma": [0.01]},
            "sweep": {
                "start": 0.90,
                "stop": 1.05,
                "step": 0.15 / (points - 1),
                "settle_periods": 300,
                "measure_periods": 20,
            },
            "solver": {"steps_per_period": 256},
            "lockin": {"harmonics": [1, 2]},
        },
        source="<bench>",
    )


def _best(run, repeats: int = 3) -> float:
    """Best wall time of ``repeats`` calls of ``run()`` [s]."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t0)
    return best


# --------------------------------------------------------------------------- floors
@njit(cache=CACHE, error_model="numpy")
def _bare_chain(d, a, b, k, loads, periods):
    """The viscous update and nothing else: ``d = fma(-(k d), sqrt(d), fma(d, a, k F - b d_))``."""
    d_prev = d
    for _ in range(periods):
        for j in range(loads.shape[0]):
            d_next = fma(-(k * d), math.sqrt(d), fma(d, a, k * loads[j] - d_prev * b))
            d_prev = d
            d = d_next
    return d


def _bare_update(x, x_prev, load, constants, t):
    """One lane's bare update: the viscous one (``constants = (a, b, k)``, arrays over the
    lanes) or the contact law's with n = 3/2 (``(2 zeta, h/2, c0)``, floats: ``c = 2 zeta
    d sqrt d``, a square root and a division, the two on the CPU's one divider)."""
    raise NotImplementedError("compiled only")


@overload(_bare_update, inline="always")
def _bare_update_typed(x, x_prev, load, constants, t):
    if isinstance(constants[0], types.Array):

        def viscous(x, x_prev, load, constants, t):
            a, b, k = constants
            kt = k[t]
            return fma(-(kt * x), math.sqrt(x), fma(x, a[t], kt * load - x_prev * b[t]))

        return viscous

    def divided(x, x_prev, load, constants, t):
        twozeta, half_h, c0 = constants
        root = math.sqrt(x)
        ch = twozeta * x * root * half_h
        return fma(ch, x_prev, fma(-(c0 * x), root, 2.0 * x - x_prev + c0 * load)) / (1.0 + ch)

    return divided


@njit(cache=CACHE, error_model="numpy")
def _bare_lanes(d, constants, loads, periods):
    """An update (:func:`_bare_update`) for T trajectories and nothing else, trajectory
    innermost (vectorised): the throughput floor of that update across trajectories."""
    d_prev = d.copy()
    for _ in range(periods):
        for j in range(loads.shape[0]):
            load = loads[j]
            for t in range(d.shape[0]):
                x = d[t]
                d[t] = _bare_update(x, d_prev[t], load, constants, t)
                d_prev[t] = x
    return d


def _chain_constants(count: int):
    n = 256
    law = make_law("viscous", 0.0045, 1.5)
    step = scheme.make_step(law, scheme.step_size(0.97, n))
    a, b, k = step.fixed
    loads = 1.0 + 0.01 * scheme.period_tables(n)[0]
    return (np.full(count, a), np.full(count, b), np.full(count, k)), loads


def floor_ns_per_step(steps: int) -> float:
    """ns per step of :func:`_bare_chain` (best of 3): the latency floor of the update."""
    (a, b, k), loads = _chain_constants(1)
    periods = max(1, steps // loads.size)
    _bare_chain(1.0, a[0], b[0], k[0], loads, 1)
    return (
        _best(lambda: _bare_chain(1.0, a[0], b[0], k[0], loads, periods))
        / (periods * loads.size)
        * 1e9
    )


def floor_ns_per_trajectory_step(count: int, steps: int) -> float:
    """ns per trajectory-step of :func:`_bare_lanes` over ``count`` trajectories."""
    (a, b, k), loads = _chain_constants(count)
    periods = max(1, steps // (loads.size * count))
    _bare_lanes(np.ones(count), (a, b, k), loads, 1)
    seconds = _best(lambda: _bare_lanes(np.ones(count), (a, b, k), loads, periods))
    return seconds / (periods * loads.size * count) * 1e9


def floor_ns_per_trajectory_step_divided(count: int, steps: int) -> float:
    """ns per trajectory-step of :func:`_bare_lanes` with the contact law's update over
    ``count`` trajectories."""
    _, loads = _chain_constants(count)
    law = make_law("contact", 0.01, 1.5)
    step = scheme.make_step(law, scheme.step_size(0.97, loads.size))
    periods = max(1, steps // (loads.size * count))
    constants = (law.twozeta, step.half_h, step.c0)
    _bare_lanes(np.ones(count), constants, loads, 1)
    seconds = _best(lambda: _bare_lanes(np.ones(count), constants, loads, periods))
    return seconds / (periods * loads.size * count) * 1e9


# --------------------------------------------------------------------------- kernels
def ns_per_step(law: str, exponent: float, steps: int) -> float:
    """Best of 3 runs of :func:`~hertzsweep.kernels.integrate.advance`, ns per step."""
    scene = bench_scene(2)
    scene = replace(scene, damping=replace(scene.damping, law=law, exponent=exponent))
    n = 256
    record = make_law(law, 0.0045, exponent)
    h = scheme.step_size(0.97, n)
    inputs = drive(scene, 0.01)
    periods = max(1, steps // n)
    integrate.advance(0.0, 0.0, h, record, inputs, 1)
    seconds = _best(lambda: integrate.advance(0.0, 0.0, h, record, inputs, periods))
    return seconds / (periods * n) * 1e9


def batch_scene(trajectories: int, law: str = "contact") -> Scene:
    """The batch benchmark: ``trajectories`` down sweeps of the Figure 15 kind (zeta =
    1 %, n = 3/2) from w = 1.00 to 0.90 in 6 dwells, sigma spread from 0.2 % to 8 % (those
    above about 3 % lose contact), 256 steps per period, 300 settling + 20 measured
    periods per dwell."""
    sigma = np.round(np.geomspace(0.002, 0.08, trajectories), 6).tolist()
    return scene_from_dict(
        {
            "rig": dict(PAPER_RIG),
            "damping": {"ratio": 0.01, "law": law, "exponent": 1.5},
            "excitation": {"sigma": sigma},
            "sweep": {
                "start": 0.90,
                "stop": 1.00,
                "step": 0.02,
                "directions": ["down"],
                "settle_periods": 300,
                "measure_periods": 20,
            },
            "solver": {"steps_per_period": 256},
        },
        source="<bench>",
    )


def bench_batch(counts: tuple[int, ...] = (1, 8, 16), repeats: int = 3) -> dict[str, Any]:
    """ns per trajectory-step of lockstep sweeps (best of ``repeats``) for 1, 8 and 16
    trajectories, viscous and contact n = 3/2, readings and jumps included; and of the
    readings' kernel alone (:func:`~hertzsweep.kernels.integrate.measure`, 20 periods of
    the 16 trajectories at w = 0.97)."""
    out: dict[str, Any] = {}
    for law in ("viscous", "contact"):
        for count in counts:
            scene = batch_scene(count, law)
            check_stability(scene)
            small = replace(scene, sweep=replace(scene.sweep, start=scene.sweep.stop))
            run_sweep(small)  # compile (or load the cache)
            steps = run_sweep(small).steps * scene.sweep.frequency_ratios.size
            seconds = _best(lambda scene=scene: run_sweep(scene), repeats)
            out[f"{law}_ns_per_trajectory_step_{count}"] = seconds / steps * 1e9
        out[f"measure_{law}_ns_per_trajectory_step_16"] = _measure_ns(batch_scene(16, law))
    return out


def _measure_ns(scene: Scene, periods: int = 20) -> float:
    """ns per trajectory-step of the readings' kernel on every trajectory of ``scene``
    (best of 5), from the state 300 periods settle reach at w = 0.97."""
    sigma = np.asarray(scene.excitation.sigma, dtype=float)
    n = int(scene.solver.steps_per_period)
    law = make_law(scene.damping.law, scene.damping.ratio, scene.damping.exponent)
    h = np.full(sigma.size, scheme.step_size(0.97, n))
    inputs = drive(scene, sigma)
    q_prev, q = np.zeros(sigma.size), np.zeros(sigma.size)
    integrate.advance_batch(q_prev, q, h, law, inputs, 300)

    def run():
        readout = integrate.new_readout(inputs.harmonics.size, sigma.size)
        integrate.measure(q_prev.copy(), q.copy(), h, law, inputs, periods, readout)

    run()
    return _best(run, 5) / (periods * n * sigma.size) * 1e9


def sweep_wall_time(scene: Scene) -> tuple[float, int]:
    """Wall time [s] (best of 2) and integration steps of the scene's sweep."""
    run_sweep(replace(scene, sweep=replace(scene.sweep, stop=scene.sweep.start)))  # compile
    steps = run_sweep(scene).steps
    return _best(lambda: run_sweep(scene), 2), steps


# --------------------------------------------------------------------------- equal accuracy
@dataclass(frozen=True)
class Dwell:
    """One dwell, the same for every competitor: eq. (8)/(11) in q,

        q'' + f_d + [H(d) d]^(3/2) = 1 + sigma sin(w tau),   d = 1 + 2 q / 3,

    ``f_d = 2 zeta q'`` (``law = "viscous"``) or ``2 zeta d^(3/2) H(d) q'`` (``"contact"``,
    n = 3/2), from rest (q = 0, q' = 0, excitation phase 0) over ``settle`` then ``measure``
    periods at w. Its H1 is the amplitude of the first harmonic of ``N/F_s = [H(d) d]^(3/2)
    + f_d`` over the measured periods, ``2 |integral (N/F_s - 1) exp(i w tau) dtau| / L`` (L:
    their length in tau).
    """

    label: str
    sigma: float
    zeta: float
    law: str
    frequency_ratio: float
    settle: int = 300
    measure: int = 20

    @property
    def period(self) -> float:
        return 2.0 * math.pi / self.frequency_ratio

    @property
    def times(self) -> tuple[float, float]:
        """tau at the end of the settling and at the end of the dwell."""
        return self.settle * self.period, (self.settle + self.measure) * self.period

    def parameters(self) -> np.ndarray:
        """``(sigma, w, 2 zeta, contact)``, what the competitors' right-hand sides read."""
        contact = 1.0 if self.law == "contact" else 0.0
        return np.array([self.sigma, self.frequency_ratio, 2.0 * self.zeta, contact])

    def h1(self, cos_integral: float, sin_integral: float) -> float:
        """H1 from ``integral (N/F_s - 1) cos(w tau)``, ``... sin(w tau)`` over the
        measured periods."""
        return 2.0 * math.hypot(cos_integral, sin_integral) / (self.measure * self.period)

    def scene(self, steps_per_period: int, method: str = "central-difference") -> Scene:
        """The one-frequency scene of hertzsweep's own drivers at N steps per period."""
        w = self.frequency_ratio
        return scene_from_dict(
            {
                "rig": dict(PAPER_RIG),
                "damping": {"ratio": self.zeta, "law": self.law, "exponent": 1.5},
                "excitation": {"sigma": [self.sigma]},
                "sweep": {
                    "start": w,
                    "stop": w,
                    "directions": ["up"],
                    "settle_periods": self.settle,
                    "measure_periods": self.measure,
                },
                "solver": {"steps_per_period": int(steps_per_period), "method": method},
                "lockin": {"harmonics": [1]},
            },
            source="<bench>",
        )


DWELLS = (
    Dwell("sigma 1 %, w 0.975", 0.01, 0.0045, "viscous", 0.975),
    Dwell("sigma 1 %, w 0.95", 0.01, 0.0045, "viscous", 0.95),
    Dwell("sigma 7.8 %, n 3/2, w 0.95", 0.078, 0.01, "contact", 0.95),
)
"""The dwells compared: the no-loss scene (sigma = 1 %, zeta = 0.45 %, viscous) on its
lower branch near resonance and below it, and the vibro-impact scene (sigma = 7.8 %,
zeta = 1 %, contact damping n = 3/2) at w = 0.95, where a dwell from rest loses contact
over 21 % of the period (from rest at w <= 0.9 it stays on the branch without loss)."""
TARGETS = (1e-4, 1e-6)  # |H1 - H1_ref|, in units of F_s
REFERENCE_RTOL = 1e-13  # DOP853's rtol = atol for the reference
RICHARDSON_CHECK = 4096  # the reference is checked against central difference N and 2N
DENSE_SAMPLES = 4096  # per period, the reference's second H1 (DFT of its dense output)
RTOL_LADDER = tuple(m * 10.0**-e for e in range(3, 11) for m in (1.0, 0.3))[:-1]


def _half_octaves(first: int, last: int) -> tuple[int, ...]:
    """Steps per period ``2^k`` and ``3 2^(k-1)`` from ``first`` to ``last``: 16, 24, 32, 48..."""
    return tuple(n for n in sorted(b << k for b in (2, 3) for k in range(16)) if first <= n <= last)


RK4_LADDER = _half_octaves(16, 1024)
CD_LADDER = _half_octaves(64, 16384)
RICHARDSON_LADDER = _half_octaves(16, 1024)  # N of the pair N, 2N


@njit(cache=CACHE, inline="always")
def _excess(q, v, twozeta, contact):
    """``N/F_s - 1`` at ``(q, q')``: the competitors' one copy of the model (n = 3/2 for
    the contact law; the kernels' own is :mod:`~hertzsweep.kernels.laws`)."""
    d = 1.0 + q * (2.0 / 3.0)
    root = math.sqrt(d) if d > 0.0 else 0.0
    c = twozeta * d * root if contact else twozeta
    return d * root - 1.0 + c * v


@njit(cache=CACHE)
def _excess_many(q, v, twozeta, contact):
    """:func:`_excess` of every sample."""
    out = np.empty_like(q)
    for i in range(q.shape[0]):
        out[i] = _excess(q[i], v[i], twozeta, contact)
    return out


@njit(cache=CACHE)
def _ivp_rhs(tau, y, p):
    """``y' `` for scipy: ``(q, q')``, and the two quadrature states ``integral (N/F_s - 1)
    cos(w tau)``, ``... sin(w tau)`` when ``y`` has four components."""
    x = _excess(y[0], y[1], p[2], p[3] > 0.5)
    phase = p[1] * tau
    out = np.empty(y.shape[0])
    out[0] = y[1]
    out[1] = p[0] * math.sin(phase) - x
    if y.shape[0] > 2:
        out[2] = x * math.cos(phase)
        out[3] = x * math.sin(phase)
    return out


def _soda_rhs(tau, u, du, p):
    """:func:`_ivp_rhs` as numbalsoda's C callback (``p[4] = 1``: four states)."""
    x = _excess(u[0], u[1], p[2], p[3] > 0.5)
    phase = p[1] * tau
    du[0] = u[1]
    du[1] = p[0] * math.sin(phase) - x
    if p[4] > 0.5:
        du[2] = x * math.cos(phase)
        du[3] = x * math.sin(phase)


@njit(cache=CACHE, inline="always")
def _rk4_step(q, v, f0, f1, f2, h, twozeta, contact):
    """One classical RK4 step, loads ``sigma sin(w tau)`` at its start, middle and end:
    ``(q, q', x1, x2 + x3, x4)``, the ``x`` being ``N/F_s - 1`` at the four stages."""
    half = 0.5 * h
    x1 = _excess(q, v, twozeta, contact)
    a1 = f0 - x1
    q2, v2 = q + half * v, v + half * a1
    x2 = _excess(q2, v2, twozeta, contact)
    a2 = f1 - x2
    q3, v3 = q + half * v2, v + half * a2
    x3 = _excess(q3, v3, twozeta, contact)
    a3 = f1 - x3
    q4, v4 = q + h * v3, v + h * a3
    x4 = _excess(q4, v4, twozeta, contact)
    a4 = f2 - x4
    sixth = h / 6.0
    q_next = q + sixth * (v + 2.0 * (v2 + v3) + v4)
    return q_next, v + sixth * (a1 + 2.0 * (a2 + a3) + a4), x1, x2 + x3, x4


@njit(cache=CACHE, error_model="numpy")
def _rk4_periods(y, p, tables, h, periods, sums):
    """Whole periods of fixed-step RK4 in place on ``y = (q, q')``; ``tables`` float[2, 2M+1]
    holds ``sin``, ``cos`` of the phase at every half step of a period of M steps. When
    ``sums`` (float[2]) is not empty, the quadrature states ``integral (N/F_s - 1) cos``,
    ``... sin`` are integrated by the same RK4 stages (Simpson's weights) and added to it."""
    q, v = y[0], y[1]
    sigma, twozeta, contact = p[0], p[2], p[3] > 0.5
    sin_t, cos_t = tables[0], tables[1]
    read = sums.shape[0] > 0
    cos_sum = 0.0
    sin_sum = 0.0
    for _ in range(periods):
        for j in range(0, sin_t.shape[0] - 1, 2):
            s0, s1, s2 = sin_t[j], sin_t[j + 1], sin_t[j + 2]
            f0, f1, f2 = sigma * s0, sigma * s1, sigma * s2
            q, v, x1, x23, x4 = _rk4_step(q, v, f0, f1, f2, h, twozeta, contact)
            if read:
                cos_sum += x1 * cos_t[j] + 2.0 * x23 * cos_t[j + 1] + x4 * cos_t[j + 2]
                sin_sum += x1 * s0 + 2.0 * x23 * s1 + x4 * s2
    y[0], y[1] = q, v
    if read:
        sums[0] += cos_sum * h / 6.0
        sums[1] += sin_sum * h / 6.0


# the H1 of a dwell by each competitor at one setting
@lru_cache(maxsize=64)
def _oscillator(dwell: Dwell, steps_per_period: int, method: str) -> Oscillator:
    return Oscillator(dwell.scene(steps_per_period, method), dwell.sigma)


def cd_h1(dwell: Dwell, steps_per_period: int, method: str = "central-difference") -> float:
    """hertzsweep's central difference (or another ``solver.method``) at N steps per
    period, through its own driver (:meth:`Oscillator.dwell`): H1 is the kernels' lock-in
    over the measured periods."""
    oscillator = _oscillator(dwell, int(steps_per_period), method)
    w = dwell.frequency_ratio
    _, reading, _ = oscillator.dwell(oscillator.from_velocity(0.0, 0.0, w), w)
    return float(reading.amplitude[0])


def richardson_h1(dwell: Dwell, steps_per_period: int) -> float:
    """Central difference at N and 2N, combined ``(4 H1(2N) - H1(N)) / 3`` (the scheme is
    second order): two dwells' cost."""
    coarse = cd_h1(dwell, steps_per_period)
    return (4.0 * cd_h1(dwell, 2 * steps_per_period) - coarse) / 3.0


def rk4_h1(dwell: Dwell, steps_per_period: int) -> float:
    """Fixed-step RK4 at M steps per period (:func:`_rk4_periods`); H1 from the quadrature
    states integrated by the same steps over the measured periods."""
    m = int(steps_per_period)
    phase = math.pi * np.arange(2 * m + 1) / m
    tables = np.stack([np.sin(phase), np.cos(phase)])
    h = dwell.period / m
    y, sums, p = np.zeros(2), np.zeros(2), dwell.parameters()
    _rk4_periods(y, p, tables, h, dwell.settle, np.zeros(0))
    _rk4_periods(y, p, tables, h, dwell.measure, sums)
    return dwell.h1(sums[0], sums[1])


def _ivp_measured(dwell: Dwell, method: str, rtol: float, dense: bool = False):
    """``solve_ivp`` over the dwell (rtol = atol): the settling periods with ``(q, q')``,
    then the measured ones with the two quadrature states added (from 0). Returns the
    second solution, or None if either failed."""
    from scipy.integrate import solve_ivp

    settle_end, end = dwell.times
    options = {"method": method, "rtol": rtol, "atol": rtol, "args": (dwell.parameters(),)}
    first = solve_ivp(_ivp_rhs, (0.0, settle_end), np.zeros(2), **options)
    if first.status != 0:
        return None
    start = np.concatenate([first.y[:, -1], np.zeros(2)])
    second = solve_ivp(_ivp_rhs, (settle_end, end), start, dense_output=dense, **options)
    return second if second.status == 0 else None


def ivp_h1(dwell: Dwell, rtol: float, method: str = "DOP853") -> float:
    """scipy's ``solve_ivp`` (``method``) at ``rtol`` (= atol); H1 from the quadrature
    states it integrates under its own error control."""
    solution = _ivp_measured(dwell, method, rtol)
    return math.nan if solution is None else dwell.h1(*solution.y[2:, -1])


@lru_cache(maxsize=1)
def _numbalsoda() -> tuple[Any, int] | None:
    """numbalsoda's ``dop853`` and the address of :func:`_soda_rhs` compiled as its
    callback; None when numbalsoda is not installed."""
    try:
        from numbalsoda import dop853
    except ImportError:
        return None
    from numba import cfunc, types

    pointer = types.CPointer(types.double)
    signature = types.void(types.double, pointer, pointer, pointer)
    return dop853, cfunc(signature, cache=CACHE)(_soda_rhs).address


def numbalsoda_h1(dwell: Dwell, rtol: float) -> float:
    """numbalsoda's DOP853 (the Hairer-Wanner code, compiled; callback compiled by numba)
    at ``rtol`` (= atol), settling then measured periods with the quadrature states, as
    :func:`ivp_h1`."""
    dop853, address = _numbalsoda()
    settle_end, end = dwell.times
    p = np.append(dwell.parameters(), 0.0)
    options = {"data": p, "rtol": rtol, "atol": rtol, "mxstep": 10**9}
    first, ok = dop853(address, np.zeros(2), np.array([0.0, settle_end]), **options)
    p[4] = 1.0
    start = np.array([first[-1, 0], first[-1, 1], 0.0, 0.0])
    second, ok_too = dop853(address, start, np.array([settle_end, end]), **options)
    return dwell.h1(second[-1, 2], second[-1, 3]) if ok and ok_too else math.nan


Competitor = namedtuple("Competitor", ["name", "label", "ladder", "h1"])
"""A method compared: its name, ``label(setting)``, its ladder of settings from the
loosest, and ``h1(dwell, setting)`` (None: not installed)."""


def competitors() -> list[Competitor]:
    """Every method compared; hertzsweep's central difference first (the ratios' base)."""
    rtol = "rtol {:.0e}".format
    soda = numbalsoda_h1 if _numbalsoda() is not None else None
    return [
        Competitor("central difference (hertzsweep)", "N {}".format, CD_LADDER, cd_h1),
        Competitor(
            "central difference, Richardson N + 2N",
            lambda n: f"N {n} + {2 * n}",
            RICHARDSON_LADDER,
            richardson_h1,
        ),
        Competitor(
            "RK4 with contact events (hertzsweep rk4)",
            "{} steps/period".format,
            RK4_LADDER,
            partial(cd_h1, method="rk4"),
        ),
        Competitor("RK4, fixed step (numba)", "{} steps/period".format, RK4_LADDER, rk4_h1),
        Competitor("solve_ivp DOP853", rtol, RTOL_LADDER, ivp_h1),
        Competitor("solve_ivp LSODA", rtol, RTOL_LADDER, partial(ivp_h1, method="LSODA")),
        Competitor("numbalsoda DOP853", rtol, RTOL_LADDER, soda),
    ]


# the reference, the ladders, the table
def reference(dwell: Dwell) -> dict[str, Any]:
    """The converged H1 of a dwell: DOP853 (scipy) at rtol = atol = 1e-13 with the
    quadrature states. Checked two ways: the DFT of its dense output (``DENSE_SAMPLES``
    per period, the rectangle rule) and hertzsweep's central difference at N = 4096 and
    8192 combined by Richardson; both differences are returned."""
    start = time.perf_counter()
    solution = _ivp_measured(dwell, "DOP853", REFERENCE_RTOL, dense=True)
    seconds = time.perf_counter() - start
    h1 = dwell.h1(*solution.y[2:, -1])
    settle_end, _ = dwell.times
    samples = dwell.measure * DENSE_SAMPLES
    tau = settle_end + dwell.period * np.arange(samples) / DENSE_SAMPLES
    q, v = solution.sol(tau)[:2]
    p = dwell.parameters()
    x = _excess_many(q, v, p[2], p[3] > 0.5)
    phase = dwell.frequency_ratio * tau
    dense = 2.0 * math.hypot(x @ np.cos(phase), x @ np.sin(phase)) / samples
    return {
        "scene": dwell.label,
        "h1": h1,
        "seconds": seconds,
        "dense_difference": dense - h1,
        "richardson_steps": RICHARDSON_CHECK,
        "richardson_difference": richardson_h1(dwell, RICHARDSON_CHECK) - h1,
    }


def _loosest(errors: list[float], target: float, walked_all: bool) -> int | None:
    """Index of the loosest rung that meets ``target`` and whose next tighter rung meets it
    too (an error that crosses zero between rungs can meet it alone, by luck); the last
    rung of a ladder counts alone."""
    for i, error in enumerate(errors):
        last = i == len(errors) - 1
        if error <= target and ((not last and errors[i + 1] <= target) or (last and walked_all)):
            return i
    return None


def _walk(h1, ladder, reference_h1: float, target: float) -> tuple[list[float], list[float]]:
    """Errors and wall times [s] of the ladder's rungs, from the loosest, until the loosest
    meeting ``target`` is known (or the ladder ends)."""
    errors, seconds = [], []
    for setting in ladder:
        start = time.perf_counter()
        try:
            value = h1(setting)
        except HertzsweepError:  # beyond a stability limit: the rung fails
            value = math.nan
        seconds.append(time.perf_counter() - start)
        error = abs(value - reference_h1)
        errors.append(error if math.isfinite(error) else math.inf)
        if _loosest(errors, target, len(errors) == len(ladder)) is not None:
            break
    return errors, seconds


def _best_of(run, first: float) -> float:
    """Best wall time [s] of ``run()`` over a few more calls (more when it is fast) and the
    ``first`` one already timed."""
    best = first
    for _ in range(5 if first < 0.05 else 2 if first < 0.5 else 1):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


def compare_dwell(dwell: Dwell, h1_ref: float, targets=TARGETS) -> list[dict[str, Any]]:
    """One row per competitor and target: the loosest setting meeting the target, its
    error, the next looser setting and its error, ms per dwell, and the ratio of that
    time to hertzsweep's central difference at the same target."""
    rows = []
    for competitor in competitors():
        if competitor.h1 is None:
            rows += [_row(dwell, target, competitor) for target in targets]
            continue
        run = partial(competitor.h1, dwell)
        errors, seconds = _walk(run, competitor.ladder, h1_ref, min(targets))
        walked_all = len(errors) == len(competitor.ladder)
        for target in targets:
            i = _loosest(errors, target, walked_all)
            row = _row(dwell, target, competitor)
            if i is not None:
                row["setting"] = competitor.label(competitor.ladder[i])
                row["error"] = errors[i]
                if i > 0:
                    row["looser"] = competitor.label(competitor.ladder[i - 1])
                    row["looser_error"] = errors[i - 1]
                setting = competitor.ladder[i]
                row["ms_per_dwell"] = 1e3 * _best_of(partial(run, setting), seconds[i])
            rows.append(row)
    rows.sort(key=lambda row: targets.index(row["target"]))  # stable: methods in order
    for row in rows:
        base = next(r for r in rows if r["target"] == row["target"])["ms_per_dwell"]
        if row["ms_per_dwell"] is not None and base is not None:
            row["ratio_to_central_difference"] = row["ms_per_dwell"] / base
    return rows


def _row(dwell: Dwell, target: float, competitor: Competitor) -> dict[str, Any]:
    missing = "not installed" if competitor.h1 is None else "not met on the ladder"
    return {
        "scene": dwell.label,
        "target": target,
        "method": competitor.name,
        "setting": missing,
        "error": None,
        "looser": None,
        "looser_error": None,
        "ms_per_dwell": None,
        "ratio_to_central_difference": None,
    }


def equal_accuracy(dwells=DWELLS, targets=TARGETS) -> dict[str, list[dict[str, Any]]]:
    """The comparison at equal accuracy: each dwell's reference (with its two checks) and,
    per target, every competitor at its loosest setting meeting it, timed in this run."""
    references, rows = [], []
    for dwell in dwells:
        ref = reference(dwell)
        references.append(ref)
        rows += compare_dwell(dwell, ref["h1"], targets)
    return {"references": references, "rows": rows}


# --------------------------------------------------------------------------- shooting
def compare_with_settle(scene: Scene) -> dict:
    """The same sweeps by long settling and by shooting: cost and agreement.

    Returns
    -------
    dict
        ``settle_steps``, ``shooting_steps`` (integration steps, tangent steps included),
        ``step_ratio`` (settle / shooting), ``settle_seconds``, ``shooting_seconds``
        (wall time, kernels compiled beforehand), ``max_h1_difference`` (largest
        ``|H1_shooting - H1_settle|`` over the grid, in units of F_s),
        ``max_h1_relative_difference``, ``max_h1_difference_settled`` (the same over the
        dwells the settled sweep reports settled), ``settle_unsettled`` (the others: where
        ``settle_periods`` left a transient, the first dwells after a jump),
        ``jump_frequency_ratio_settle`` and
        ``jump_frequency_ratio_shooting`` (lists over direction and sigma), ``dwells``,
        ``shooting_unsettled`` (dwells where no stable period-1 orbit was found).
    """
    check_stability(scene)
    small = replace(scene, sweep=replace(scene.sweep, stop=scene.sweep.start))
    results = {}
    seconds = {}
    for method in ("settle", "shooting"):
        variant = replace(scene, sweep=replace(scene.sweep, steady_state=method))
        run_sweep(replace(small, sweep=replace(small.sweep, steady_state=method)))  # compile
        start = time.perf_counter()
        results[method] = run_sweep(variant)
        seconds[method] = time.perf_counter() - start
    settled, shot = results["settle"], results["shooting"]
    h1_settle = settled.amplitude[..., 0]
    h1_shooting = shot.amplitude[..., 0]
    difference = np.abs(h1_shooting - h1_settle)
    return {
        "settle_steps": int(settled.steps),
        "shooting_steps": int(shot.steps),
        "step_ratio": settled.steps / max(shot.steps, 1),
        "settle_seconds": seconds["settle"],
        "shooting_seconds": seconds["shooting"],
        "time_ratio": seconds["settle"] / max(seconds["shooting"], 1e-12),
        "max_h1_difference": float(np.max(difference)),
        "max_h1_relative_difference": float(np.max(difference / np.abs(h1_settle))),
        "max_h1_difference_settled": float(np.max(difference, where=settled.settled, initial=0)),
        "settle_unsettled": int(np.sum(~settled.settled)),
        "jump_frequency_ratio_settle": settled.jump_frequency_ratio.tolist(),
        "jump_frequency_ratio_shooting": shot.jump_frequency_ratio.tolist(),
        "dwells": int(h1_settle.size),
        "shooting_unsettled": int(np.sum(~shot.settled)),
    }


# --------------------------------------------------------------------------- random
RANDOM_LEVELS = (0.001, 0.01, 0.05, 0.15, 0.3)  # the paper scene's rms levels when
# configs/paper/random.toml is missing: the linear regime (no loss) to frequent loss of
# contact (loss fractions 0, 0, 5e-4, 0.22 and 0.53 of the time on the paper's rig)
RANDOM_BAND = (0.2, 3.0)  # the band of frequency ratios
RANDOM_LOCKSTEP = 16  # realisations of the ns figure: the lockstep sweep's 16 trajectories
RANDOM_RK4_STEPS = 64  # rk4's steps a period in its random figures (its order 4 needs fewer)


def random_scene(
    levels: tuple[float, ...] = RANDOM_LEVELS,
    realisations: int | None = None,
    duration_periods: int | None = None,
    transient_periods: int | None = None,
    zeta: float = 0.0045,
) -> Scene:
    """A random scene on the paper's rig, viscous damping: the issue's paper scene by
    default (five levels x 16 realisations x 2000 measured + 200 transient periods, at the
    default scene's steps per period and Welch segment: the [random] table's defaults)."""
    run = {
        "realisations": realisations,
        "duration_periods": duration_periods,
        "transient_periods": transient_periods,
    }
    return scene_from_dict(
        {
            "rig": dict(PAPER_RIG),
            "damping": {"ratio": zeta, "law": "viscous"},
            "excitation": {"kind": "random", "rms": list(levels), "band": list(RANDOM_BAND)},
            "random": {key: value for key, value in run.items() if value is not None},
        },
        source="<bench>",
    )


def paper_random_scene() -> Scene:
    """configs/paper/random.toml with the single model when the checkout has it, else
    :func:`random_scene`'s default."""
    path = CONFIGS / "paper" / "random.toml"
    if not path.is_file():
        return random_scene()
    from ..core.config import load_scene

    scene = load_scene(path)
    return replace(scene, model=replace(scene.model, kind="single"))


def _warm_random() -> None:
    """Compile the random kernels (or load them from the cache) on a tiny run."""
    from .random import run_random

    run_random(random_scene((0.01,), 2, 64, 0))


def random_costs(scene: Scene, repeats: int = 3) -> dict[str, float]:
    """ns per trajectory-step of the scene's random run (best of ``repeats``): the whole
    run (:func:`~hertzsweep.drivers.random.run_random`: the forcing table, the compiled
    steps and tallies, the Welch spectra and the statistics); its compiled steps alone
    (the scene's kernels over every segment of the record: ``settle`` (or ``advance``)
    through the transient, ``measure`` (or ``advance`` and
    :func:`~hertzsweep.kernels.random.accumulate`) through the measured record, the
    forcing table made beforehand); the compiled steps without the tallies (``settle``,
    or ``advance``, over every segment: the steps alone); the forcing table alone
    (:func:`~hertzsweep.drivers.random.forcing_table`); and the Welch sums alone
    (:class:`~hertzsweep.drivers.random.Welch` over the measured segments)."""
    from ..kernels import random as kernels
    from .oscillator import model_law
    from .random import Plan, Welch, forcing_table, kernel, run_random, step_segment

    _warm_random()
    steps = run_random(scene).steps
    whole = _best(lambda: run_random(scene), repeats)
    plan = Plan.of(scene)
    table = forcing_table(plan)
    forcing = _best(lambda: forcing_table(plan), repeats)
    inputs = plan.drive()
    law = model_law(scene)
    chosen = kernel(scene)
    record = chosen.new_record(plan.segment_steps, plan.trajectories)
    m = plan.per_step

    def compiled(tallied: bool = True) -> None:
        state = chosen.at_rest(inputs, table, plan.h, law)
        tally = kernels.new_tally(plan.trajectories, plan.bins, 0.0, plan.pdf_high / plan.bins)
        for first, length, measured in plan.chunks():
            part = type(record)(*(buffer[:length] for buffer in record))
            read = tally if measured and tallied else None
            step_segment(chosen, law, plan.h, (state, inputs), table[m * first :], part, read)

    def welch() -> None:
        sums = Welch(plan)
        for first, length, measured in plan.chunks():
            if measured and length == plan.segment_steps:
                sums.add(record.excess, table[m * first : m * (first + length) : m], inputs)

    return {
        "ns_per_trajectory_step": whole / steps * 1e9,
        "compiled_ns_per_trajectory_step": _best(compiled, repeats) / steps * 1e9,
        "untallied_ns_per_trajectory_step": _best(lambda: compiled(False), repeats) / steps * 1e9,
        "forcing_ns_per_trajectory_step": forcing / steps * 1e9,
        "welch_ns_per_trajectory_step": _best(welch, repeats) / steps * 1e9,
    }


def random_figures(lockstep_ns: float, quick: bool = False) -> dict[str, Any]:
    """The random run's figures: ns per realisation-step of :data:`RANDOM_LOCKSTEP`
    realisations of one level (rms 1 %, zeta 1 % and 256 steps per period as the lockstep
    sweep's; 2200 periods, 440 in quick mode), of the whole run, of its compiled steps
    with their tallies and of the steps alone, each over ``lockstep_ns`` (the lockstep
    sweep's ns per trajectory-step of as many trajectories, measured in the same run; the
    issue's bound: 1.5), and the forcing table's and the Welch sums' parts
    (:func:`random_costs`); rk4's compiled steps with their tallies and alone on the same
    realisations (:data:`RANDOM_RK4_STEPS` steps a period, 440 periods); and the wall time
    [s] of the paper scene's run
    (:func:`paper_random_scene`, best of 2, once in quick mode; kernels loaded beforehand,
    the forcing's generation included: the issue's bound 10 s) and its trajectory-steps."""
    from .random import run_random

    duration, transient = (400, 40) if quick else (2000, 200)
    scene = random_scene((0.01,), RANDOM_LOCKSTEP, duration, transient, zeta=0.01)
    costs = random_costs(scene, repeats=1 if quick else 3)
    out: dict[str, Any] = {
        "random_ns_per_trajectory_step": costs["ns_per_trajectory_step"],
        "random_ratio_to_lockstep": costs["ns_per_trajectory_step"] / lockstep_ns,
        "random_compiled_ns_per_trajectory_step": costs["compiled_ns_per_trajectory_step"],
        "random_compiled_ratio_to_lockstep": costs["compiled_ns_per_trajectory_step"] / lockstep_ns,
        "random_untallied_ns_per_trajectory_step": costs["untallied_ns_per_trajectory_step"],
        "random_untallied_ratio_to_lockstep": costs["untallied_ns_per_trajectory_step"]
        / lockstep_ns,
        "random_forcing_ns_per_trajectory_step": costs["forcing_ns_per_trajectory_step"],
        "random_welch_ns_per_trajectory_step": costs["welch_ns_per_trajectory_step"],
    }
    # rk4 (advance_rk4 then accumulate) on the same realisations, 400 + 40 periods of 64 steps
    rk4 = random_scene((0.01,), RANDOM_LOCKSTEP, 400, 40, zeta=0.01)
    rk4 = replace(rk4, solver=replace(rk4.solver, method="rk4", steps_per_period=RANDOM_RK4_STEPS))
    costs = random_costs(rk4, repeats=1 if quick else 3)
    out["random_rk4_compiled_ns_per_trajectory_step"] = costs["compiled_ns_per_trajectory_step"]
    out["random_rk4_untallied_ns_per_trajectory_step"] = costs["untallied_ns_per_trajectory_step"]
    paper = paper_random_scene()
    out["random_paper_trajectory_steps"] = run_random(paper).steps
    out["random_paper_seconds"] = _best(lambda: run_random(paper), 1 if quick else 2)
    return out


# --------------------------------------------------------------------------- commands
CONFIGS = Path(__file__).resolve().parents[3] / "configs"  # a checkout's scenes and studies


def command_lines(python: str, program: str) -> dict[str, list[str]]:
    """The whole processes timed by :func:`command_times`: bare interpreters as floors, the
    package's import alone, and the commands as a shell, a Makefile or CI runs them (scene
    files of the checkout)."""
    scene = str(CONFIGS / "default.toml")
    study = str(CONFIGS / "studies" / "fig15.toml")
    return {
        "python_import_numpy": [python, "-c", "import numpy"],
        "python_import_numpy_numba": [python, "-c", "import numpy, numba"],
        "python_import_hertzsweep": [python, "-c", "import hertzsweep"],
        "help": [program, "--help"],
        "rig": [program, "rig", str(CONFIGS / "rig.toml")],
        "demo_sweep": [program, "sweep", scene, "-o", "{out}", "-q"],
        "shooting_sweep": [
            program, "sweep", scene, "-o", "{out}", "-q", "--set", "sweep.steady_state=shooting",
        ],
        "fig15_study_1_worker": [program, "study", study, "-o", "{out}", "-q", "--workers", "1"],
        "fig15_study_2_workers": [program, "study", study, "-o", "{out}", "-q", "--workers", "2"],
    }  # fmt: skip


def command_times(runs: int = 5, study_runs: int = 3) -> dict[str, Any]:
    """Median wall time [s] of each command of :func:`command_lines` as a process
    (``runs`` runs each, ``study_runs`` for the studies), the floors in the same run, and
    the ratios the issues set targets on. Empty when the checkout's configs are missing."""
    import shutil
    import statistics
    import subprocess
    import sys
    import tempfile

    program = shutil.which("hertzsweep") or str(Path(sys.executable).with_name("hertzsweep"))
    if not (CONFIGS / "default.toml").is_file() or not Path(program).exists():
        return {}
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as folder:
        for name, line in command_lines(sys.executable, program).items():
            count = study_runs if "study" in name else runs
            seconds = []
            for run in range(count + 1):  # the first run warms the caches, not timed
                target = str(Path(folder) / f"{name}-{run}.nc")
                argv = [part.replace("{out}", target) for part in line]
                start = time.perf_counter()
                subprocess.run(argv, check=True, stdout=subprocess.DEVNULL)
                if run:
                    seconds.append(time.perf_counter() - start)
            out[f"command_seconds_{name}"] = statistics.median(seconds)
    numpy_floor = out["command_seconds_python_import_numpy"]
    numba_floor = out["command_seconds_python_import_numpy_numba"]
    out["ratio_import_hertzsweep_to_import_numpy"] = (
        out["command_seconds_python_import_hertzsweep"] / numpy_floor
    )
    out["ratio_help_to_import_numpy"] = out["command_seconds_help"] / numpy_floor
    out["ratio_rig_to_import_numpy"] = out["command_seconds_rig"] / numpy_floor
    out["ratio_demo_sweep_to_import_numpy_numba"] = out["command_seconds_demo_sweep"] / numba_floor
    out["ratio_settle_to_shooting_sweep"] = (
        out["command_seconds_demo_sweep"] / out["command_seconds_shooting_sweep"]
    )
    out["fig15_study_speedup_2_workers"] = (
        out["command_seconds_fig15_study_1_worker"] / out["command_seconds_fig15_study_2_workers"]
    )
    return out


def sweep_process_times(scene: Scene, repeats: int = 5) -> dict[str, Any]:
    """Process (CPU) time of the scene's sweep by settling and by shooting, best of
    ``repeats``, kernels loaded beforehand: the issue's "shooting at least 10x faster"."""
    out: dict[str, Any] = {}
    for method in ("settle", "shooting"):
        variant = replace(scene, sweep=replace(scene.sweep, steady_state=method))
        run_sweep(variant)
        best = np.inf
        for _ in range(repeats):
            start = time.process_time()
            run_sweep(variant)
            best = min(best, time.process_time() - start)
        out[f"process_seconds_{method}_sweep"] = best
    out["process_ratio_settle_to_shooting"] = (
        out["process_seconds_settle_sweep"] / out["process_seconds_shooting_sweep"]
    )
    return out


def model_costs(scene: Scene, repeats: int = 5) -> dict[str, Any]:
    """Wall time of the scene's sweep with each model (``model.kind``), best of
    ``repeats``, kernels loaded beforehand, and the ball model's over the single one's
    (the same steps per period, the same dwells)."""
    out: dict[str, Any] = {}
    for kind in ("single", "ball"):
        variant = replace(
            scene,
            model=replace(scene.model, kind=kind),
            sweep=replace(scene.sweep, steady_state="settle"),
        )
        run_sweep(variant)
        out[f"model_seconds_{kind}_sweep"] = _best(
            lambda variant=variant: run_sweep(variant), repeats
        )
    out["model_ratio_ball_to_single"] = (
        out["model_seconds_ball_sweep"] / out["model_seconds_single_sweep"]
    )
    return out


def run_all(quick: bool = False) -> dict[str, Any]:
    """Every figure (what ``hertzsweep bench --json`` prints): numbers by name, and the
    comparison at equal accuracy as two lists of rows, ``equal_accuracy_references`` (one
    per dwell) and ``equal_accuracy`` (one per dwell, target and competitor)."""
    out: dict[str, Any] = {}
    steps = 2_000_000 if quick else 20_000_000
    out["floor_ns_per_step"] = floor_ns_per_step(steps)
    for name, (law, exponent) in LAWS.items():
        out[f"ns_per_step_{name}"] = ns_per_step(law, exponent, steps)
    out["ratio_to_floor_viscous"] = out["ns_per_step_viscous"] / out["floor_ns_per_step"]
    out["floor_ns_per_trajectory_step_16"] = floor_ns_per_trajectory_step(16, steps)
    for key, value in bench_batch(repeats=1 if quick else 3).items():
        out[f"batch_{key}"] = value
    out["floor_ns_per_trajectory_step_16_divided"] = floor_ns_per_trajectory_step_divided(16, steps)
    for law in ("viscous", "contact"):
        out[f"batch_ratio_to_floor_{law}_16"] = (
            out[f"batch_{law}_ns_per_trajectory_step_16"] / out["floor_ns_per_trajectory_step_16"]
        )
    out["batch_measure_ratio_to_floor_viscous_16"] = (
        out["batch_measure_viscous_ns_per_trajectory_step_16"]
        / out["floor_ns_per_trajectory_step_16"]
    )
    out["batch_ratio_to_divided_floor_contact_16"] = (
        out["batch_contact_ns_per_trajectory_step_16"]
        / out["floor_ns_per_trajectory_step_16_divided"]
    )
    out.update(random_figures(out["batch_viscous_ns_per_trajectory_step_16"], quick))
    scene = bench_scene(31 if quick else 121)
    out["sweep_points"] = int(scene.sweep.frequency_ratios.size)
    out["sweep_dwells"] = out["sweep_points"] * len(scene.sweep.directions)
    seconds, sweep_steps = sweep_wall_time(scene)
    out["sweep_seconds"] = seconds
    out["sweep_steps"] = sweep_steps
    out["sweep_ns_per_step"] = seconds / sweep_steps * 1e9
    for key, value in compare_with_settle(bench_scene(16) if quick else scene).items():
        out[f"shooting_{key}"] = value
    if (CONFIGS / "default.toml").is_file():
        from ..core.config import load_scene

        default = load_scene(CONFIGS / "default.toml")
        out.update(sweep_process_times(default))
        out.update(model_costs(default, repeats=2 if quick else 5))
    out.update(command_times(runs=2 if quick else 5, study_runs=1 if quick else 3))
    compared = equal_accuracy(DWELLS[:1] if quick else DWELLS)
    out["equal_accuracy_references"] = compared["references"]
    out["equal_accuracy"] = compared["rows"]
    return out


__all__ = [
    "DWELLS",
    "TARGETS",
    "Dwell",
    "bench_batch",
    "cd_h1",
    "compare_dwell",
    "compare_with_settle",
    "competitors",
    "equal_accuracy",
    "ivp_h1",
    "random_costs",
    "random_figures",
    "random_scene",
    "numbalsoda_h1",
    "reference",
    "richardson_h1",
    "rk4_h1",
    "run_all",
]
