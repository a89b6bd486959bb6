"""``hertzsweep rerun IN.nc -o OUT.nc [--set k=v]``: run again the command that made a
dataset, from the dataset alone (:mod:`hertzsweep.api.rerun`): without overrides its data
variables equal the original's bit for bit, except the accuracy dataset's ``wall_time``.
"""

from __future__ import annotations

import os

import click

from . import options
from .group import cli

WORKERS_HELP = "Local worker processes for a study (default: the number of cores)."


@cli.command("rerun")
@click.argument("input_file", metavar="IN.nc", type=click.Path(exists=True, dir_okay=False))
@options.output_option
@options.set_option
@click.option("--workers", type=click.IntRange(min=1), default=None, help=WORKERS_HELP)
@options.quiet_option
def rerun_command(
    input_file: str,
    output: str,
    overrides: tuple[str, ...],
    workers: int | None,
    quiet: bool,
) -> None:
    """Run again the command that made IN.nc (sweep, trace, branch, study, accuracy) from
    its config_json and command_json, with --set overrides applied; OUT.nc is a dataset of
    the same kind (without overrides, the same data bit for bit)."""
    from ..api.rerun import json_attribute, scene_of, trace_streams, what_to_rerun

    ds = options.read_attributes(input_file)  # its record of how it was made: no data
    options.claim_output(output, (input_file,))
    name, run = what_to_rerun(ds.attrs, input_file)
    config = json_attribute(ds.attrs, "config_json", input_file)
    command = json_attribute(ds.attrs, "command_json", input_file)
    source = f"{os.path.abspath(input_file)}:config_json"
    values = options.parse_overrides(overrides)
    if run is None:
        _rerun_study(config, values, source, output, workers, quiet)
        return
    scene = scene_of(config, values, source)
    progress = options.progress(quiet)
    if name == "trace" and trace_streams(scene, command):
        options.write_streamed(output, scene, lambda sink: run(scene, command, progress, sink))
        return
    options.write_run(run(scene, command, progress, None), output)


def _rerun_study(config, overrides, source: str, output: str, workers, quiet: bool) -> None:
    """The study's cases on a local pool, into ``OUT.parts/``, then ONE dataset, as
    ``hertzsweep study`` does (exit status 1 when cases failed)."""
    from ..api.rerun import study_of
    from ..api.runs import engine_for, run_study
    from .study import conclude

    study = study_of(config, overrides, source)
    engine = engine_for(workers)
    try:
        outcome = run_study(study, output, engine, options.progress(quiet), options.history())
    finally:
        engine.close()
    conclude(outcome, output, engine)


__all__ = ["rerun_command"]
