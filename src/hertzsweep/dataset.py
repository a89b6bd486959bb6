"""Datasets: results -> self-describing xarray Datasets with CF-1.11 attributes.

The one table of output attributes is :data:`ATTRIBUTES`; every builder takes names
from it, so a variable means the same thing in every dataset. Only this layer knows
xarray; only the CLI opens and writes files, through :func:`write_atomic`.
"""

from __future__ import annotations

import datetime as _dt
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from . import __version__
from .config import Scene
from .rig import RigConstants, derive
from .sweep import SweepResult

CONVENTIONS = "CF-1.11"

# name -> (long_name, units[, extra attributes]); units "1" is dimensionless (of F_s).
ATTRIBUTES: dict[str, tuple[str, str] | tuple[str, str, dict[str, Any]]] = {
    # coordinates
    "direction": ("sweep direction", "1"),
    "sigma": ("input level F/F_s", "1"),
    "frequency_ratio": ("excitation frequency over the natural frequency f0", "1"),
    "frequency": ("excitation frequency", "Hz"),
    "harmonic": ("harmonic order k of the transmitted normal force", "1"),
    # sweep variables
    "amplitude": ("amplitude of harmonic k of N/F_s (peak)", "1"),
    "phase": ("phase lag of harmonic k behind the k-th excitation reference", "degree"),
    "mean_force": ("mean transmitted normal force N/F_s", "1"),
    "force_max": ("maximum of the transmitted normal force N/F_s", "1"),
    "force_min": ("minimum of the transmitted normal force N/F_s", "1"),
    "contact_loss_fraction": ("share of the period out of contact", "1"),
    "flight_time": ("longest flight (loss of contact) per period", "s"),
    "settled": ("steady state reached within the tolerance", "1"),
    "periodic": ("steady state repeats every excitation period", "1"),
    "jump_frequency_ratio": ("frequency ratio where the H1 response jumped", "1"),
    "jump_frequency": ("frequency where the H1 response jumped", "Hz"),
    # --- trace attributes (insert above this line)
    # --- branch attributes (insert above this line)
    # --- study attributes (insert above this line)
    # --- accuracy attributes (insert above this line)
}


def attrs(name: str) -> dict[str, Any]:
    """CF attributes of a named variable from :data:`ATTRIBUTES`."""
    entry = ATTRIBUTES[name]
    out: dict[str, Any] = {"long_name": entry[0], "units": entry[1]}
    if len(entry) > 2:
        out.update(entry[2])  # type: ignore[misc]
    return out


def history_line(argv: list[str] | None = None) -> str:
    """``history``: UTC time, the command line and the version (CF section 2.6.2)."""
    import shlex
    import sys

    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    command = shlex.join(argv if argv is not None else ["hertzsweep", *sys.argv[1:]])
    return f"{now}: {command} (hertzsweep {__version__})"


def global_attributes(
    scene: Scene, title: str, kind: str, history: str | None = None
) -> dict[str, Any]:
    """The global attributes every dataset carries: conventions, provenance, every
    resolved config value and the rig's derived constants."""
    constants = derive(scene.rig)
    out: dict[str, Any] = {
        "Conventions": CONVENTIONS,
        "title": title,
        "history": history or history_line(),
        "source": f"hertzsweep {__version__}",
        "hertzsweep_kind": kind,
        "scene_file": scene.source,
    }
    for key, value in scene.attributes().items():
        out[key] = _netcdf_value(value)
    for key, value in constants.as_dict().items():
        out[key] = float(value)
    return out


def _netcdf_value(value: Any) -> Any:
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, list):
        return np.asarray(value)
    return value


def _coords(result: SweepResult, constants: RigConstants) -> dict[str, Any]:
    return {
        "direction": ("direction", np.array(result.directions, dtype=object), attrs("direction")),
        "sigma": ("sigma", result.sigma, attrs("sigma")),
        "frequency_ratio": ("frequency_ratio", result.frequency_ratio, attrs("frequency_ratio")),
        "frequency": (
            "frequency_ratio",
            result.frequency_ratio * constants.natural_frequency,
            attrs("frequency"),
        ),
        "harmonic": ("harmonic", result.harmonics, attrs("harmonic")),
    }


def sweep_dataset(result: SweepResult, scene: Scene, history: str | None = None) -> xr.Dataset:
    """The SPEC's sweep dataset."""
    constants = derive(scene.rig)
    base = ("direction", "sigma", "frequency_ratio")
    data = {
        "amplitude": (base + ("harmonic",), result.amplitude),
        "phase": (base + ("harmonic",), result.phase),
        "mean_force": (base, result.mean_force),
        "force_max": (base, result.force_max),
        "force_min": (base, result.force_min),
        "contact_loss_fraction": (base, result.contact_loss_fraction),
        "flight_time": (base, result.flight_tau / constants.natural_circular_frequency),
        "settled": (base, result.settled.astype(np.int8)),
        "periodic": (base, result.periodic.astype(np.int8)),
        "jump_frequency_ratio": (("direction", "sigma"), result.jump_frequency_ratio),
        "jump_frequency": (
            ("direction", "sigma"),
            result.jump_frequency_ratio * constants.natural_frequency,
        ),
    }
    ds = xr.Dataset(
        {name: (dims, values, attrs(name)) for name, (dims, values) in data.items()},
        coords=_coords(result, constants),
        attrs=global_attributes(scene, "Stepped-sine sweep of a preloaded Hertzian contact",
                                "sweep", history),
    )  # fmt: skip
    for flag in ("settled", "periodic"):
        ds[flag].attrs.update(flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="no yes")
    ds.attrs["integration_steps"] = int(result.steps)
    return ds


# --------------------------------------------------------------------------- trace
# (trace dataset builders go here)

# --------------------------------------------------------------------------- branch
# (branch dataset builders go here)

# --------------------------------------------------------------------------- study
# (study dataset builders go here)

# --------------------------------------------------------------------------- accuracy
# (accuracy dataset builders go here)


# --------------------------------------------------------------------------- files
def write_atomic(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write netCDF4 to a temporary name in the same folder, then rename: the output is
    complete or absent."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        encoding = {
            name: {"zlib": True, "complevel": 4}
            for name, var in ds.data_vars.items()
            if var.dtype.kind == "f" and var.size > 1
        }
        ds.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def open_dataset(path: str | os.PathLike) -> xr.Dataset:
    """Open a hertzsweep netCDF file fully into memory (the file is closed on return)."""
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()


def merge_attributes(ds: xr.Dataset, extra: Mapping[str, Any]) -> xr.Dataset:
    ds.attrs.update({k: _netcdf_value(v) for k, v in extra.items()})
    return ds
