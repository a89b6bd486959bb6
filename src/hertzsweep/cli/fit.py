"""``hertzsweep fit MEASURED --scene SCENE --free KEY[,KEY] -o FIT.nc``: the model's
parameters identified from measurements by least squares
(:func:`hertzsweep.drivers.fit.fit`)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from ..drivers.fit import FREE_KEYS, METHODS, expected_evaluations
from ..output.dataset import write_atomic
from ..output.kinds import KINDS
from . import options
from .group import cli
from .progress import progress_bar

FIT = KINDS["fit"]
DATASET_SUFFIXES = (".nc", ".nc4", ".cdf")  # MEASURED read as a dataset; anything else as CSV
FREE_HELP = f"Parameters to fit, comma-separated: any of {', '.join(FREE_KEYS)}."
METHOD_HELP = (
    "Model evaluation: linear (response of eq. 8 linearised), shooting (sweeps of periodic "
    "orbits), fold (jump frequencies); auto picks by the data."
)
LAWS_HELP = (
    "Fit damping.ratio with the contact law's n fixed at 0, 1/2, 1, 3/2 and with n free; "
    "print the table of residuals (as Figure 15 against Figure 11)."
)


def read_measurements(path: str):
    """The measurements of a CSV file or of a measured dataset (by the file's suffix)."""
    from ..output.measured import measurements_from_dataset, read_measurements

    if Path(path).suffix.lower() in DATASET_SUFFIXES:
        return measurements_from_dataset(options.read_dataset(path), path)
    return read_measurements(path)


class _Meter:
    """A progress callback that stops short of the bar's end until the fit is done (the
    number of model evaluations is known only then)."""

    def __init__(self, update, total: int) -> None:
        self.update, self.total, self.done = update, total, 0

    def __call__(self, count: int) -> None:
        step = min(count, self.total - 1 - self.done)
        if self.update is not None and step > 0:
            self.update(step)
            self.done += step


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
@click.option("--method", type=click.Choice(METHODS), default="auto", help=METHOD_HELP)
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
    from ..output.measured import fit_json, fit_summary

    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, (measured_file, *scene.inputs))
    data = read_measurements(measured_file)
    free = [key.strip() for key in free_text.split(",") if key.strip()]
    total = expected_evaluations(len(free), compare_laws)
    with progress_bar(total, "fit", not quiet, unit="evaluation") as bar:
        meter = _Meter(bar, total)
        result = FIT.run(scene, data, free, method, meter, compare_laws)
        if bar is not None:
            bar(total - meter.done)  # the bar's end: the fit is done
    command = {
        "command": "fit",
        "measured": str(Path(measured_file).resolve()),
        "free": list(result.keys),
        "method": method,
        "compare_laws": compare_laws,
    }
    ds = FIT.build(result, scene, command=command)
    write_atomic(ds, output)
    if as_json:
        click.echo(json.dumps(fit_json(result, output), indent=2))
        return
    click.echo(fit_summary(result, ds))
    click.echo(f"wrote {output}")


__all__ = ["fit_command"]
