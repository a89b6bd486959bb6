"""``hertzsweep branch``: periodic orbits by shooting with pseudo-arclength continuation."""

from __future__ import annotations

import click

from . import options
from .group import cli


@cli.command("branch")
@options.scene_argument
@options.output_option
@options.set_option
@click.option(
    "--follow-pd",
    "follow_pd",
    is_flag=True,
    help="Also continue the period-doubled branch from every period-doubling point, "
    "recursively down to period 8 (as --set branch.follow_period_doubling=true).",
)
@options.quiet_option
def branch_command(
    scene_file: str, output: str, overrides: tuple[str, ...], follow_pd: bool, quiet: bool
) -> None:
    """Periodic orbits by shooting with arclength continuation across the sweep's span,
    for every sigma: stable and unstable branches, Floquet multipliers, located folds,
    period doublings and Neimark-Sacker points; prints the bifurcations."""
    from ..api.runs import run_branch

    if follow_pd:
        overrides = (*overrides, "branch.follow_period_doubling=true")
    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, scene.inputs)
    options.write_run(run_branch(scene, options.progress(quiet)), output)


__all__ = ["branch_command"]
