"""``hertzsweep fit MEASURED --scene SCENE --free KEY[,KEY] -o FIT.nc``: the model's
parameters identified from measurements by least squares
(:func:`hertzsweep.drivers.fit.fit`)."""

from __future__ import annotations

import json

import click

from ..api.choices import FIT_FREE_KEYS, FIT_METHODS
from . import options
from .group import cli

FREE_HELP = f"Parameters to fit, comma-separated: any of {', '.join(FIT_FREE_KEYS)}."
METHOD_HELP = (
    "Model evaluation: linear (response of eq. 8 linearised), shooting (sweeps of periodic "
    "orbits), fold (jump frequencies); auto picks by the data."
)
LAWS_HELP = (
    "Fit damping.ratio with the contact law's n fixed at 0, 1/2, 1, 3/2 and with n free; "
    "print the table of residuals (as Figure 15 against Figure 11)."
)


@cli.command("fit")
@click.argument("measured_file", metavar="MEASURED", type=click.Path(dir_okay=False))
@click.option(
    "--scene",
    "scene_file",
    required=True,
    type=click.Path(dir_okay=False),
    metavar="SCENE",
    help="The scene: rig, damping law, solver; its values start the search.",
)
@click.option("--free", "free_text", required=True, metavar="KEY[,KEY...]", help=FREE_HELP)
@options.output_option
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@click.option("--compare-laws", is_flag=True, help=LAWS_HELP)
@click.option("--method", type=click.Choice(FIT_METHODS), default="auto", help=METHOD_HELP)
@options.set_option
@options.quiet_option
def fit_command(
    measured_file: str,
    scene_file: str,
    free_text: str,
    output: str,
    as_json: bool,
    compare_laws: bool,
    method: str,
    overrides: tuple[str, ...],
    quiet: bool,
) -> None:
    """Fit rig.natural_frequency, damping.ratio and/or damping.exponent to MEASURED (a
    CSV file or a dataset of `hertzsweep import`) by least squares: H1 amplitude and
    phase of sweeps, or jump frequencies. Prints the estimates with their standard
    errors and correlations and the residual RMS; FIT.nc holds them with the data and
    the fitted model at every measured point."""
    from ..api.runs import fit_json, run_fit

    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, (measured_file, *scene.inputs))
    free = free_text.split(",")
    run = run_fit(measured_file, scene, free, method, compare_laws, options.progress(quiet))
    options.files.write(run.frame, output)
    if as_json:
        click.echo(json.dumps(fit_json(run.result, output), indent=2))
        return
    click.echo(run.summary())
    click.echo(f"wrote {output}")


__all__ = ["fit_command"]
