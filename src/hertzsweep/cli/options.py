"""Options and steps shared by several commands: reading a scene or a dataset, writing
a command's dataset and printing its summary."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import click

from ..core.config import Scene, load_scene
from ..errors import HertzsweepError

if TYPE_CHECKING:
    import xarray as xr

    from ..output.kinds import Kind

scene_argument = click.argument("scene_file", metavar="SCENE", type=click.Path(dir_okay=False))
output_option = click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="netCDF file to write."
)
set_option = click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="TABLE.KEY=VALUE",
    help="Override a config key (TOML value syntax); repeatable.",
)
quiet_option = click.option("-q", "--quiet", is_flag=True, help="No progress bar.")


def read_scene(scene_file: str, overrides: tuple[str, ...] = ()) -> Scene:
    """The scene of a file, with ``--set`` overrides applied."""
    return load_scene(scene_file, overrides)


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

    try:
        return open_dataset(path)
    except FileNotFoundError:
        raise
    except (OSError, ValueError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise HertzsweepError(f"{path}: cannot read it as netCDF ({reason})") from None


def write_result(kind: Kind, result: Any, scene: Scene, output: str) -> xr.Dataset:
    """Build a command's dataset from its driver's result, write it atomically, print
    the kind's summary and the file written."""
    from ..output.dataset import write_atomic

    ds = kind.build(result, scene)
    write_atomic(ds, output)
    text = kind.summary(result, ds)
    if text:
        click.echo(text)
    click.echo(f"wrote {output}")
    return ds
