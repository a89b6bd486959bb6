"""``hertzsweep trace``: settled time history, spectrum and flights at one frequency."""

from __future__ import annotations

import click

from ..drivers.trace import BRANCHES, DEFAULT_PERIODS, run_trace, trace_count
from ..output.dataset import trace_dataset, write_atomic
from . import cli
from .options import output_option, quiet_option, read_scene, scene_argument, set_option
from .progress import progress_bar


@cli.command("trace")
@scene_argument
@click.option(
    "-w",
    "--frequency",
    "frequency_ratio",
    required=True,
    type=float,
    metavar="W",
    help="Frequency ratio w = f/f0 to record at.",
)
@output_option
@click.option(
    "--periods",
    type=int,
    default=DEFAULT_PERIODS,
    show_default=True,
    help="Whole excitation periods to record.",
)
@click.option(
    "--branch",
    type=click.Choice(BRANCHES),
    default="upper",
    show_default=True,
    help="Reach W as a down sweep from sweep.stop (upper) or an up sweep from sweep.start (lower).",
)
@click.option(
    "--samples-per-period",
    type=int,
    default=None,
    help="Samples kept per period, a divisor of solver.steps_per_period [default: every step].",
)
@set_option
@quiet_option
def trace_command(
    scene_file: str,
    frequency_ratio: float,
    output: str,
    periods: int,
    branch: str,
    samples_per_period: int | None,
    overrides: tuple[str, ...],
    quiet: bool,
) -> None:
    """Settled time history of one frequency for every sigma: q, q', N/F_s and contact,
    the spectrum of N/F_s, and every flight; prints one line per sigma."""
    scene = read_scene(scene_file, overrides)
    with progress_bar(trace_count(scene, frequency_ratio, branch), "trace", not quiet) as bar:
        result = run_trace(scene, frequency_ratio, periods, branch, samples_per_period, bar)
    ds = trace_dataset(result, scene)
    write_atomic(ds, output)
    for line in summary_lines(ds):
        click.echo(line)
    click.echo(f"wrote {output}")


def summary_lines(ds) -> list[str]:
    """One line per sigma: harmonics, force extremes, contact loss and flights."""
    lines = []
    for sigma in ds.sigma.values:
        sel = ds.sel(sigma=sigma)
        harmonics = " ".join(
            f"H{int(k)} {float(a):.4f}"
            for k, a in zip(ds.harmonic.values, sel.amplitude.values, strict=True)
        )
        count = int(sel.flight_count)
        flights = (
            f"{count} flight(s), longest {float(sel.flight_time) * 1e3:.3f} ms"
            if count
            else "no flight"
        )
        state = "settled" if int(sel.settled) else "NOT settled"
        if not int(sel.periodic):
            state += ", not periodic"
        lines.append(
            f"sigma {sigma:.4g} w {ds.attrs['frequency_ratio']:.4f} {ds.attrs['branch']}: "
            f"{harmonics}  N max {float(sel.force_max):.3f} min {float(sel.force_min):.3f}  "
            f"loss {float(sel.contact_loss_fraction):.3f}  {flights} ({state})"
        )
    return lines


__all__ = ["summary_lines", "trace_command"]
