"""``hertzsweep study``: a grid of scenes on a local pool or a Dask cluster.

Exit status: 0 when every case finished; 1 when some failed (one line each on stderr;
the output holds the others, ``case_failed = 1`` for those); 128 + the signal number
(130 for SIGINT, 143 for SIGTERM) when stopped: the finished cases stay in
``OUT.parts/`` for ``--resume`` and the output is not written; 2 for a bad study file,
key or value, or an output that cannot be written.

A study that writes no output (stopped, or every case failed) leaves a file already at
``OUT.nc`` as it was, and says in its last line that it is an earlier run's result.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import click

from ..drivers.study import (
    CASE_KINDS,
    DaskCluster,
    LocalPool,
    cases_summary,
    expand,
    load_study,
)
from ..errors import Failed, Stopped
from ..output.paths import parts_folder
from . import options
from .group import cli
from .options import output_option, quiet_option
from .progress import progress_bar

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
BAR_SMOOTHING = 0.1  # cases take seconds to minutes each: an ETA over many of them


class StopRequest:
    """Set by SIGINT / SIGTERM while cases run: the driver stops submitting, abandons the
    cases in flight and returns (the finished parts are already on disk)."""

    def __init__(self) -> None:
        self.signal_number = 0

    def __call__(self) -> int:
        return self.signal_number

    def handle(self, signal_number: int, frame: object) -> None:
        self.signal_number = signal_number

    @contextmanager
    def installed(self) -> Iterator[StopRequest]:
        previous = {s: signal.signal(s, self.handle) for s in STOP_SIGNALS}
        try:
            yield self
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)


@cli.command("study")
@click.argument("study_file", metavar="STUDY", type=click.Path(dir_okay=False))
@output_option
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Local worker processes (default: the number of cores).",
)
@click.option(
    "--scheduler",
    metavar="ADDR",
    default=None,
    help="Run on an existing Dask cluster, e.g. tcp://HOST:8786.",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Skip the cases whose part in OUT.parts/ exists and is readable.",
)
@quiet_option
def study_command(
    study_file: str,
    output: str,
    workers: int | None,
    scheduler: str | None,
    resume: bool,
    quiet: bool,
) -> None:
    """A grid of scenes (every combination of the study's [grid] is a case), in parallel;
    ONE dataset with the grid keys as dimensions. Finished cases are kept in OUT.parts/.

    Exit status: 0 every case finished; 1 some failed (one line each, the output holds
    the others); 130 / 143 stopped by SIGINT / SIGTERM (finished cases kept, no output;
    rerun with --resume); 2 a bad study file, key or value."""
    if workers is not None and scheduler is not None:
        raise click.UsageError("--workers and --scheduler exclude each other")
    if scheduler is not None and not scheduler.strip():
        raise click.UsageError("--scheduler: empty address (give tcp://HOST:PORT)")
    # the local workers start (and warm up) while the driver imports the output layer:
    # the start-up of both overlaps
    study = load_study(study_file, CASE_KINDS)  # the study and every case checked (with
    cases = expand(study)  # the output) before any worker starts
    options.claim_output(output, study_inputs(study_file), folders=(parts_folder(output),))
    engine = DaskCluster(scheduler) if scheduler else LocalPool(workers)
    try:
        _run(study, cases, output, engine, resume, quiet)
    except BaseException:  # a bad study file, a failed case, a signal: no worker is needed
        engine.stop(())  # any more: the pool ends its workers once its start is done
        raise
    finally:
        engine.close()


def _run(study, cases, output: str, engine, resume: bool, quiet: bool) -> None:
    """The study on an engine: parts, the combined dataset and its summary."""
    from ..output.dataset import history_line
    from ..output.kinds import KINDS
    from ..output.study import resumable

    study_kind = KINDS["study"]
    history = history_line()
    resumed = resumable(cases, output) if resume else []
    stop = StopRequest()
    bar = progress_bar(
        len(cases), "study", not quiet, unit="case", initial=len(resumed), smoothing=BAR_SMOOTHING
    )
    with stop.installed(), bar as progress:
        run = study_kind.run(
            study,
            cases,
            output,
            engine,
            history=history,
            resumed=resumed,
            progress=progress,
            stop_requested=stop,
        )
    conclude(study_kind, study, cases, output, history, run, engine)


def study_inputs(study_file: str) -> tuple[str, ...]:
    """The files a study reads: the study file, the scene file it names and their rig
    files (an output must be none of them)."""
    from ..core.config import read_scene_files, read_toml

    files = read_scene_files(study_file)[1]
    scene = read_toml(study_file).get("scene")
    if isinstance(scene, str):
        files += read_scene_files(Path(study_file).parent / scene)[1]
    return files


def conclude(kind, study, cases, output: str, history: str, run, engine) -> None:
    """After a study's cases ran: one line per failed case; when stopped by a signal, the
    finished cases kept for ``--resume``; else ONE dataset built, written and summarised
    (exit status 1 when cases failed).

    A study that writes no output (stopped, or every case failed) leaves a file already
    at ``output`` as it was, and its last line says that file is an earlier run's."""
    from ..output.dataset import write_atomic
    from ..output.study import failure_lines, parts_folder

    folder = parts_folder(output)
    failures = failure_lines(run, folder)
    for line in failures:
        click.echo(f"hertzsweep: case failed: {line}", err=True)
    if run.stopped_by:
        name = signal.Signals(run.stopped_by).name
        done = len(run.computed) + len(run.resumed)
        message = f"interrupted by {name}: {done} of {len(cases)} cases finished, kept in {folder}"
        raise Stopped(f"{message}; rerun with --resume{_earlier(output)}", run.stopped_by)
    ds = kind.build(study, cases, output, history, failures)
    if ds is not None:
        write_atomic(ds, output)
        table = kind.summary(run, ds)
        if table:
            click.echo(table)
    click.echo(f"{cases_summary(run)} on {engine.name} ({engine.slots} slots)")
    if ds is not None:
        click.echo(f"wrote {output}")
    if failures:
        written = "" if ds is not None else f"; no output written{_earlier(output)}"
        raise Failed(f"{len(failures)} of {len(cases)} cases failed{written}")


def _earlier(output: str) -> str:
    """What a study that wrote nothing says of a file already at its output."""
    if not os.path.lexists(output):
        return ""
    return f"; {output} is left as it was: an earlier run's, not this one's"


__all__ = ["conclude", "study_command"]
