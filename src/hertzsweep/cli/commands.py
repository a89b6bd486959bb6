"""Core commands: rig, validate, sweep."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click
import numpy as np

from ..core.config import load_rig
from ..core.model import check_stability, stability_limit
from ..core.rig import UNITS, derive
from ..drivers.sweep import dwell_count, run_sweep
from ..errors import Interrupted
from ..output.dataset import sweep_dataset, write_atomic
from . import cli
from .options import output_option, quiet_option, read_scene, scene_argument, set_option
from .progress import progress_bar

RIG_LABELS = {
    "contact_stiffness": "contact stiffness k (eq. 12)",
    "static_compression": "static compression z_s (eq. 2)",
    "natural_circular_frequency": "natural circular frequency Omega (eq. 3)",
    "natural_frequency": "natural frequency f0 (eq. 15)",
    "static_load": "static load F_s",
    "contact_pressure": "static contact pressure p0 (Hertz)",
    "contact_radius": "static contact radius a (Hertz)",
    "ball_mode_frequency": "ball's own mode (2-dof estimate)",
}


def _scene_or_none(path: str):
    """The scene of a scene file, or None for a bare rig file."""
    from ..core.config import read_toml

    raw = read_toml(path)
    return None if set(raw) == {"rig"} else read_scene(path)


@cli.command("rig")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
def rig_command(file: str, as_json: bool) -> None:
    """Derived constants of a rig, or of a scene's rig (eq. 2, 3, 12, 15)."""
    constants = derive(load_rig(file)).as_dict()
    scene = _scene_or_none(file)
    if scene is not None:
        limit = stability_limit(scene)
        constants["stability_limit_steps_per_period"] = limit
        constants["stability_margin"] = scene.solver.steps_per_period / limit
    if as_json:
        click.echo(json.dumps({k: (None if isinstance(v, float) and math.isnan(v) else v)
                               for k, v in constants.items()}, indent=2))  # fmt: skip
        return
    for key, value in constants.items():
        label = RIG_LABELS.get(key, key.replace("_", " "))
        unit = UNITS.get(key, "")
        text = "n/a (single sphere-plane)" if math.isnan(value) else f"{value:.6g} {unit}"
        click.echo(f"{label:44s} {text}")


@cli.command("validate")
@scene_argument
@set_option
def validate_command(scene_file: str, overrides: tuple[str, ...]) -> None:
    """Check a scene: exit 0, or one line naming file, key and reason, exit 2."""
    scene = read_scene(scene_file, overrides)
    check_stability(scene)
    limit = stability_limit(scene)
    steps = scene.solver.steps_per_period
    click.echo(
        f"{scene_file}: ok: {len(scene.sweep.directions)} direction(s) x "
        f"{len(scene.excitation.sigma)} sigma x {scene.sweep.frequency_ratios.size} frequencies; "
        f"steps_per_period {steps} is {steps / limit:.1f}x the stability limit {limit:.1f}"
    )


@cli.command("sweep")
@scene_argument
@output_option
@set_option
@quiet_option
def sweep_command(scene_file: str, output: str, overrides: tuple[str, ...], quiet: bool) -> None:
    """Stepped-sine sweeps, up and/or down, for every sigma; prints a short table."""
    scene = read_scene(scene_file, overrides)
    try:
        with progress_bar(dwell_count(scene), "sweep", not quiet) as progress:
            result = run_sweep(scene, progress)
    except Interrupted as exc:
        keep_partial(exc, scene, output)
        raise
    ds = sweep_dataset(result, scene)
    write_atomic(ds, output)
    click.echo(summary_table(ds))
    click.echo(f"wrote {output}")


def keep_partial(exc: Interrupted, scene, output: str) -> None:
    """Write the finished sweeps of an interrupted run to ``OUT.partial.nc`` (atomically;
    dwells not reached are NaN, attribute ``complete = 0``); the output itself stays absent."""
    result = exc.partial
    if result is None or not result.finished.any():
        return
    ds = sweep_dataset(result, scene)
    ds["finished"] = (("direction", "sigma"), result.finished.astype(np.int8),
                      {"long_name": "that sweep ran to its end", "units": "1"})  # fmt: skip
    ds.attrs["complete"] = 0
    partial = Path(output).with_suffix(".partial.nc")
    write_atomic(ds, partial)
    click.echo(f"kept {int(result.finished.sum())} finished sweep(s) in {partial}", err=True)


def summary_table(ds) -> str:
    """A short table: per direction and sigma, the H1 peak and the jump."""
    lines = [f"{'direction':9s} {'sigma':>8s} {'peak H1':>8s} {'at w':>7s} {'jump w':>7s} "
             f"{'N max':>6s} {'N min':>6s} {'loss':>5s}"]  # fmt: skip
    for direction in ds.direction.values:
        for sigma in ds.sigma.values:
            sel = ds.sel(direction=direction, sigma=sigma)
            h1 = sel.amplitude.isel(harmonic=0).values
            i = int(np.nanargmax(h1))
            jump = float(sel.jump_frequency_ratio)
            lines.append(
                f"{direction:9s} {sigma:8.4g} {h1[i]:8.4f} {float(sel.frequency_ratio[i]):7.4f} "
                f"{'-' if math.isnan(jump) else f'{jump:.4f}':>7s} "
                f"{float(sel.force_max.max()):6.3f} {float(sel.force_min.min()):6.3f} "
                f"{float(sel.contact_loss_fraction.max()):5.2f}"
            )
    return "\n".join(lines)
