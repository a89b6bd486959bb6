"""``hertzsweep sweep``: stepped-sine sweeps, up and/or down, for every sigma."""

from __future__ import annotations

from ..errors import Interrupted
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
    from ..api.runs import run_sweep

    scene = options.read_scene_or_example(scene_file, example, overrides)
    options.claim_output(output, scene.inputs)
    try:
        run = run_sweep(scene, options.progress(quiet))
    except Interrupted as exc:
        keep_partial(exc, scene, output)
        raise
    options.write_run(run, output)


def keep_partial(exc: Interrupted, scene, output: str) -> None:
    """Write the finished dwells of an interrupted run to ``OUT.partial.nc`` (dwells not
    reached are NaN, ``finished`` marks the sweeps that ran to their end, attribute
    ``complete = 0``); the output itself stays absent.

    The partial file is written as the output is: not over one of the run's inputs, nor
    over a link, a folder or a special file, atomically. When it cannot be written, one
    line says why and the run still ends as interrupted."""
    from ..api.runs import partial_sweep

    kept = partial_sweep(exc, scene)
    if kept is None:
        return
    ds, dwells, whole = kept
    held = f"{dwells} finished dwell(s), {whole} whole sweep(s),"
    options.keep_partial(ds, scene, output, "the finished dwells", held)
