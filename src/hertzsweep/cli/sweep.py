"""``hertzsweep sweep``: stepped-sine sweeps, up and/or down, for every sigma."""

from __future__ import annotations

from functools import partial

from . import options
from .group import cli


@cli.command("sweep")
@options.scene_argument_or_example
@options.output_option
@options.set_option
@options.example_option
@options.quiet_option
def sweep_command(
    scene_file: str | None,
    output: str,
    overrides: tuple[str, ...],
    example: str | None,
    quiet: bool,
) -> None:
    """Stepped-sine sweeps, up and/or down, for every sigma; prints a short table.

    SCENE is a scene file, or give --example NAME for a scene shipped with hertzsweep."""
    from ..api.runs import partial_sweep, run_sweep

    scene = options.read_scene_or_example(scene_file, example, overrides)
    options.claim_output(output, scene.inputs)
    run = partial(run_sweep, scene, options.progress(quiet))
    options.write_or_keep(run, partial_sweep, scene, output)


__all__ = ["sweep_command"]
