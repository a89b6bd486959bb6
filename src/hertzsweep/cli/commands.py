"""``hertzsweep rig`` and ``hertzsweep validate``: the configuration layer only (no
compiler, no xarray: they start in a blink)."""

from __future__ import annotations

import json
import math

import click

from ..api.choices import RIG_UNITS, STABILITY, format_size
from . import options
from .group import cli

RIG_LABELS = {  # rig constant -> its printed label, with the paper's equation
    "contact_stiffness": "contact stiffness k (eq. 12)",
    "static_compression": "static compression z_s (eq. 2)",
    "natural_circular_frequency": "natural circular frequency Omega (eq. 3)",
    "natural_frequency": "natural frequency f0 (eq. 15)",
    "static_load": "static load F_s",
    "contact_pressure": "static contact pressure p0 (Hertz)",
    "contact_radius": "static contact radius a (Hertz)",
    "ball_mode_frequency": "ball's own mode (2-dof estimate)",
    "hertz_contact_stiffness": "contact stiffness k, Hertz (eq. 12)",
    "hertz_natural_frequency": "natural frequency f0, Hertz (eq. 15)",
}
MEASURED_LABELS = {  # the labels that change when the rig gives a measured f0
    "contact_stiffness": "contact stiffness k (from the measured f0)",
    "static_compression": "static compression z_s (eq. 2, measured f0)",
    "natural_circular_frequency": "natural circular frequency Omega (measured)",
    "natural_frequency": "natural frequency f0 (rig.natural_frequency)",
}
HERTZ_ONLY = ("hertz_contact_stiffness", "hertz_natural_frequency")  # shown beside a measured f0


@cli.command("rig")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
def rig_command(file: str, as_json: bool) -> None:
    """Derived constants of a rig, or of a scene's rig (eq. 2, 3, 12, 15)."""
    from ..api.runs import rig_report

    constants, measured = rig_report(file)
    if as_json:
        defined = {
            k: None if isinstance(v, float) and math.isnan(v) else v for k, v in constants.items()
        }
        click.echo(json.dumps(defined, indent=2))
        return
    for key, value in constants.items():
        if key in HERTZ_ONLY and not measured:
            continue  # the same values as k and f0
        label = (MEASURED_LABELS if measured else {}).get(key) or RIG_LABELS.get(
            key, key.replace("_", " ")
        )
        unit = RIG_UNITS.get(key, "")
        text = "n/a (single sphere-plane)" if math.isnan(value) else f"{value:.6g} {unit}"
        click.echo(f"{label:44s} {text}")


@cli.command("validate")
@options.scene_argument
@options.set_option
def validate_command(scene_file: str, overrides: tuple[str, ...]) -> None:
    """Check a scene: exit 0, or one line naming file, key and reason, exit 2."""
    from ..api.runs import validate

    scene, figures = validate(scene_file, options.parse_overrides(overrides))
    steps = scene.solver.steps_per_period
    limit = figures.stability_limit
    mode = ", omega_max of the ball's own mode" if scene.model.kind == "ball" else ""
    trajectories = f"{figures.trajectories} trajector{'y' if figures.trajectories == 1 else 'ies'}"
    if scene.excitation.kind == "random":
        low, high = scene.excitation.band
        what = (
            f"random: {len(scene.excitation.rms)} rms x {scene.random.realisations} "
            f"realisation(s) ({trajectories} of {scene.random.transient_periods} + "
            f"{scene.random.duration_periods} periods); band {low:g} .. {high:g}"
        )
    else:
        what = (
            f"{len(scene.sweep.directions)} direction(s) x {len(scene.excitation.sigma)} "
            f"sigma x {figures.points} frequencies ({trajectories} of "
            f"{figures.periods_per_dwell} periods a dwell)"
        )
    click.echo(
        f"{scene_file}: ok: {what}; "
        f"steps_per_period {steps} is {figures.stability_margin:.1f}x the stability limit "
        f"{limit:.1f} of {scene.solver.method} (h omega_max < "
        f"{STABILITY[scene.solver.method]:.3g}{mode}); {figures.steps:.3g} integration steps "
        f"of the budget {figures.max_steps:.3g}; results {format_size(figures.memory)} of the "
        f"budget {format_size(figures.memory_budget)}"
    )
