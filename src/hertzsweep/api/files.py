"""Files for the command line: reading datasets, checking and claiming outputs, writing
them atomically (:mod:`hertzsweep.output.paths`, :mod:`hertzsweep.output.dataset`).

The command line reaches the engine only through :mod:`hertzsweep.api`; this module is
the part of it that deals in files. Standard library only at import: the light commands
(``rig``, ``validate``) import it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..errors import HertzsweepError
from ..output.paths import (
    OutputPathError,
    atomic_path,
    check_not_input,
    check_output,
    lock_output,
    parts_folder,
    remove_stale_temporaries,
)

if TYPE_CHECKING:
    import xarray as xr


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


def read_attributes(path: str | os.PathLike) -> dict[str, Any]:
    """The global attributes of a netCDF file, its variables left unread (neither the
    data nor xarray is loaded); the same errors as :func:`read_dataset`."""
    from ..output.dataset import read_attributes as attributes

    return _read(attributes, path)


def _read(reader: Callable[[Any], Any], path: str | os.PathLike) -> Any:
    """``reader(path)``, a file that is not netCDF as one HertzsweepError naming it."""
    try:
        return reader(path)
    except FileNotFoundError:
        raise
    except (OSError, ValueError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise HertzsweepError(f"{path}: cannot read it as netCDF ({reason})") from None


def write(ds: Any, path: str | os.PathLike) -> Any:
    """Write a dataset (a Frame or an xarray Dataset) atomically: complete or absent."""
    from ..output.dataset import write_atomic

    return write_atomic(ds, path)


def history() -> str:
    """``history`` of a dataset a command makes: the UTC time, this process's command line
    with absolute paths, the working folder and the version
    (:func:`hertzsweep.output.dataset.history_line`)."""
    from ..output.dataset import history_line

    return history_line()


def record_stream(path: str | os.PathLike, scene: Any) -> Any:
    """A long trace's record stream into ``path`` (a temporary of the output), the
    record's time scaled by the scene's natural circular frequency."""
    from ..core.rig import derive
    from ..output.dataset import RecordStream

    return RecordStream(path, derive(scene.rig).natural_circular_frequency)


def figure_format(path: str | os.PathLike) -> str:
    """The format of a figure file by its suffix (png, pdf or svg).

    Raises
    ------
    HertzsweepError
        Another suffix.
    """
    from ..output.plot import figure_format as format_of

    return format_of(path)


def write_figure(fig: Any, path: str | os.PathLike, **metadata: Any) -> None:
    """Write a figure atomically, its metadata naming the datasets and the command
    (:func:`hertzsweep.output.plot.write_figure`)."""
    from ..output.plot import write_figure as write

    write(fig, path, **metadata)


__all__ = [
    "history",
    "figure_format",
    "write_figure",
    "OutputPathError",
    "atomic_path",
    "check_not_input",
    "check_output",
    "lock_output",
    "parts_folder",
    "read_attributes",
    "read_dataset",
    "record_stream",
    "remove_stale_temporaries",
    "write",
]
