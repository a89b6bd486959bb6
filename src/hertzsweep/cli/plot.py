"""``hertzsweep plot IN.nc -o FIG.(png|pdf|svg)``: the paper-style figure of a dataset."""

from __future__ import annotations

import os
import shlex

import click

from ..api.choices import KINDS
from . import options
from .group import cli

VIEW_HELP = "; ".join(f"{kind.name}: {', '.join(kind.views)}" for kind in KINDS.values())
DEFAULT_DPI = 200  # print quality: hertzsweep.output.plot.DPI (not imported: no matplotlib here)


@cli.command("plot")
@click.argument("input_file", metavar="IN.nc", type=click.Path(exists=True, dir_okay=False))
@options.output_option_for("FIG", "Figure to write: FIG.png, FIG.pdf or FIG.svg.")
@click.option("--view", default=None, help=f"The view (default the first): {VIEW_HELP}.")
@click.option(
    "--harmonic",
    "harmonics",
    type=str,
    multiple=True,
    metavar="K",
    help="Draw only harmonic K (sweep, branch), e.g. 2 or 1/2; repeatable.",
)
@click.option(
    "--sigma",
    "sigmas",
    type=float,
    multiple=True,
    metavar="S",
    help="Draw only input level S (F/F_s, e.g. 0.01); repeatable.",
)
@click.option(
    "--overlay",
    type=click.Path(exists=True, dir_okay=False),
    metavar="SWEEP.nc",
    help="A simulated sweep dataset drawn as markers over a branch (as in Figures 13 and 14).",
)
@click.option(
    "--wrap-phase",
    is_flag=True,
    help="Draw phases as stored, in [0, 360) (default: unwrapped, continuous along each curve).",
)
@click.option(
    "--dpi",
    type=click.FloatRange(min=10.0, max=2400.0),
    default=DEFAULT_DPI,
    show_default=True,
    help="Dots per inch of a PNG (and of raster parts of a PDF or SVG).",
)
def plot_command(
    input_file: str,
    output: str,
    view: str | None,
    harmonics: tuple[str, ...],
    sigmas: tuple[float, ...],
    overlay: str | None,
    wrap_phase: bool,
    dpi: float,
) -> None:
    """The paper-style figure of a sweep, trace, branch, study, accuracy, measured, fit or
    random dataset, picked by its hertzsweep_kind attribute. The file's metadata name the
    dataset, this command and the version."""
    from ..api import plot
    from ..api.files import figure_format, write_figure

    figure_format(output)
    options.claim_output(output, (input_file, *([overlay] if overlay else [])))
    fig = plot(
        input_file, view, harmonics=harmonics, sigmas=sigmas, overlay=overlay, wrap_phase=wrap_phase
    )
    datasets = [input_file, *([overlay] if overlay else [])]
    arguments = {"view": view, "harmonic": harmonics, "sigma": sigmas, "overlay": overlay}
    command = command_line(input_file, output, arguments, wrap_phase, dpi)
    made_by = str(options.read_attributes(input_file).attrs.get("history", ""))
    write_figure(fig, output, dpi=dpi, datasets=datasets, command=command, made_by=made_by)
    click.echo(f"wrote {output}")


def command_line(
    input_file: str, output: str, arguments: dict, wrap_phase: bool, dpi: float
) -> str:
    """The ``hertzsweep plot`` command that draws a figure, files as absolute paths
    (``arguments``: option name -> value, a tuple for a repeated option, None if not
    given)."""
    argv = ["hertzsweep", "plot", os.path.abspath(input_file), "-o", os.path.abspath(output)]
    for name, value in arguments.items():
        for item in value if isinstance(value, tuple) else (value,):
            if item is None:
                continue
            if name == "overlay":
                item = os.path.abspath(item)
            argv += [f"--{name}", f"{item:g}" if isinstance(item, float) else str(item)]
    if wrap_phase:
        argv.append("--wrap-phase")
    argv += ["--dpi", f"{dpi:g}"]
    return shlex.join(argv)


__all__ = ["command_line", "plot_command"]
