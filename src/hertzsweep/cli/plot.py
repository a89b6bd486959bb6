"""``hertzsweep plot IN.nc -o FIG.(png|pdf|svg)``: the paper-style figure of a dataset."""

from __future__ import annotations

import click

from ..errors import HertzsweepError
from ..output.kinds import KINDS, figure
from .group import cli
from .options import read_dataset

VIEW_HELP = "; ".join(f"{kind.name}: {', '.join(kind.views)}" for kind in KINDS.values())


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
    from ..output.plot import figure_format, write_figure

    figure_format(output)
    ds = read_dataset(input_file)
    extra = read_dataset(overlay) if overlay else None
    try:
        fig = figure(ds, view, harmonics or None, sigmas or None, extra)
    except HertzsweepError as exc:
        raise exc.with_context(input_file) from None
    except (KeyError, AttributeError) as exc:  # a variable or coordinate the kind needs
        kind = ds.attrs.get("hertzsweep_kind")
        raise HertzsweepError(f"{input_file}: not a complete {kind} dataset ({exc})") from None
    write_figure(fig, output)
    click.echo(f"wrote {output}")


__all__ = ["plot_command"]
