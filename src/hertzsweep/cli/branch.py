"""``hertzsweep branch``: periodic orbits by shooting with pseudo-arclength continuation."""

from __future__ import annotations

from . import options
from .group import cli


@cli.command("branch")
@options.scene_argument
@options.output_option
@options.set_option
@options.quiet_option
def branch_command(scene_file: str, output: str, overrides: tuple[str, ...], quiet: bool) -> None:
    """Periodic orbits by shooting with arclength continuation across the sweep's span,
    for every sigma: stable and unstable branches, Floquet multipliers, located folds,
    period doublings and Neimark-Sacker points; prints the bifurcations."""
    from ..api.runs import run_branch

    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, scene.inputs)
    options.write_run(run_branch(scene, options.progress(quiet)), output)


__all__ = ["branch_command"]
