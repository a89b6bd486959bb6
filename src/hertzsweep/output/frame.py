"""A dataset as plain numpy arrays: what the builders make and the netCDF writer reads.

A command that writes a sweep, a trace or a branch needs neither xarray nor pandas
(importing them, with the dask probe xarray makes, is most of a short run's start-up);
:class:`Frame` holds the variables, coordinates and attributes with the few names the
writer (:func:`hertzsweep.output.dataset.write_netcdf`) and the summaries use, which are
also xarray's: ``attrs``, ``sizes``, ``dims``, ``coords``, ``data_vars``, ``variables``,
``ds[name].dims / .values / .attrs``. :meth:`Frame.to_xarray` gives the
:class:`xarray.Dataset` that reading the written file gives, for the callers that
compute with one (figures, studies, tests).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

Entry = tuple[Any, Any, dict[str, Any]]  # (dims: a name or a tuple of names, values, attrs)


@dataclass
class Variable:
    """One variable: its dimensions, values and attributes."""

    dims: tuple[str, ...]
    values: np.ndarray
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.values.shape


def _variable(name: str, entry: Entry) -> Variable:
    dims, values, attrs = entry
    dims = (dims,) if isinstance(dims, str) else tuple(dims)
    values = np.asarray(values)
    if values.ndim != len(dims):
        raise ValueError(f"{name}: {values.ndim} dimension(s) of values for dims {dims}")
    return Variable(dims, values, dict(attrs))


class Frame:
    """Coordinates, data variables and global attributes of one dataset.

    Parameters
    ----------
    data : ``{name: (dims, values, attrs)}``, the data variables.
    coords : the same for the coordinates.
    attrs : the global attributes.

    Raises
    ------
    ValueError
        A dimension has two lengths, or values do not match their dims.
    """

    def __init__(
        self, data: Mapping[str, Entry], coords: Mapping[str, Entry], attrs: Mapping[str, Any]
    ) -> None:
        self.coords = {name: _variable(name, entry) for name, entry in coords.items()}
        self.data_vars: dict[str, Variable] = {}
        self.attrs = dict(attrs)
        self.sizes: dict[str, int] = {}
        for variable in self.coords.values():
            self._size(variable)
        for name, entry in data.items():
            self[name] = entry

    def _size(self, variable: Variable) -> None:
        for dim, n in zip(variable.dims, variable.shape, strict=True):
            if self.sizes.setdefault(dim, n) != n:
                raise ValueError(f"dimension {dim!r} of lengths {self.sizes[dim]} and {n}")

    def __setitem__(self, name: str, entry: Entry) -> None:
        variable = _variable(name, entry)
        self._size(variable)
        self.data_vars[name] = variable

    def __getitem__(self, name: str) -> Variable:
        return self.variables[name]

    def __contains__(self, name: object) -> bool:
        return name in self.variables

    @property
    def variables(self) -> dict[str, Variable]:
        """Coordinates first, then data variables (the writer's order)."""
        return {**self.coords, **self.data_vars}

    @property
    def dims(self) -> dict[str, int]:
        return self.sizes

    def to_xarray(self) -> Any:
        """The :class:`xarray.Dataset` of the same variables, coordinates and attributes."""
        xr = load_xarray()

        def entries(variables: dict[str, Variable]) -> dict[str, Entry]:
            return {name: (v.dims, v.values, dict(v.attrs)) for name, v in variables.items()}

        return xr.Dataset(entries(self.data_vars), entries(self.coords), dict(self.attrs))


def as_xarray(ds: Any) -> Any:
    """An :class:`xarray.Dataset` of a :class:`Frame` (an xarray dataset as it is)."""
    return ds.to_xarray() if isinstance(ds, Frame) else ds


def load_xarray() -> Any:
    """xarray, imported on first use, its dask probe kept quiet (below)."""
    import xarray

    _quiet_dask_probe()
    return xarray


def _quiet_dask_probe() -> None:
    """Keep xarray from importing dask when it wraps numpy data.

    xarray asks for dask's array type each time it wraps data into a variable
    (``xarray.core.variable.array_type("dask")``), which imports ``dask.array`` (0.2 s, and
    distributed's configuration) although no array here is a dask array. While
    ``dask.array`` has not been imported, no array can be one: answer with no type. Once
    anything imports dask.array, xarray's own answer is used.
    """
    from xarray.core import variable

    original = getattr(variable, "array_type", None)
    if original is None or getattr(original, "hertzsweep", False):
        return

    def array_type(mod: str) -> Any:
        if mod == "dask" and "dask.array" not in sys.modules:
            return ()
        return original(mod)

    array_type.hertzsweep = True  # type: ignore[attr-defined]
    variable.array_type = array_type
