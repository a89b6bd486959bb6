"""Compile every kernel specialisation into numba's cache ahead of the first run.

numba compiles a kernel on its first call with a new damping-law type (the laws are
namedtuple types, :mod:`hertzsweep.kernels.laws`) and caches the machine code on disk;
a fresh install therefore pays about 1.5 s of compilation on each command's first run,
and the test suite about a minute in all. ``python -m hertzsweep.drivers.warm`` (run by
``make install``) runs tiny scenes through every driver path (the sweep in lockstep and
one trajectory at a time, automatic settling, shooting, a trace, a branch; sweeps,
shooting and a branch also with ``rk4``; the ball model's sweeps, shooting, trace and
branch) for every
law type, one group of laws per process, so that the compilation is paid once, at
install, spread over the cores. It changes no result: the cache holds what the first
run would have compiled. :func:`load_kernels` loads a sweep case's kernels from that
cache (a study's workers call it as they start).
"""

from __future__ import annotations

import os
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

from ..core.config import ModelConfig, scene_from_dict

# one scene per law type (hertzsweep.kernels.laws.LAWS): (law, exponent) of Viscous,
# Contact (the paper's n) and ContactPower (any other n)
LAW_SETTINGS = (("viscous", 1.5), ("contact", 1.5), ("contact", 0.7))
TINY_SCENE = {  # a few dwells of a few periods: cheap, and every code path of a driver
    "rig": {"ball_radius": 0.0127, "youngs_modulus": 2.1e11, "poisson_ratio": 0.29, "mass": 11.4},
    "excitation": {"sigma": [0.05, 0.08]},
    "sweep": {"start": 0.9, "stop": 0.96, "step": 0.03, "settle_periods": 4, "measure_periods": 2},
    "solver": {"steps_per_period": 32},
    "lockin": {"harmonics": [1, 2]},
}


def compile_law(law: str, exponent: float) -> str:
    """Run every driver path once on a tiny scene with this damping law."""
    from .continuation import run_branch
    from .sweep import run_sweep
    from .trace import run_trace

    raw = {**TINY_SCENE, "damping": {"law": law, "ratio": 0.01, "exponent": exponent}}
    scene = scene_from_dict(raw, source="<warm-up>")
    run_sweep(scene, ball_mode=True)
    run_sweep(scene, batched=False, ball_mode=True)
    automatic = replace(scene.sweep, settle_periods=None, max_settle_periods=8)
    shooting = replace(scene.sweep, steady_state="shooting")
    for sweep in (automatic, shooting):
        run_sweep(replace(scene, sweep=sweep))
    run_trace(scene, 0.92, periods=2)
    short = replace(scene.sweep, start=0.9, stop=0.92, step=0.01)
    run_branch(replace(scene, sweep=short))
    rk4 = replace(scene, solver=replace(scene.solver, method="rk4"))
    run_sweep(rk4, ball_mode=True)
    run_sweep(rk4, batched=False)
    run_sweep(replace(rk4, sweep=shooting))
    run_branch(replace(rk4, sweep=short))
    # the ball model (its mode needs finer steps than the tiny scene's)
    ball = replace(
        scene, model=ModelConfig("ball"), solver=replace(scene.solver, steps_per_period=256)
    )
    run_sweep(ball)
    run_sweep(ball, batched=False)
    run_sweep(replace(ball, sweep=shooting))
    run_trace(ball, 0.92, periods=2)
    run_branch(replace(ball, sweep=short))
    return f"{law} n={exponent}"


def load_kernels() -> None:
    """Load the compiled kernels a sweep case uses for every law type (numba's cache; its
    runtime starts on the first load, about 0.5 s), so that a study's worker is warm
    before its first case."""
    import numpy as np

    from ..kernels import integrate, scheme
    from ..kernels.laws import make_law
    from .oscillator import drive

    scene = scene_from_dict(TINY_SCENE, source="<warm-up>")
    h = np.full(2, scheme.step_size(1.0, scene.solver.steps_per_period))
    inputs = drive(scene, scene.excitation.sigma)
    buffers = integrate.new_readout(len(scene.lockin.harmonics), 2)
    for law, exponent in LAW_SETTINGS:
        record = make_law(law, 0.01, exponent)
        integrate.advance_batch(np.zeros(2), np.zeros(2), h.copy(), record, inputs, 1)
        integrate.measure(np.zeros(2), np.zeros(2), h.copy(), record, inputs, 1, buffers)
        integrate.retune_batch(np.zeros(2), np.zeros(2), h.copy(), 1.01 * h, record)


def compile_all(workers: int | None = None) -> list[str]:
    """Compile every law's kernels, one law per process (at most ``workers``)."""
    workers = workers or min(len(LAW_SETTINGS), os.cpu_count() or 1)
    if workers == 1:
        return [compile_law(*setting) for setting in LAW_SETTINGS]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(compile_law, *zip(*LAW_SETTINGS, strict=True)))


if __name__ == "__main__":
    done = compile_all()
    print(f"hertzsweep: kernels compiled for {', '.join(done)}", file=sys.stderr)
