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
from ..drivers.sweep import dwell_count
from ..errors import Interrupted
from ..output.dataset import write_atomic
from ..output.kinds import KINDS
from . import options
from .group import cli
from .progress import progress_bar

SWEEP = KINDS["sweep"]
# the variable OUT.partial.nc adds: which (direction, sigma) sweeps ran to their end
FINISHED_ATTRS = {"long_name": "that sweep ran to its end", "units": "1"}
RIG_LABELS = {  # rig constant -> its printed label, with the paper's equation
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
    return None if set(raw) == {"rig"} else options.read_scene(path)


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
        defined = {
            k: None if isinstance(v, float) and math.isnan(v) else v for k, v in constants.items()
        }
        click.echo(json.dumps(defined, indent=2))
        return
    for key, value in constants.items():
        label = RIG_LABELS.get(key, key.replace("_", " "))
        unit = UNITS.get(key, "")
        text = "n/a (single sphere-plane)" if math.isnan(value) else f"{value:.6g} {unit}"
        click.echo(f"{label:44s} {text}")


@cli.command("validate")
@options.scene_argument
@options.set_option
def validate_command(scene_file: str, overrides: tuple[str, ...]) -> None:
    """Check a scene: exit 0, or one line naming file, key and reason, exit 2."""
    scene = options.read_scene(scene_file, overrides)
    check_stability(scene)
    limit = stability_limit(scene)
    steps = scene.solver.steps_per_period
    click.echo(
        f"{scene_file}: ok: {len(scene.sweep.directions)} direction(s) x "
        f"{len(scene.excitation.sigma)} sigma x {scene.sweep.frequency_ratios.size} frequencies; "
        f"steps_per_period {steps} is {steps / limit:.1f}x the stability limit {limit:.1f}"
    )


@cli.command("sweep")
@options.scene_argument
@options.output_option
@options.set_option
@options.quiet_option
def sweep_command(scene_file: str, output: str, overrides: tuple[str, ...], quiet: bool) -> None:
    """Stepped-sine sweeps, up and/or down, for every sigma; prints a short table."""
    scene = options.read_scene(scene_file, overrides)
    try:
        with progress_bar(dwell_count(scene), "sweep", not quiet) as progress:
            result = SWEEP.run(scene, progress)
    except Interrupted as exc:
        keep_partial(exc, scene, output)
        raise
    options.write_result(SWEEP, result, scene, output)


def keep_partial(exc: Interrupted, scene, output: str) -> None:
    """Write the finished sweeps of an interrupted run to ``OUT.partial.nc`` (atomically;
    dwells not reached are NaN, attribute ``complete = 0``); the output itself stays absent."""
    result = exc.partial
    if result is None or not result.finished.any():
        return
    ds = SWEEP.build(result, scene)
    ds["finished"] = (("direction", "sigma"), result.finished.astype(np.int8), FINISHED_ATTRS)
    ds.attrs["complete"] = 0
    partial = Path(output).with_suffix(".partial.nc")
    write_atomic(ds, partial)
    click.echo(f"kept {int(result.finished.sum())} finished sweep(s) in {partial}", err=True)
