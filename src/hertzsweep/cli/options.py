"""Options and steps shared by several commands: reading a scene or a dataset, claiming
and writing a command's output and printing its summary.

An output (``-o``) is checked twice before anything is computed: by the option itself
(:func:`hertzsweep.output.paths.check_output`: not empty, not a folder, a special file or
a symbolic link, in a writable folder), and by :func:`claim_output`, which each writing
command calls once it knows its input files: not one of them, then locked against a
second run writing the same output, stale temporaries of a killed run removed.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import click

from ..api import files
from ..api.choices import EXAMPLES

if TYPE_CHECKING:
    import xarray as xr

    from ..api import Scene
    from ..api.runs import Run

scene_argument = click.argument("scene_file", metavar="SCENE", type=click.Path(dir_okay=False))
scene_argument_or_example = click.argument(
    "scene_file", metavar="[SCENE]", required=False, type=click.Path(dir_okay=False)
)
example_option = click.option(
    "--example",
    type=click.Choice(list(EXAMPLES)),
    default=None,
    help="Run a scene shipped with hertzsweep instead of SCENE (default: the paper's "
    "Figures 4-5; smoke: the same on a reduced grid).",
)


def _checked_output(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """The ``-o`` callback: what needs no scene is refused before anything is read."""
    if value is not None:
        files.check_output(value)
    return value


def output_option_for(metavar: str, help: str):
    """The ``-o/--output`` option of a command that writes one file (checked before
    anything is read: :func:`_checked_output`)."""
    return click.option(
        "-o",
        "--output",
        required=True,
        type=click.Path(),
        metavar=metavar,
        callback=_checked_output,
        help=help,
    )


output_option = output_option_for("OUT.nc", "netCDF file to write.")
set_option = click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="TABLE.KEY=VALUE",
    help="Override a config key (TOML value syntax); repeatable.",
)
quiet_option = click.option("-q", "--quiet", is_flag=True, help="No progress bar.")


def read_scene(scene_file: str, overrides: tuple[str, ...] = ()) -> Scene:
    """The scene of a file, with ``--set`` overrides applied, after every check a run
    makes (:func:`hertzsweep.api.load_scene`)."""
    from ..api import load_scene

    return load_scene(scene_file, parse_overrides(overrides))


def read_scene_or_example(
    scene_file: str | None, example: str | None, overrides: tuple[str, ...] = ()
) -> Scene:
    """The scene of SCENE or of ``--example NAME`` (exactly one of them).

    Raises
    ------
    click.UsageError
        Both or neither given.
    """
    if (scene_file is None) == (example is None):
        raise click.UsageError("give a scene file SCENE or --example NAME (one of them)")
    if example is None:
        return read_scene(scene_file, overrides)
    from ..api import example_scene

    return example_scene(example, parse_overrides(overrides))


def history() -> str:
    """A dataset's ``history``: this command line (:func:`hertzsweep.api.files.history`)."""
    return files.history()


def progress(quiet: bool) -> bool | str:
    """A command's progress bar: on stderr when it is a terminal, off with ``--quiet``
    (:data:`hertzsweep.api.runs.TERMINAL`)."""
    return False if quiet else "terminal"


def parse_overrides(overrides: tuple[str, ...]) -> dict[str, Any]:
    """``--set`` texts as the API's ``{key: value}`` overrides (the last of a key wins,
    as when the texts are applied in order)."""
    from ..api.runs import parse_overrides

    return parse_overrides(overrides)


def read_dataset(path: str | os.PathLike) -> xr.Dataset:
    """A netCDF file, fully read into memory (:func:`hertzsweep.api.files.read_dataset`)."""
    return files.read_dataset(path)


def read_attributes(path: str | os.PathLike) -> SimpleNamespace:
    """The global attributes of a netCDF file as ``.attrs``, its variables left unread (a
    command that needs only a dataset's record of how it was made loads neither its data
    nor xarray); the same errors as :func:`read_dataset`."""
    return SimpleNamespace(attrs=files.read_attributes(path))


def claim_output(
    output: str, inputs: Iterable[str | os.PathLike] = (), folders: Iterable[str] = ()
) -> None:
    """Claim a command's output once its input files are known, before computing: refuse
    one of ``inputs``; take the output's lock until the command ends (a second run
    writing it is refused); remove the temporaries a killed run left beside it (and in
    ``folders``, a study's parts), saying so in one line.

    Raises
    ------
    OutputPathError
        The output is an input, or another run holds its lock, or its lock cannot be
        created.
    """
    files.check_not_input(output, inputs)
    lock = files.lock_output(output)
    click.get_current_context().call_on_close(lock.release)
    place = os.path.dirname(output) or "."
    removed = files.remove_stale_temporaries(place, os.path.basename(output))
    for folder in folders:
        removed += files.remove_stale_temporaries(folder)
    if removed:
        click.echo(
            f"hertzsweep: removed {len(removed)} temporary file(s) of {output} left by a "
            f"killed run: {', '.join(p.name for p in removed)}",
            err=True,
        )


def write_run(run: Run, output: str) -> None:
    """Write a run's dataset atomically, print the kind's summary and the file written."""
    files.write(run.frame, output)
    report(run, output)


def write_streamed(output: str, scene: Scene, make: Callable[[Any], Run]) -> None:
    """Run a trace whose record streams into the output as it is integrated
    (``make(sink)`` with a record stream on the output's temporary), finish the file with
    the rest of the dataset, print the summary."""
    with files.atomic_path(output) as tmp, files.record_stream(tmp, scene) as stream:
        run = make(stream)
        stream.finish(run.frame)
    report(run, output)


def report(run: Run, output: str) -> None:
    """The kind's summary of a written output, and the file written; on stderr, once, a
    warning where the response reaches the ball's own mode (:mod:`hertzsweep.core.ballmode`)."""
    text = run.summary()
    if text:
        click.echo(text)
    click.echo(f"wrote {output}")
    warning = run.warning()
    if warning:
        click.echo(f"hertzsweep: warning: {warning}", err=True)


def write_or_keep(
    run: Callable[[], Run], partial: Callable[..., Any], scene: Scene, output: str
) -> None:
    """Run and write the output; when a signal interrupts the run, write what it finished
    (``partial(exc, scene)``: a :class:`~hertzsweep.api.runs.Partial` or None) to
    ``OUT.partial.nc``, say so on stderr, and end as interrupted. The output itself stays
    absent.

    The partial file is written as the output is: not over one of the run's inputs, nor
    over a link, a folder or a special file, atomically. When it cannot be written, one
    line says why and the run still ends as interrupted."""
    from ..errors import Interrupted

    try:
        done = run()
    except Interrupted as exc:
        kept = partial(exc, scene)
        if kept is not None:
            _keep(kept, scene, output)
        raise
    write_run(done, output)


def _keep(kept: Any, scene: Scene, output: str) -> None:
    """Write an interrupted run's :class:`~hertzsweep.api.runs.Partial` beside the output."""
    from pathlib import Path

    from ..errors import HertzsweepError

    partial = Path(output).with_suffix(".partial.nc")
    try:
        files.check_not_input(partial, scene.inputs)
        files.write(kept.dataset, partial)
    except (OSError, HertzsweepError) as error:
        where = f"{error.filename}: {error.strerror}" if isinstance(error, OSError) else error
        click.echo(f"hertzsweep: cannot keep {kept.what}: {where}", err=True)
        return
    click.echo(f"kept {kept.kept} in {partial}", err=True)
