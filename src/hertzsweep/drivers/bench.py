"""The project's own speed figures (``hertzsweep bench``); not timed tests.

Figures, each against a floor named in the issues:

- ns per integration step of the compiled loop on one trajectory (floor: a hand-written C
  loop of the same scheme, 15 ns per step on the 2-core reference machine);
- wall time of a 121-point up + down sweep (w 0.90 to 1.05, 256 steps per period,
  300 settle + 20 measured periods, sigma = 1 %);
- the same sweep with ``scipy.integrate.solve_ivp`` (DOP853, the loosest tolerance for
  which H1 agrees with a tight reference to 1e-4), measured on a few frequencies and
  extrapolated to the whole sweep, and the ratio (target: at least 100x);
- when present: shooting-accelerated vs settled sweep (steps and time), and batched
  trajectories (ns per trajectory-step; floor 2.9 ns for 8 trajectories in C).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from ..core.config import Scene, scene_from_dict
from ..core.lockin import demodulate
from ..core.model import VISCOUS
from ..kernels import integrators
from .sweep import run_sweep

C_FLOOR_NS = 15.0  # hand-written C loop of the same scheme, one trajectory (issue)
C_BATCH_FLOOR_NS = 2.9  # hand-written C loop, 8 trajectories together (issue)
PAPER_RIG = {
    "ball_radius": 12.7e-3,
    "youngs_modulus": 210e9,
    "poisson_ratio": 0.29,
    "mass": 11.4,
    "static_load": 110.0,
}


def bench_scene(points: int = 121) -> Scene:
    """The benchmark sweep: sigma = 1 %, zeta = 0.45 % viscous, w 0.90..1.05."""
    step = 0.15 / (points - 1)
    return scene_from_dict(
        {
            "rig": dict(PAPER_RIG),
            "damping": {"ratio": 0.0045, "law": "viscous"},
            "excitation": {"sigma": [0.01]},
            "sweep": {"start": 0.90, "stop": 1.05, "step": step, "settle_periods": 300,
                      "measure_periods": 20},
            "solver": {"steps_per_period": 256},
            "lockin": {"harmonics": [1, 2]},
        },
        source="<bench>",
    )  # fmt: skip


def ns_per_step(law: int = VISCOUS, exponent: float = 1.5, steps: int = 20_000_000) -> float:
    """Best of 3 runs of the compiled loop on one trajectory, ns per step."""
    n = 256
    sin_table, _ = integrators.period_tables(n)
    h = integrators.step_size(0.97, n)
    periods = max(1, steps // n)
    integrators.advance(0.0, 0.0, h, 0.01, sin_table, 1, 0.0045, law, exponent)  # compile
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        integrators.advance(0.0, 0.0, h, 0.01, sin_table, periods, 0.0045, law, exponent)
        best = min(best, time.perf_counter() - t0)
    return best / (periods * n) * 1e9


def sweep_wall_time(scene: Scene) -> tuple[float, int]:
    """Wall time [s] (best of 2) and integration steps of the scene's sweep."""
    run_sweep(replace(scene, sweep=replace(scene.sweep, stop=scene.sweep.start)))  # compile
    best, steps = np.inf, 0
    for _ in range(2):
        t0 = time.perf_counter()
        result = run_sweep(scene)
        best = min(best, time.perf_counter() - t0)
        steps = result.steps
    return best, steps


def _ivp_dwell(w, sigma, zeta, y0, periods, measure, rtol):
    """solve_ivp over ``periods`` periods; H1 of N/F_s over the last ``measure``."""

    def rhs(t, y):
        d = 1.0 + 2.0 * y[0] / 3.0
        restoring = d * np.sqrt(d) if d > 0 else 0.0
        return [y[1], 1.0 + sigma * np.sin(w * t) - restoring - 2.0 * zeta * y[1]]

    period = 2.0 * np.pi / w
    samples = 256
    t_eval = period * (periods - measure + np.arange(measure * samples) / samples)
    sol = solve_ivp(rhs, (0.0, periods * period), y0, method="DOP853", rtol=rtol,
                    atol=rtol * 1e-2, t_eval=t_eval)  # fmt: skip
    q, v = sol.y
    d = np.maximum(1.0 + 2.0 * q / 3.0, 0.0)
    force = d * np.sqrt(d) + 2.0 * zeta * v
    _, amplitude, _ = demodulate(force, [1], samples)
    return amplitude[0], sol.y[:, -1]


def solve_ivp_comparison(scene: Scene, frequencies=(0.93, 0.97, 1.01)) -> dict[str, Any]:
    """Per-dwell cost of solve_ivp (DOP853) at the loosest tolerance meeting 1e-4 in H1,
    extrapolated to the scene's whole sweep."""
    sigma, zeta = scene.excitation.sigma[0], scene.damping.ratio
    settle, measure = scene.sweep.settle_periods or 300, scene.sweep.measure_periods
    w0 = frequencies[len(frequencies) // 2]
    start = [0.0, 0.0]
    # the tolerance is checked on the very dwell that is timed (settle + measure periods)
    periods = settle + measure
    reference, _ = _ivp_dwell(w0, sigma, zeta, start, periods, measure, 1e-12)
    chosen = None
    for rtol in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10):
        h1, _ = _ivp_dwell(w0, sigma, zeta, start, periods, measure, rtol)
        if abs(h1 - reference) <= 1e-4 * abs(reference):
            chosen = rtol
            break
    chosen = chosen or 1e-10
    times = []
    for w in frequencies:
        t0 = time.perf_counter()
        _ivp_dwell(w, sigma, zeta, start, settle + measure, measure, chosen)
        times.append(time.perf_counter() - t0)
    dwells = len(scene.sweep.directions) * scene.sweep.frequency_ratios.size
    return {"rtol": chosen, "seconds_per_dwell": float(np.mean(times)),
            "extrapolated_sweep_seconds": float(np.mean(times) * dwells)}  # fmt: skip


def run_all(quick: bool = False) -> dict[str, Any]:
    """Every figure, as a flat dict (what ``hertzsweep bench --json`` prints)."""
    out: dict[str, Any] = {}
    steps = 2_000_000 if quick else 20_000_000
    out["ns_per_step_viscous"] = ns_per_step(VISCOUS, steps=steps)
    out["ns_per_step_contact_n1.5"] = ns_per_step(4, 1.5, steps=steps)
    out["ns_per_step_contact_general_n"] = ns_per_step(5, 1.3, steps=steps)
    out["c_floor_ns_per_step"] = C_FLOOR_NS
    out["ratio_to_c_floor"] = out["ns_per_step_viscous"] / C_FLOOR_NS
    scene = bench_scene(31 if quick else 121)
    out["sweep_points"] = int(scene.sweep.frequency_ratios.size)
    out["sweep_dwells"] = out["sweep_points"] * len(scene.sweep.directions)
    seconds, sweep_steps = sweep_wall_time(scene)
    out["sweep_seconds"] = seconds
    out["sweep_steps"] = sweep_steps
    out["sweep_ns_per_step"] = seconds / sweep_steps * 1e9
    ivp = solve_ivp_comparison(scene, (0.97,) if quick else (0.93, 0.97, 1.01))
    out["solve_ivp_rtol"] = ivp["rtol"]
    out["solve_ivp_seconds_per_dwell"] = ivp["seconds_per_dwell"]
    out["solve_ivp_sweep_seconds_extrapolated"] = ivp["extrapolated_sweep_seconds"]
    out["speedup_vs_solve_ivp"] = ivp["extrapolated_sweep_seconds"] / seconds
    out.update(_optional_figures(scene, quick))
    return out


def _optional_figures(scene: Scene, quick: bool) -> dict[str, Any]:
    """Figures of the shooting and batch layers."""
    out: dict[str, Any] = {}
    try:
        from .shooting import compare_with_settle
    except ImportError:
        pass
    else:
        small = scene if not quick else bench_scene(16)
        for key, value in compare_with_settle(small).items():
            out[f"shooting_{key}"] = value
    try:
        from .batch import bench_batch
    except ImportError:
        pass
    else:
        for key, value in bench_batch().items():
            out[f"batch_{key}"] = value
        per = out.get("batch_ns_per_trajectory_step_8")
        if per is not None:
            out["batch_ratio_to_c_floor_8"] = per / C_BATCH_FLOOR_NS
    return out
