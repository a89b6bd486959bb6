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

from ..core.checks import load_checked_scene
from ..core.config import Scene
from ..errors import HertzsweepError
from ..output import paths

if TYPE_CHECKING:
    import xarray as xr

    from ..output.kinds import Kind

scene_argument = click.argument("scene_file", metavar="SCENE", type=click.Path(dir_okay=False))


def _checked_output(ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """The ``-o`` callback: what needs no scene is refused before anything is read."""
    if value is not None:
        paths.check_output(value)
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
    makes (:func:`hertzsweep.core.checks.preflight`)."""
    return load_checked_scene(scene_file, overrides)[0]


def read_dataset(path: str | os.PathLike) -> xr.Dataset:
    """A netCDF file, fully read into memory; one clear error when it is not one.

    Raises
    ------
    FileNotFoundError
        No such file.
    HertzsweepError
        The file is not netCDF.
    """
    from ..output.dataset import open_dataset

    return _read(open_dataset, path)


def read_attributes(path: str | os.PathLike) -> SimpleNamespace:
    """The global attributes of a netCDF file as ``.attrs``, its variables left unread
    (:func:`hertzsweep.output.dataset.read_attributes`: a command that needs only a
    dataset's record of how it was made loads neither its data nor xarray); the same
    errors as :func:`read_dataset`."""
    from ..output.dataset import read_attributes as attributes

    return SimpleNamespace(attrs=_read(attributes, path))


def _read(reader: Callable[[Any], Any], path: str | os.PathLike) -> Any:
    """``reader(path)``, a file that is not netCDF as one HertzsweepError naming it."""
    try:
        return reader(path)
    except FileNotFoundError:
        raise
    except (OSError, ValueError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise HertzsweepError(f"{path}: cannot read it as netCDF ({reason})") from None


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
    paths.check_not_input(output, inputs)
    lock = paths.lock_output(output)
    click.get_current_context().call_on_close(lock.release)
    place = os.path.dirname(output) or "."
    removed = paths.remove_stale_temporaries(place, os.path.basename(output))
    for folder in folders:
        removed += paths.remove_stale_temporaries(folder)
    if removed:
        click.echo(
            f"hertzsweep: removed {len(removed)} temporary file(s) of {output} left by a "
            f"killed run: {', '.join(p.name for p in removed)}",
            err=True,
        )


def write_result(kind: Kind, result: Any, scene: Scene, output: str) -> xr.Dataset:
    """Build a command's dataset from its driver's result, write it atomically, print
    the kind's summary and the file written."""
    from ..output.dataset import write_atomic

    ds = kind.build(result, scene)
    write_atomic(ds, output)
    _report(kind, result, ds, output, scene)
    return ds


def write_streamed(kind: Kind, scene: Scene, output: str, run: Callable[[Any], Any]) -> None:
    """Run a driver whose record streams into the output as it is integrated
    (``run(sink)`` with a :class:`hertzsweep.output.dataset.RecordStream` on the output's
    temporary), finish the file with the rest of the dataset, print the summary."""
    from ..core.rig import derive
    from ..output.dataset import RecordStream

    omega = derive(scene.rig).natural_circular_frequency
    with paths.atomic_path(output) as tmp, RecordStream(tmp, omega) as stream:
        result = run(stream)
        ds = kind.build(result, scene)
        stream.finish(ds)
    _report(kind, result, ds, output, scene)


def _report(kind: Kind, result: Any, ds: Any, output: str, scene: Scene) -> None:
    """The kind's summary of a written output, and the file written; on stderr, once, a
    warning where the response reaches the ball's own mode (:mod:`hertzsweep.core.ballmode`)."""
    text = kind.summary(result, ds)
    if text:
        click.echo(text)
    click.echo(f"wrote {output}")
    warning = ball_mode_warning(result, scene)
    if warning:
        click.echo(f"hertzsweep: warning: {warning}", err=True)


def ball_mode_warning(result: Any, scene: Scene) -> str:
    """The warning of a sweep's or a trace's largest ball-mode figure above the threshold
    (its sigma, w and, for a sweep, direction), or "" where none is."""
    import numpy as np

    from ..core.ballmode import THRESHOLD, warning_text
    from ..core.rig import derive

    errors = getattr(result, "ball_mode_error", None)
    if errors is None or not np.any(errors > THRESHOLD):
        return ""
    at = np.unravel_index(np.nanargmax(errors), errors.shape)
    if len(at) == 3:  # a sweep: (direction, sigma, frequency_ratio)
        d, s, p = at
        w, after = result.frequency_ratio[p], f" ({result.directions[d]} sweep)"
    else:  # a trace: (sigma,) at its one frequency ratio
        (s,), w, after = at, result.frequency_ratio, ""
    where = f"sigma = {result.sigma[s]:g}, w = {w:g}{after}"
    return warning_text(float(errors[at]), where, derive(scene.rig).ball_mode_frequency)
