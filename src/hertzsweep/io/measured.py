"""Measured data in and fits out: CSV files, the ``measured`` and ``fit`` datasets.

A measurement file is CSV with a header line; lines whose first cell starts with ``#``
and blank lines are skipped. Two kinds, told apart by the header:

- sweeps, as a lock-in reads them: ``direction,sigma,frequency,amplitude,phase``, one row
  per reading; ``frequency`` in Hz (or ``frequency_ratio`` instead), ``amplitude`` the
  peak A_k of N/F_s, ``phase`` phi_k in degrees (SPEC convention; an empty cell: not
  measured); optional ``harmonic`` (k, default 1);
- jump frequencies: ``direction,sigma,jump_frequency`` [Hz] (or ``jump_frequency_ratio``).

Both may have a ``reference`` column (free text: where the value comes from). A file
that breaks a rule (a missing or unknown column, a cell that is not a number or out of
range, an unknown direction, a repeated row) raises
:class:`~hertzsweep.errors.MeasurementError` naming the file, the line and the column.

:func:`measured_dataset` puts the measurements in the sweep layout (``amplitude`` and
``phase`` on ``direction, sigma, frequency, harmonic``, NaN where not measured; or
``jump_frequency`` on ``direction, sigma``), ``hertzsweep_kind = "measured"``;
:func:`fit_dataset` writes a :class:`~hertzsweep.drivers.fit.FitResult`: the data, the
fitted model at every measured point, the residuals, the estimates with their standard
errors and correlations (``hertzsweep_kind = "fit"``).
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .. import __version__
from ..core.config import Scene, read_text
from ..core.lockin import order_label
from ..drivers.fit import (
    FitResult,
    JumpMeasurements,
    Measurements,
    SweepMeasurements,
)
from ..errors import ConfigError, HertzsweepError, MeasurementError
from ..output.dataset import (
    CONVENTIONS,
    REFERENCES,
    SUMMARIES,
    attrs,
    global_attributes,
    history_line,
    merge_attributes,
    ordered_attributes,
    provenance,
)
from ..output.frame import load_xarray

xr = load_xarray()  # xarray with its dask probe kept quiet

DIRECTIONS = ("up", "down")
MAX_MEASUREMENT_BYTES = 64 * 2**20  # a rig's CSV of sweeps or jumps is kilobytes; 64 MiB
# leaves room for a long record and refuses a wrong file (a device, a disk image) early
SWEEP_COLUMNS = ("direction", "sigma", "frequency", "amplitude", "phase")
JUMP_COLUMNS = ("direction", "sigma", "jump_frequency")
RATIO_COLUMNS = {"frequency": "frequency_ratio", "jump_frequency": "jump_frequency_ratio"}
OPTIONAL_COLUMNS = {"sweep": ("harmonic", "reference"), "jumps": ("reference",)}
KIND = "measured"
FIT_KIND = "fit"

PARAMETER_UNITS = {
    "rig.natural_frequency": "Hz",
    "damping.ratio": "1",
    "damping.exponent": "1",
}
RESIDUAL_UNITS = "relative (amplitudes and jump frequencies); radian (phases)"


# --------------------------------------------------------------------------- CSV
def csv_rows(source: str, text: str, delimiter: str = ",") -> list[tuple[int, list[str]]]:
    """``(line, cells)`` of every row of a CSV text, its cells stripped; blank lines and
    lines whose first cell starts with ``#`` left out.

    Raises
    ------
    MeasurementError
        Not CSV (naming the line).
    """
    reader = csv.reader(io.StringIO(text), delimiter=delimiter)
    rows: list[tuple[int, list[str]]] = []
    try:
        for cells in reader:
            if not cells or all(not c.strip() for c in cells):
                continue
            if cells[0].lstrip().startswith("#"):
                continue
            rows.append((reader.line_num, [c.strip() for c in cells]))
    except csv.Error as exc:
        raise MeasurementError(source, reader.line_num, "", f"not CSV ({exc})") from None
    return rows


class _Table:
    """The rows of a CSV file: ``(line, {column: cell})``, comments and blank lines out."""

    def __init__(self, source: str, text: str) -> None:
        self.source = source
        rows = csv_rows(source, text)
        if not rows:
            raise MeasurementError(source, 0, "", "no header line (and no data)")
        self.header_line, self.columns = rows[0]
        self.rows = rows[1:]

    def error(self, line: int, column: str, reason: str) -> MeasurementError:
        return MeasurementError(self.source, line, column, reason)


def read_measurements(path: str | os.PathLike) -> Measurements:
    """The measurements of a CSV file (module notes).

    Raises
    ------
    MeasurementError
        The file is missing or unreadable, or breaks a rule: one line naming the file,
        the line and the column.
    """
    source = str(path)
    try:  # a regular UTF-8 text file (never a FIFO or a device), a BOM allowed
        text = read_text(path, MAX_MEASUREMENT_BYTES).removeprefix("\ufeff")
    except ConfigError as exc:
        raise MeasurementError(source, 0, "", exc.reason) from None
    table = _Table(source, text)
    kind, frequency_column = _check_header(table)
    values = _parse_rows(table, kind, frequency_column)
    in_hertz = frequency_column in ("frequency", "jump_frequency")
    reference = np.array(values.get("reference", [""] * len(table.rows)), dtype=object)
    if kind == "jumps":
        return JumpMeasurements(
            direction=np.array(values["direction"]),
            sigma=np.array(values["sigma"]),
            frequency=np.array(values[frequency_column]),
            in_hertz=in_hertz,
            source=source,
            reference=reference,
        )
    return SweepMeasurements(
        direction=np.array(values["direction"]),
        sigma=np.array(values["sigma"]),
        frequency=np.array(values[frequency_column]),
        harmonic=np.array(values.get("harmonic", [1] * len(table.rows)), dtype=np.float64),
        amplitude=np.array(values["amplitude"]),
        phase=np.array(values["phase"]),
        in_hertz=in_hertz,
        source=source,
        reference=reference,
    )


def _check_header(table: _Table) -> tuple[str, str]:
    """The file's kind (``sweep`` or ``jumps``) and its frequency column."""
    columns, line = table.columns, table.header_line
    for i, name in enumerate(columns):
        if not name:
            raise table.error(line, f"column {i + 1}", "empty column name in the header")
        if name in columns[:i]:
            raise table.error(line, name, "column named twice in the header")
    jumps = any(name.startswith("jump_frequency") for name in columns)
    kind, required = ("jumps", JUMP_COLUMNS) if jumps else ("sweep", SWEEP_COLUMNS)
    frequency = required[2]
    if frequency in columns and RATIO_COLUMNS[frequency] in columns:
        raise table.error(
            line, RATIO_COLUMNS[frequency], f"give {frequency} [Hz] or {RATIO_COLUMNS[frequency]}"
        )
    if RATIO_COLUMNS[frequency] in columns:
        frequency = RATIO_COLUMNS[frequency]
    needed = tuple(frequency if name == required[2] else name for name in required)
    known = needed + OPTIONAL_COLUMNS[kind]
    described = (
        f"a {'jump-frequency' if jumps else 'sweep'} file has {', '.join(required)} "
        f"({required[2]} in Hz, or {RATIO_COLUMNS[required[2]]}), optional "
        f"{', '.join(OPTIONAL_COLUMNS[kind])}"
    )
    for name in columns:
        if name not in known:
            raise table.error(line, name, f"unknown column ({described})")
    for name in needed:
        if name not in columns:
            raise table.error(line, name, f"missing column ({described})")
    return kind, frequency


def _number(table: _Table, line: int, column: str, cell: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise table.error(line, column, f"not a number: {cell!r}") from None
    if not math.isfinite(value):
        raise table.error(line, column, f"expected a finite number, got {cell!r}")
    return value


def _positive(table: _Table, line: int, column: str, cell: str) -> float:
    value = _number(table, line, column, cell)
    if value <= 0.0:
        raise table.error(line, column, f"must be positive, got {cell!r}")
    return value


def _phase(table: _Table, line: int, column: str, cell: str) -> float:
    if not cell:
        return math.nan  # not measured
    return _number(table, line, column, cell) % 360.0


def _harmonic(table: _Table, line: int, column: str, cell: str) -> int:
    value = _number(table, line, column, cell)
    if value < 1 or not value.is_integer():
        raise table.error(line, column, f"expected a whole number >= 1, got {cell!r}")
    return int(value)


def _direction(table: _Table, line: int, column: str, cell: str) -> str:
    if cell.lower() not in DIRECTIONS:
        raise table.error(line, column, f"unknown direction {cell!r} (expected up or down)")
    return cell.lower()


CELLS: dict[str, Callable[[_Table, int, str, str], Any]] = {  # column -> its parser
    "direction": _direction,
    "sigma": _positive,
    "frequency": _positive,
    "frequency_ratio": _positive,
    "amplitude": _positive,
    "phase": _phase,
    "harmonic": _harmonic,
    "jump_frequency": _positive,
    "jump_frequency_ratio": _positive,
    "reference": lambda table, line, column, cell: cell,
}


def _parse_rows(table: _Table, kind: str, frequency: str) -> dict[str, list[Any]]:
    """Every cell parsed, rows checked for their length and for repeats."""
    if not table.rows:
        raise table.error(table.header_line, "", "no measurements after the header")
    values: dict[str, list[Any]] = {name: [] for name in table.columns}
    seen: dict[tuple, int] = {}
    for line, cells in table.rows:
        if len(cells) != len(table.columns):
            raise table.error(
                line, "", f"expected {len(table.columns)} cells as the header, got {len(cells)}"
            )
        row = {
            name: CELLS[name](table, line, name, cell)
            for name, cell in zip(table.columns, cells, strict=True)
        }
        for name, value in row.items():
            values[name].append(value)
        if kind == "jumps":
            key, column = (row["direction"], row["sigma"]), "sigma"
            what = f"direction {key[0]}, sigma {key[1]:g}"
        else:
            key = (row["direction"], row["sigma"], row[frequency], row.get("harmonic", 1))
            column = frequency
            what = (
                f"direction {key[0]}, sigma {key[1]:g}, {frequency} {key[2]:g}, harmonic {key[3]}"
            )
        if key in seen:
            raise table.error(line, column, f"repeats line {seen[key]} ({what})")
        seen[key] = line
    return values


# --------------------------------------------------------------------------- datasets
def _base_attributes(title: str, kind: str, history: str | None) -> dict[str, Any]:
    """Conventions and provenance of a dataset made without a scene, in the order of
    :func:`~hertzsweep.output.dataset.ordered_attributes`."""
    out = {
        "Conventions": CONVENTIONS,
        "title": title,
        "summary": SUMMARIES[kind],
        "history": history or history_line(),
        "source": f"hertzsweep {__version__}",
        "references": REFERENCES,
        "hertzsweep_kind": kind,
        **provenance(),
    }
    return ordered_attributes(out)


def _frequency_name(data: Measurements) -> str:
    """The dimension of the measured frequencies: ``frequency`` [Hz] or ``frequency_ratio``."""
    return "frequency" if data.in_hertz else "frequency_ratio"


def _jump_name(data: JumpMeasurements) -> str:
    return "jump_frequency" if data.in_hertz else "jump_frequency_ratio"


def _grid(
    data: Measurements,
) -> tuple[list[str], np.ndarray, dict[str, Any], list[tuple[int, int]]]:
    """Directions present (up first), sigma levels, coordinates, and per row the indices
    ``(direction, sigma)``."""
    directions = [d for d in DIRECTIONS if np.any(data.direction == d)]
    sigma = np.unique(data.sigma)
    cells = [
        (directions.index(d), int(np.searchsorted(sigma, s)))
        for d, s in zip(data.direction, data.sigma, strict=True)
    ]
    coords = {
        "direction": ("direction", np.array(directions, dtype=object), attrs("direction")),
        "sigma": ("sigma", sigma, attrs("sigma")),
    }
    return directions, sigma, coords, cells


def _references(data: Measurements, shape: tuple[int, int], cells) -> np.ndarray | None:
    """The ``reference`` texts per (direction, sigma): the distinct ones joined by "; "."""
    if data.reference is None or not any(data.reference):
        return None
    texts: dict[tuple[int, int], list[str]] = {}
    for cell, text in zip(cells, data.reference, strict=True):
        if text and text not in texts.setdefault(cell, []):
            texts[cell].append(text)
    out = np.full(shape, "", dtype=object)
    for (d, s), items in texts.items():
        out[d, s] = "; ".join(items)
    return out


def measured_dataset(
    data: Measurements, scene: Scene | None = None, history: str | None = None
) -> xr.Dataset:
    """The ``measured`` dataset of measurements (module notes). ``scene`` is not used
    (the builders' signature); the data carry no f0."""
    directions, sigma, coords, cells = _grid(data)
    shape = (len(directions), sigma.size)
    variables: dict[str, Any] = {}
    if isinstance(data, JumpMeasurements):
        name = _jump_name(data)
        values = np.full(shape, np.nan)
        for (d, s), f in zip(cells, data.frequency, strict=True):
            values[d, s] = f
        variables[name] = (("direction", "sigma"), values, attrs(name))
        title = "Measured jump frequencies of a preloaded Hertzian contact"
    else:
        axis = _frequency_name(data)
        frequency = np.unique(data.frequency)
        harmonic = np.unique(data.harmonic).astype(np.float64)  # orders, as a sweep's
        amplitude = np.full((*shape, frequency.size, harmonic.size), np.nan)
        phase = np.full_like(amplitude, np.nan)
        i = np.searchsorted(frequency, data.frequency)
        k = np.searchsorted(harmonic, data.harmonic)
        for row, (d, s) in enumerate(cells):
            amplitude[d, s, i[row], k[row]] = data.amplitude[row]
            phase[d, s, i[row], k[row]] = data.phase[row]
        dims = ("direction", "sigma", axis, "harmonic")
        variables["amplitude"] = (dims, amplitude, attrs("amplitude"))
        variables["phase"] = (dims, phase, attrs("phase"))
        coords[axis] = (axis, frequency, attrs(axis))
        coords["harmonic"] = ("harmonic", harmonic, attrs("harmonic"))
        title = "Measured stepped-sine sweeps of a preloaded Hertzian contact"
    reference = _references(data, shape, cells)
    if reference is not None:
        variables["reference"] = (("direction", "sigma"), reference, attrs("reference"))
    ds = xr.Dataset(variables, coords=coords, attrs=_base_attributes(title, KIND, history))
    merge_attributes(
        ds, {"measured_kind": data.kind, "measured_file": os.path.abspath(data.source)}
    )
    return ds


def measurements_from_dataset(ds: xr.Dataset, source: str) -> Measurements:
    """The measurements of a ``measured`` dataset (as :func:`read_measurements` read
    them, minus the row order).

    Raises
    ------
    HertzsweepError
        The dataset is not of kind ``measured``.
    """
    kind = ds.attrs.get("hertzsweep_kind")
    if kind != KIND:
        raise HertzsweepError(
            f"{source}: expected measurements (a CSV file, or a dataset of `hertzsweep "
            f"import`), got a {kind or 'non-hertzsweep'} dataset"
        )
    references = ds["reference"].to_series() if "reference" in ds else None

    def reference(d: np.ndarray, s: np.ndarray) -> np.ndarray | None:
        if references is None:
            return None
        return np.array([references[(a, b)] for a, b in zip(d, s, strict=True)], dtype=object)

    if ds.attrs.get("measured_kind") == "jumps":
        name = "jump_frequency" if "jump_frequency" in ds else "jump_frequency_ratio"
        table = ds[name].to_series().dropna()
        d = np.array(table.index.get_level_values("direction"), dtype=str)
        s = np.array(table.index.get_level_values("sigma"), dtype=float)
        return JumpMeasurements(
            direction=d,
            sigma=s,
            frequency=table.to_numpy(),
            in_hertz=name == "jump_frequency",
            source=source,
            reference=reference(d, s),
        )
    axis = "frequency" if "frequency" in ds.amplitude.dims else "frequency_ratio"
    amplitude = ds.amplitude.to_series()
    measured = amplitude.notna().to_numpy()
    index = amplitude.index[measured]
    phase = ds.phase.to_series().to_numpy()[measured]
    d = np.array(index.get_level_values("direction"), dtype=str)
    s = np.array(index.get_level_values("sigma"), dtype=float)
    return SweepMeasurements(
        direction=d,
        sigma=s,
        frequency=np.array(index.get_level_values(axis), dtype=float),
        harmonic=np.array(index.get_level_values("harmonic"), dtype=np.float64),
        amplitude=amplitude.to_numpy()[measured],
        phase=phase,
        in_hertz=axis == "frequency",
        source=source,
        reference=reference(d, s),
    )


def fit_dataset(
    result: FitResult,
    scene: Scene | None = None,
    history: str | None = None,
    command: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """The ``fit`` dataset of a :class:`~hertzsweep.drivers.fit.FitResult` (module
    notes). Its global attributes are those of the scene with the estimates set
    (``natural_frequency`` the fitted f0 when it was free), plus the fit's summary."""
    data = result.data
    directions, sigma, coords, cells = _grid(data)
    shape = (len(directions), sigma.size)
    f0 = _f0(result)
    if isinstance(data, JumpMeasurements):
        variables = _jump_variables(result, cells, shape)
        coords["curve_sigma"] = ("curve_sigma", result.curve_sigma, attrs("curve_sigma"))
        order = [("down", "up").index(d) for d in directions]
        variables["curve_jump_frequency_ratio"] = (
            ("direction", "curve_sigma"),
            result.curve_frequency_ratio[order],
            attrs("curve_jump_frequency_ratio"),
        )
    else:
        variables, axis_coords = _sweep_variables(result, cells, shape, f0)
        coords.update(axis_coords)
    variables.update(_parameter_variables(result))
    coords["parameter"] = ("parameter", np.array(result.keys, dtype=object), attrs("parameter"))
    coords["parameter_column"] = (
        "parameter_column",
        np.array(result.keys, dtype=object),
        attrs("parameter_column"),
    )
    if result.laws:
        law_variables, law_coords = _law_variables(result)
        variables.update(law_variables)
        coords.update(law_coords)
    title = "Least-squares identification of a preloaded Hertzian contact from measurements"
    command = command or {"command": "fit", "free": list(result.keys), "method": result.method}
    ds = xr.Dataset(
        variables,
        coords=coords,
        attrs=global_attributes(result.scene, title, FIT_KIND, history, command=command),
    )
    extra: dict[str, Any] = {
        "measured_kind": data.kind,
        "measured_file": os.path.abspath(data.source),
        "fit_method": result.method,
        "fit_free": ",".join(result.keys),
        "residual_rms": float(result.residual_rms),
        "residual_units": RESIDUAL_UNITS,
        "fit_residuals": int(result.residuals.size),
        "fit_evaluations": int(result.evaluations),
        "fit_success": int(result.success),
        "fit_message": result.message,
    }
    for key, x, s in zip(result.keys, result.estimate, result.standard_error, strict=True):
        name = key.replace(".", "_")
        extra[f"fit_{name}"] = float(x)
        extra[f"fit_{name}_standard_error"] = float(s)
    merge_attributes(ds, extra)
    return ds


def _f0(result: FitResult) -> float:
    from ..core.rig import derive

    return derive(result.scene.rig).natural_frequency


def _per_cell(values: np.ndarray, cells, shape: tuple[int, ...]) -> np.ndarray:
    out = np.full(shape, np.nan)
    for (d, s), value in zip(cells, values, strict=True):
        out[d, s] = value
    return out


def _jump_variables(result: FitResult, cells, shape) -> dict[str, Any]:
    data = result.data
    name = _jump_name(data)
    dims = ("direction", "sigma")
    model = result.model["frequency"]
    return {
        name: (dims, _per_cell(data.frequency, cells, shape), attrs(name)),
        f"model_{name}": (dims, _per_cell(model, cells, shape), attrs(f"model_{name}")),
        "residual_jump": (
            dims,
            _per_cell(result.point_residuals["jump"], cells, shape),
            attrs("residual_jump"),
        ),
    }


def _sweep_variables(result: FitResult, cells, shape, f0: float) -> tuple[dict, dict]:
    """H1 measured and fitted on ``direction, sigma, frequency`` (NaN where not measured)."""
    data = result.data
    axis = _frequency_name(data)
    frequency = np.unique(data.frequency)
    i = np.searchsorted(frequency, data.frequency)
    full = (*shape, frequency.size)

    def grid(values: np.ndarray) -> np.ndarray:
        out = np.full(full, np.nan)
        for row, (d, s) in enumerate(cells):
            out[d, s, i[row]] = values[row]
        return out

    residual = result.point_residuals
    dims = ("direction", "sigma", axis)
    variables = {
        "amplitude": (dims, grid(data.amplitude), attrs("amplitude")),
        "phase": (dims, grid(data.phase), attrs("phase")),
        "model_amplitude": (dims, grid(result.model["amplitude"]), attrs("model_amplitude")),
        "model_phase": (dims, grid(result.model["phase"]), attrs("model_phase")),
        "residual_amplitude": (dims, grid(residual["amplitude"]), attrs("residual_amplitude")),
        "residual_phase": (
            dims,
            grid(np.degrees(residual["phase"])),
            attrs("residual_phase"),
        ),
    }
    other = "frequency_ratio" if axis == "frequency" else "frequency"
    scaled = frequency / f0 if axis == "frequency" else frequency * f0
    coords = {axis: (axis, frequency, attrs(axis)), other: (axis, scaled, attrs(other))}
    return variables, coords


def _parameter_variables(result: FitResult) -> dict[str, Any]:
    keys = ("parameter",)
    units = np.array([PARAMETER_UNITS[k] for k in result.keys], dtype=object)
    return {
        "parameter_units": (keys, units, attrs("parameter_units")),
        "estimate": (keys, result.estimate, attrs("estimate")),
        "standard_error": (keys, result.standard_error, attrs("standard_error")),
        "initial_value": (keys, result.initial, attrs("initial_value")),
        "lower_bound": (keys, result.lower, attrs("lower_bound")),
        "upper_bound": (keys, result.upper, attrs("upper_bound")),
        "at_bound": (keys, result.at_bound.astype(np.int8), attrs("at_bound")),
        "correlation": (
            ("parameter", "parameter_column"),
            result.correlation,
            attrs("correlation"),
        ),
    }


def _law_variables(result: FitResult) -> tuple[dict, dict]:
    """The contact-law comparison on a ``law`` dimension, each law's estimates over the
    fit's parameters (NaN where the law held one fixed)."""
    laws = result.laws
    keys = list(result.keys)
    estimate = np.full((len(laws), len(keys)), np.nan)
    error = np.full_like(estimate, np.nan)
    for row, law in enumerate(laws):
        fitted = law.result
        for key, x, s in zip(fitted.keys, fitted.estimate, fitted.standard_error, strict=True):
            estimate[row, keys.index(key)] = x
            error[row, keys.index(key)] = s
    dims = ("law", "parameter")
    variables = {
        "law_estimate": (dims, estimate, attrs("law_estimate")),
        "law_standard_error": (dims, error, attrs("law_standard_error")),
        "law_residual_rms": (
            ("law",),
            np.array([law.result.residual_rms for law in laws]),
            attrs("law_residual_rms"),
        ),
    }
    coords = {
        "law": ("law", np.arange(len(laws), dtype=np.int32), attrs("law")),
        "law_exponent": (
            "law",
            np.array([law.exponent for law in laws]),
            attrs("law_exponent"),
        ),
    }
    return variables, coords


# --------------------------------------------------------------------------- summaries
def measured_summary(data: Measurements, ds: xr.Dataset) -> str:
    """What ``hertzsweep import`` prints: what the file holds."""
    levels = ", ".join(f"{s:g}" for s in ds.sigma.values)
    directions = ", ".join(str(d) for d in ds.direction.values)
    if isinstance(data, JumpMeasurements):
        unit = "Hz" if data.in_hertz else "(frequency ratio)"
        return (
            f"measured jump frequencies: {data.frequency.size} ({directions}) at sigma "
            f"{levels}; {np.min(data.frequency):g} to {np.max(data.frequency):g} {unit}"
        )
    unit = "Hz" if data.in_hertz else "(frequency ratio)"
    harmonics = ", ".join(order_label(k) for k in ds.harmonic.values)
    return (
        f"measured sweeps: {data.amplitude.size} readings ({directions}; harmonic "
        f"{harmonics}) at sigma {levels}; {np.min(data.frequency):g} to "
        f"{np.max(data.frequency):g} {unit}"
    )


def _law_name(exponent: float) -> str:
    if math.isnan(exponent):
        return "n free"
    names = {0.0: "0", 0.5: "1/2", 1.0: "1", 1.5: "3/2"}
    return f"n = {names.get(exponent, f'{exponent:g}')}"


def fit_summary(result: FitResult, ds: xr.Dataset | None = None) -> str:
    """What ``hertzsweep fit`` prints: the estimates with their standard errors, the
    correlations, the residual RMS and, with ``--compare-laws``, the table of laws."""
    data = result.data
    count = data.frequency.size
    what = "jump frequencies" if isinstance(data, JumpMeasurements) else "H1 readings"
    lines = [
        f"fit of {', '.join(result.keys)} to {count} {what} ({result.method}, "
        f"{result.evaluations} model evaluations)",
        f"{'parameter':24s} {'estimate':>14s} {'std. error':>11s} {'start':>11s}",
    ]
    for i, key in enumerate(result.keys):
        note = "  (on a bound)" if result.at_bound[i] else ""
        lines.append(
            f"{key:24s} {result.estimate[i]:14.8g} {result.standard_error[i]:11.3g} "
            f"{result.initial[i]:11.5g}{note}"
        )
    for i in range(len(result.keys)):
        for j in range(i + 1, len(result.keys)):
            lines.append(
                f"correlation {result.keys[i]} / {result.keys[j]}: {result.correlation[i, j]:+.3f}"
            )
    lines.append(f"residual RMS {result.residual_rms:.4g} ({RESIDUAL_UNITS})")
    if not result.success:
        lines.append(f"the search did not converge: {result.message}")
    if result.laws:
        lines.append(_law_table(result))
    return "\n".join(lines)


def _law_table(result: FitResult) -> str:
    """The contact laws side by side (Figure 15 against Figure 11)."""
    keys = [k for k in result.keys]
    head = f"{'law':8s} " + " ".join(f"{k:>26s}" for k in keys) + f" {'residual RMS':>13s}"
    lines = [head]
    for law in result.laws:
        fitted = law.result
        pairs = zip(fitted.estimate, fitted.standard_error, strict=True)
        found = dict(zip(fitted.keys, pairs, strict=True))
        cells = []
        for key in keys:
            if key in found:
                x, s = found[key]
                cells.append(f"{x:13.5g} +- {s:<9.2g}")
            else:
                cells.append(f"{law.exponent:13g} (fixed)  ")
        lines.append(
            f"{_law_name(law.exponent):8s} "
            + " ".join(f"{c:>26s}" for c in cells)
            + f" {law.result.residual_rms:13.4g}"
        )
    return "\n".join(lines)


def fit_json(result: FitResult, output: str | None = None) -> dict[str, Any]:
    """``--json``: ``{"parameters": {KEY: {"estimate", "standard_error", ...}},
    "residual_rms", ...}`` (NaN and infinity as null)."""

    def number(x: float) -> float | None:
        return float(x) if math.isfinite(x) else None

    parameters = {}
    for i, key in enumerate(result.keys):
        parameters[key] = {
            "estimate": number(result.estimate[i]),
            "standard_error": number(result.standard_error[i]),
            "initial": number(result.initial[i]),
            "lower_bound": number(result.lower[i]),
            "upper_bound": number(result.upper[i]),
            "at_bound": bool(result.at_bound[i]),
            "units": PARAMETER_UNITS[key],
        }
    out: dict[str, Any] = {
        "parameters": parameters,
        "residual_rms": number(result.residual_rms),
        "residual_units": RESIDUAL_UNITS,
        "residuals": int(result.residuals.size),
        "correlation": {
            a: {b: number(result.correlation[i, j]) for j, b in enumerate(result.keys)}
            for i, a in enumerate(result.keys)
        },
        "method": result.method,
        "evaluations": int(result.evaluations),
        "success": bool(result.success),
        "message": result.message,
        "measured": result.data.source,
        "measured_kind": result.data.kind,
    }
    if output is not None:
        out["output"] = output
    if result.laws:
        out["laws"] = [
            {
                "exponent": number(law.exponent),
                "parameters": fit_json(law.result)["parameters"],
                "residual_rms": number(law.result.residual_rms),
            }
            for law in result.laws
        ]
    return out


__all__ = [
    "FIT_KIND",
    "KIND",
    "fit_dataset",
    "fit_json",
    "fit_summary",
    "measured_dataset",
    "measured_summary",
    "measurements_from_dataset",
    "read_measurements",
]
