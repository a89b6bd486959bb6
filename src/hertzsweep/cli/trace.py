"""``hertzsweep trace``: settled time history, spectrum and flights at one frequency."""

from __future__ import annotations

import click

from ..api.choices import TRACE_BRANCHES, TRACE_DEFAULT_PERIODS
from . import options
from .group import cli


@cli.command("trace")
@options.scene_argument
@click.option(
    "-w",
    "--frequency",
    "frequency_ratio",
    required=True,
    type=float,
    metavar="W",
    help="Frequency ratio w = f/f0 to record at.",
)
@options.output_option
@click.option(
    "--periods",
    type=int,
    default=TRACE_DEFAULT_PERIODS,
    show_default=True,
    help="Whole excitation periods to record.",
)
@click.option(
    "--branch",
    type=click.Choice(TRACE_BRANCHES),
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
@options.set_option
@options.quiet_option
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
    from ..api.runs import check_trace, run_trace

    scene = options.read_scene(scene_file, overrides)
    streamed = check_trace(scene, periods, samples_per_period)
    options.claim_output(output, scene.inputs)
    arguments = (scene, frequency_ratio, periods, branch, samples_per_period)

    def run(sink=None):
        return run_trace(*arguments, progress=options.progress(quiet), sink=sink)

    if streamed:  # a long record goes to the file as it is integrated
        options.write_streamed(output, scene, run)
    else:
        options.write_run(run(), output)


__all__ = ["trace_command"]
