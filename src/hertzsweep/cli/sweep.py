"""``hertzsweep sweep``: stepped-sine sweeps, up and/or down, for every sigma."""

from __future__ import annotations

from pathlib import Path

import click

from ..api import files
from ..errors import HertzsweepError, Interrupted
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
    partial = Path(output).with_suffix(".partial.nc")
    try:
        files.check_not_input(partial, scene.inputs)
        files.write(ds, partial)
    except (OSError, HertzsweepError) as error:
        where = f"{error.filename}: {error.strerror}" if isinstance(error, OSError) else error
        click.echo(f"hertzsweep: cannot keep the finished dwells: {where}", err=True)
        return
    click.echo(
        f"kept {dwells} finished dwell(s), {whole} whole sweep(s), in {partial}",
        err=True,
    )
