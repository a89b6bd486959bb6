"""``hertzsweep branch``: periodic orbits by shooting with pseudo-arclength continuation."""

from __future__ import annotations

import click
import numpy as np

from ..core.config import Scene
from ..drivers.continuation import BranchResult, progress_total, run_branch
from ..output.dataset import branch_dataset, write_atomic
from . import cli
from .options import output_option, quiet_option, read_scene, scene_argument, set_option
from .progress import progress_bar

ENDS = {
    "start": "it turned back and left the span where it began",
    "stalled": "the continuation stalled",
    "retraced": "it ran back onto itself past a corner of the map",
    "max-points": "too many points",
}


@cli.command("branch")
@scene_argument
@output_option
@set_option
@quiet_option
def branch_command(scene_file: str, output: str, overrides: tuple[str, ...], quiet: bool) -> None:
    """Periodic orbits by shooting with arclength continuation across the sweep's span,
    for every sigma: stable and unstable branches, Floquet multipliers, located folds,
    period doublings and Neimark-Sacker points; prints the bifurcations."""
    scene = read_scene(scene_file, overrides)
    with progress_bar(progress_total(scene), "branch", not quiet, unit="%") as progress:
        result = run_branch(scene, progress)
    write_atomic(branch_dataset(result, scene), output)
    click.echo(summary(result, scene))
    click.echo(f"wrote {output}")


def summary(result: BranchResult, scene: Scene | None = None) -> str:
    """Per sigma: points, stable share, peak H1 and the located bifurcations; a caution
    where contact damping with n < 1 meets loss of contact."""
    lines = [
        f"branch from w = {result.start_frequency_ratio:g} to {result.end_frequency_ratio:g}; "
        f"{result.steps} integration steps"
    ]
    for branch in result.branches:
        peak = int(np.argmax(branch.amplitude[:, 0]))
        state = "" if branch.complete else f" (stopped short: {ENDS.get(branch.end, branch.end)})"
        lines.append(
            f"sigma {branch.sigma:g}: {branch.size} points, {int(branch.stable.sum())} stable, "
            f"peak H{int(result.harmonics[0])} {branch.amplitude[peak, 0]:.4f} at "
            f"w = {branch.frequency_ratio[peak]:.4f}{state}"
        )
        if branch.bridges:
            lines.append(f"  {branch.bridges} gap(s) of the map crossed at fixed w")
        if not branch.bifurcations:
            lines.append("  no bifurcation")
        for found in branch.bifurcations:
            mu = found.multipliers[0]
            lines.append(
                f"  {found.kind:15s} w = {found.frequency_ratio:.6f}  H1 = {found.amplitude:.4f}  "
                f"multiplier {mu.real:+.6f}{mu.imag:+.6f}j"
            )
    rough = scene is not None and scene.damping.law == "contact" and scene.damping.exponent < 1
    if rough and any(branch.contact_loss_fraction.max() > 0 for branch in result.branches):
        lines.append(
            "note: contact damping with n < 1 makes the scheme's one-period map non-smooth "
            "where the orbit loses contact; there the branch may stop short or show extra "
            "folds: check the jumps against a sweep"
        )
    return "\n".join(lines)
