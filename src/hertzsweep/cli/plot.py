"""``hertzsweep plot IN.nc -o FIG.(png|pdf|svg)``: the paper-style figure of a dataset."""

from __future__ import annotations

import os
from pathlib import Path

import click
import xarray as xr
from matplotlib.figure import Figure

from ..errors import HertzsweepError
from ..output.dataset import atomic_path, open_dataset
from ..output.plot import VIEWS, figure
from . import cli

FORMATS = ("png", "pdf", "svg")


def figure_format(path: str | os.PathLike) -> str:
    """The format named by a figure file's extension (one of :data:`FORMATS`)."""
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        raise HertzsweepError(
            f"-o: {str(path)!r}: unknown figure extension {('.' + suffix) if suffix else '(none)'}"
            f" (use {', '.join('.' + f for f in FORMATS)})"
        )
    return suffix


def read_dataset(path: str | os.PathLike) -> xr.Dataset:
    """A hertzsweep netCDF file, or one clear error."""
    try:
        return open_dataset(path)
    except FileNotFoundError:
        raise
    except (OSError, ValueError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise HertzsweepError(f"{path}: cannot read it as netCDF ({reason})") from None


def write_figure(fig: Figure, path: str | os.PathLike) -> Path:
    """Save a figure in the format of its extension, atomically: complete or absent."""
    path = Path(path)
    fmt = figure_format(path)
    with atomic_path(path, suffix=f".{fmt}") as tmp:
        fig.savefig(tmp, format=fmt)
    return path


VIEW_HELP = "; ".join(f"{kind}: {', '.join(views)}" for kind, views in VIEWS.items())


@cli.command("plot")
@click.argument("input_file", metavar="IN.nc", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False),
    help="Figure to write: FIG.png, FIG.pdf or FIG.svg.",
)
@click.option("--view", default=None, help=f"The view (default the first): {VIEW_HELP}.")
@click.option(
    "--harmonic",
    "harmonics",
    type=int,
    multiple=True,
    metavar="K",
    help="Draw only harmonic K (sweep, branch); repeatable.",
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
    help="A sweep dataset drawn as markers over a branch (as in Figures 13 and 14).",
)
def plot_command(
    input_file: str,
    output: str,
    view: str | None,
    harmonics: tuple[int, ...],
    sigmas: tuple[float, ...],
    overlay: str | None,
) -> None:
    """The paper-style figure of a sweep, trace, branch, study or accuracy dataset,
    picked by its hertzsweep_kind attribute."""
    figure_format(output)
    ds = read_dataset(input_file)
    extra = read_dataset(overlay) if overlay else None
    try:
        fig = figure(ds, view, harmonics or None, sigmas or None, extra)
    except HertzsweepError as exc:
        raise HertzsweepError(f"{input_file}: {exc}") from None
    except (KeyError, AttributeError) as exc:  # a variable or coordinate the kind needs
        kind = ds.attrs.get("hertzsweep_kind")
        raise HertzsweepError(f"{input_file}: not a complete {kind} dataset ({exc})") from None
    write_figure(fig, output)
    click.echo(f"wrote {output}")
