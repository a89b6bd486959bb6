"""``hertzsweep sweep``: stepped-sine sweeps, up and/or down, for every sigma."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np

from ..drivers.sweep import dwell_count
from ..errors import HertzsweepError, Interrupted
from ..output import paths
from ..output.dataset import write_atomic
from ..output.kinds import KINDS
from . import options
from .group import cli
from .progress import progress_bar

SWEEP = KINDS["sweep"]
# the variable OUT.partial.nc adds: which (direction, sigma) sweeps ran to their end
FINISHED_ATTRS = {"long_name": "that sweep ran to its end", "units": "1"}


@cli.command("sweep")
@options.scene_argument
@options.output_option
@options.set_option
@options.quiet_option
def sweep_command(scene_file: str, output: str, overrides: tuple[str, ...], quiet: bool) -> None:
    """Stepped-sine sweeps, up and/or down, for every sigma; prints a short table."""
    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, scene.inputs)
    try:
        with progress_bar(dwell_count(scene), "sweep", not quiet) as progress:
            result = SWEEP.run(scene, progress)
    except Interrupted as exc:
        keep_partial(exc, scene, output)
        raise
    options.write_result(SWEEP, result, scene, output)


def keep_partial(exc: Interrupted, scene, output: str) -> None:
    """Write the finished dwells of an interrupted run to ``OUT.partial.nc`` (dwells not
    reached are NaN, ``finished`` marks the sweeps that ran to their end, attribute
    ``complete = 0``); the output itself stays absent.

    The partial file is written as the output is: not over one of the run's inputs, nor
    over a link, a folder or a special file, atomically. When it cannot be written, one
    line says why and the run still ends as interrupted."""
    result = exc.partial
    if result is None or not np.isfinite(result.amplitude).any():
        return
    ds = SWEEP.build(result, scene)
    ds["finished"] = (("direction", "sigma"), result.finished.astype(np.int8), FINISHED_ATTRS)
    ds.attrs["complete"] = 0
    partial = Path(output).with_suffix(".partial.nc")
    try:
        paths.check_not_input(partial, scene.inputs)
        write_atomic(ds, partial)
    except (OSError, HertzsweepError) as error:
        where = f"{error.filename}: {error.strerror}" if isinstance(error, OSError) else error
        click.echo(f"hertzsweep: cannot keep the finished dwells: {where}", err=True)
        return
    dwells = int(np.isfinite(result.amplitude[..., 0]).sum())
    click.echo(
        f"kept {dwells} finished dwell(s), {int(result.finished.sum())} whole sweep(s), "
        f"in {partial}",
        err=True,
    )
