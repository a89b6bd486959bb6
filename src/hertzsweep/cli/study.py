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

import click

from ..errors import Failed, HertzsweepError, Stopped
from . import options
from .group import cli
from .options import output_option, quiet_option

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


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
    from ..api.files import parts_folder
    from ..api.runs import check_engine, engine_for, load_study, study_inputs

    try:
        check_engine(workers, scheduler)
    except HertzsweepError as exc:
        raise click.UsageError(str(exc)) from None
    # the local workers start (and warm up) while the driver imports the output layer:
    # the start-up of both overlaps
    study = load_study(study_file)  # the study and every case checked (with the output)
    options.claim_output(output, study_inputs(study_file), folders=(parts_folder(output),))
    engine = engine_for(workers, scheduler)  # before any worker starts
    try:
        _run(study, output, engine, resume, quiet)
    except BaseException:  # a bad study file, a failed case, a signal: no worker is needed
        engine.stop(())  # any more: the pool ends its workers once its start is done
        raise
    finally:
        engine.close()


def _run(study, output: str, engine, resume: bool, quiet: bool) -> None:
    """The study on an engine: parts, the combined dataset and its summary."""
    from ..api.runs import run_study

    stop = StopRequest()
    with stop.installed():
        outcome = run_study(
            study,
            output,
            engine,
            options.progress(quiet),
            options.history(),
            resume=resume,
            stop_requested=stop,
        )
    conclude(outcome, output, engine)


def conclude(outcome, output: str, engine) -> None:
    """After a study's cases ran: one line per failed case; when stopped by a signal, the
    finished cases kept for ``--resume``; else ONE dataset written and summarised (exit
    status 1 when cases failed).

    A study that writes no output (stopped, or every case failed) leaves a file already
    at ``output`` as it was, and its last line says that file is an earlier run's."""
    from ..api.files import parts_folder, write
    from ..api.runs import cases_summary, counted_cases

    run, cases, ds, failures = outcome.run, outcome.cases, outcome.dataset, outcome.failures
    for line in failures:
        click.echo(f"hertzsweep: case failed: {line}", err=True)
    if run.stopped_by:
        name = signal.Signals(run.stopped_by).name
        done = len(run.computed) + len(run.resumed)
        folder = parts_folder(output)
        counted = counted_cases(cases)
        message = f"interrupted by {name}: {done} of {counted} finished, kept in {folder}"
        raise Stopped(f"{message}; rerun with --resume{_earlier(output)}", run.stopped_by)
    if ds is not None:
        write(ds, output)
        table = outcome.summary()
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
