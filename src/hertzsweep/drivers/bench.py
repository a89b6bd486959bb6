"""The project's own speed figures (``hertzsweep bench``); not timed tests.

Every ratio is measured in the same run, never typed in:

- ns per integration step of the compiled loop on one trajectory, for each damping law,
  against the *floor*: the bare recurrence of the viscous update (state in
  ``d = 1 + 2q/3``, a square root then one FMA per step, nothing else) compiled the same
  way on this CPU;
- ns per trajectory-step of many trajectories in lockstep (8 and 16), against the bare
  recurrence vectorised across 16 trajectories (the throughput floor of the CPU's vector
  square root);
- wall time of a 121-point up + down sweep (w 0.90 to 1.05, 256 steps per period,
  300 settle + 20 measured periods, sigma = 1 %), and the same sweep with
  ``scipy.integrate.solve_ivp`` (DOP853, the loosest tolerance for which H1 agrees with a
  tight reference to 1e-4), measured on a few frequencies and extrapolated;
- shooting-accelerated vs settled sweep (steps and time, the same jumps).
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from scipy.integrate import solve_ivp

from ..core.config import Scene, scene_from_dict
from ..core.lockin import demodulate
from ..core.model import check_stability
from ..kernels import CACHE, integrate, scheme
from ..kernels.laws import make_law
from ..kernels.scheme import fma
from .oscillator import drive
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


@njit(cache=CACHE, error_model="numpy")
def _bare_lanes(d, a, b, k, loads, periods):
    """:func:`_bare_chain` for T trajectories, trajectory innermost (vectorised): the
    throughput floor of the update across trajectories."""
    d_prev = d.copy()
    for _ in range(periods):
        for j in range(loads.shape[0]):
            load = loads[j]
            for t in range(d.shape[0]):
                x = d[t]
                kt = k[t]
                d[t] = fma(-(kt * x), math.sqrt(x), fma(x, a[t], kt * load - d_prev[t] * b[t]))
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
    _bare_lanes(np.ones(count), a, b, k, loads, 1)
    seconds = _best(lambda: _bare_lanes(np.ones(count), a, b, k, loads, periods))
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
    trajectories, viscous and contact n = 3/2, readings and jumps included."""
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
    return out


def sweep_wall_time(scene: Scene) -> tuple[float, int]:
    """Wall time [s] (best of 2) and integration steps of the scene's sweep."""
    run_sweep(replace(scene, sweep=replace(scene.sweep, stop=scene.sweep.start)))  # compile
    steps = run_sweep(scene).steps
    return _best(lambda: run_sweep(scene), 2), steps


def _ivp_dwell(w, sigma, zeta, y0, periods, measure, rtol):
    """solve_ivp over ``periods`` periods; H1 of N/F_s over the last ``measure``."""

    def rhs(t, y):
        d = 1.0 + 2.0 * y[0] / 3.0
        restoring = d * np.sqrt(d) if d > 0 else 0.0
        return [y[1], 1.0 + sigma * np.sin(w * t) - restoring - 2.0 * zeta * y[1]]

    period = 2.0 * np.pi / w
    samples = 256
    t_eval = period * (periods - measure + np.arange(measure * samples) / samples)
    sol = solve_ivp(
        rhs,
        (0.0, periods * period),
        y0,
        method="DOP853",
        rtol=rtol,
        atol=rtol * 1e-2,
        t_eval=t_eval,
    )
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
    return {
        "rtol": chosen,
        "seconds_per_dwell": float(np.mean(times)),
        "extrapolated_sweep_seconds": float(np.mean(times) * dwells),
    }


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


# --------------------------------------------------------------------------- commands
CONFIGS = Path(__file__).resolve().parents[3] / "configs"  # a checkout's scenes and studies


def command_lines(python: str, program: str) -> dict[str, list[str]]:
    """The whole processes timed by :func:`command_times`: bare interpreters as floors, and
    the commands as a shell, a Makefile or CI runs them (scene files of the checkout)."""
    scene = str(CONFIGS / "default.toml")
    study = str(CONFIGS / "studies" / "fig15.toml")
    return {
        "python_import_numpy": [python, "-c", "import numpy"],
        "python_import_numpy_numba": [python, "-c", "import numpy, numba"],
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


def run_all(quick: bool = False) -> dict[str, Any]:
    """Every figure, as a flat dict (what ``hertzsweep bench --json`` prints)."""
    out: dict[str, Any] = {}
    steps = 2_000_000 if quick else 20_000_000
    out["floor_ns_per_step"] = floor_ns_per_step(steps)
    for name, (law, exponent) in LAWS.items():
        out[f"ns_per_step_{name}"] = ns_per_step(law, exponent, steps)
    out["ratio_to_floor_viscous"] = out["ns_per_step_viscous"] / out["floor_ns_per_step"]
    out["floor_ns_per_trajectory_step_16"] = floor_ns_per_trajectory_step(16, steps)
    for key, value in bench_batch(repeats=1 if quick else 3).items():
        out[f"batch_{key}"] = value
    for law in ("viscous", "contact"):
        out[f"batch_ratio_to_floor_{law}_16"] = (
            out[f"batch_{law}_ns_per_trajectory_step_16"] / out["floor_ns_per_trajectory_step_16"]
        )
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
    for key, value in compare_with_settle(bench_scene(16) if quick else scene).items():
        out[f"shooting_{key}"] = value
    if (CONFIGS / "default.toml").is_file():
        from ..core.config import load_scene

        out.update(sweep_process_times(load_scene(CONFIGS / "default.toml")))
    out.update(command_times(runs=2 if quick else 5, study_runs=1 if quick else 3))
    return out


__all__ = ["bench_batch", "compare_with_settle", "run_all"]
