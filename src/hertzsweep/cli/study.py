"""``hertzsweep study``: a grid of scenes on a local pool or a Dask cluster.

Exit status: 0 when every case finished; 1 when some failed (one line each on stderr;
the output holds the others, ``case_failed = 1`` for those); 128 + the signal number
(130 for SIGINT, 143 for SIGTERM) when stopped: the finished cases stay in
``OUT.parts/`` for ``--resume`` and the output is not written; 2 for a bad study file,
key or value.
"""

from __future__ import annotations

import itertools
import math
import signal
import sys
from contextlib import contextmanager

import click

from ..drivers.study import (
    DaskCluster,
    LocalPool,
    cases_summary,
    combine,
    expand,
    load_study,
    parts_folder,
    resumable,
    run_study,
)
from ..output.dataset import history_line, write_atomic
from . import cli, fail
from .options import output_option, quiet_option

EXIT_FAILED = 1  # some cases failed; the others are in the output
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
MAX_TABLE_ROWS = 60  # the jump table is printed for studies up to this many rows


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
    def installed(self):
        previous = {s: signal.signal(s, self.handle) for s in STOP_SIGNALS}
        try:
            yield self
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)


@contextmanager
def case_bar(total: int, initial: int, enabled: bool):
    """One tqdm bar over cases (with its ETA) on stderr, when it is a terminal."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from tqdm import tqdm

    with tqdm(total=total, initial=initial, desc="study", unit="case", file=sys.stderr,
              leave=False, smoothing=0.1) as bar:  # fmt: skip
        yield bar.update


@cli.command("study")
@click.argument("study_file", metavar="STUDY", type=click.Path(dir_okay=False))
@output_option
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Local worker processes (default: the number of cores).")  # fmt: skip
@click.option("--scheduler", metavar="ADDR", default=None,
              help="Run on an existing Dask cluster, e.g. tcp://HOST:8786.")  # fmt: skip
@click.option("--resume", is_flag=True,
              help="Skip the cases whose part in OUT.parts/ exists and is readable.")  # fmt: skip
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
    study = load_study(study_file)
    cases = expand(study)
    history = history_line()
    engine = DaskCluster(scheduler) if scheduler else LocalPool(workers)
    folder = parts_folder(output)
    resumed = resumable(cases, output) if resume else []
    stop = StopRequest()
    try:
        with stop.installed(), case_bar(len(cases), len(resumed), not quiet) as progress:
            run = run_study(study, cases, output, engine, resume=resume, history=history,
                            progress=progress, stop_requested=stop, resumed=resumed)  # fmt: skip
    finally:
        engine.close()
    failures = run.failure_lines(folder)
    for line in failures:
        click.echo(f"hertzsweep: case failed: {line}", err=True)
    if run.stopped_by:
        name = signal.Signals(run.stopped_by).name
        done = len(run.computed) + len(run.resumed)
        fail(f"interrupted by {name}: {done} of {len(cases)} cases finished, kept in "
             f"{folder}; rerun with --resume", 128 + run.stopped_by)  # fmt: skip
    ds = combine(study, cases, output, history, failures)
    if ds is not None:
        write_atomic(ds, output)
        table = jump_table(ds)
        if table:
            click.echo(table)
    click.echo(f"{cases_summary(run)} on {engine.name} ({engine.slots} slots)")
    if ds is not None:
        click.echo(f"wrote {output}")
    if failures:
        fail(f"{len(failures)} of {len(cases)} cases failed"
             + ("" if ds is not None else "; no output written"), EXIT_FAILED)  # fmt: skip


def jump_table(ds) -> str:
    """For a sweep study: the jump frequency ratio per direction at every grid point."""
    if ds.attrs.get("study_kind") != "sweep" or "jump_frequency_ratio" not in ds:
        return ""
    jumps = ds["jump_frequency_ratio"].transpose("direction", ...)
    grid = [d for d in jumps.dims if d != "direction"]
    points = list(itertools.product(*(range(jumps.sizes[d]) for d in grid)))
    if len(points) > MAX_TABLE_ROWS:
        return ""
    lines = [" ".join(f"{d:>16s}" for d in grid)
             + "".join(f" {'jump ' + str(v):>10s}" for v in jumps.direction.values)]  # fmt: skip
    for point in points:
        cell = jumps.isel(dict(zip(grid, point, strict=True)))
        keys = " ".join(f"{str(cell[d].values):>16s}" for d in grid)
        values = "".join(f" {'-' if math.isnan(x) else f'{x:.4f}':>10s}"
                         for x in cell.values.tolist())  # fmt: skip
        lines.append(keys + values)
    return "\n".join(lines)


__all__ = ["study_command"]
