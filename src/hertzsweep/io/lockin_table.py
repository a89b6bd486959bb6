"""Lock-in tables in, measurement tables out.

:func:`read_lockin_table` reads a lock-in amplifier's readings, one per row, into
:class:`~hertzsweep.drivers.fit.SweepMeasurements` (the peak harmonics A_k of N/F_s and
their phase lags phi_k in the SPEC's convention), with the conversions of
:class:`~hertzsweep.io.import_options.ImportOptions`:

- **Files.** CSV: a header line, then one reading per line; blank lines and lines whose
  first cell starts with ``#`` are skipped; the separator is the one of ``,``, ``;`` and a
  tab that splits the header into the most cells (LabOne writes ``;``, a spreadsheet
  ``,``). JSON (the text starts with ``[`` or ``{``): a list of objects, one per reading
  (``[{"freq": 230.0, "X": 1e-3, "Y": -2e-4}, ...]``), or an object of columns
  (``{"freq": [...], "X": [...], "Y": [...]}``); numbers, or strings that hold one. UTF-8
  (a BOM allowed) and at most :data:`~hertzsweep.io.measured.MAX_MEASUREMENT_BYTES`.
- **Columns.** ``options.columns`` (or its ``preset``) maps the quantities ``frequency``
  [Hz], ``x`` and ``y`` (or ``r`` and ``phase``), and optionally ``harmonic``,
  ``direction`` and ``sigma`` to the file's column names (a name matches exactly, or else
  regardless of case when only one column does). Without a map, the columns named as the
  quantities are taken.
- **Values.** ``R e^{i theta} = x + i y`` (or ``r`` and ``phase``, in
  ``options.phase_unit``); the peak ``sqrt(2) R``, or ``R`` when ``options.rms`` is
  false (``--peak``); with a ``sensitivity`` [V/N] volts / sensitivity are newtons and
  newtons / ``static_load`` are N/F_s (the static load is then required), without one the
  values are N/F_s already (a file in newtons: ``sensitivity = 1``); ``phi_k = -theta``
  (the lock-in's lead, ``"lock-in"``) or ``theta`` (``"spec"``), in [0, 360) degrees.
- **Sweeps.** The level: the ``sigma`` column, else ``options.level``; the direction: the
  ``direction`` column, else ``options.direction``, else the order of the frequencies
  (rising: up, falling: down). One sweep is the rows of one (direction, sigma, harmonic),
  in the order of the file, which is the order the sweep visited them: up sweeps rise and
  down sweeps fall, strictly. The harmonic: the ``harmonic`` column, else 1.

A file or option that breaks a rule raises :class:`~hertzsweep.errors.MeasurementError`:
one line naming the file, the line (0 for the file or an option; JSON rows are named
``row N``) and the column or option.

:func:`write_measurement_csv` writes a ``sweep``, ``measured`` or ``fit`` dataset as
hertzsweep's own measurement CSV (``direction,sigma,frequency,amplitude,phase,harmonic``,
that :func:`~hertzsweep.io.measured.read_measurements` reads back exactly), and
:func:`write_lockin_csv` as a lock-in's table in volts RMS
(``direction,sigma,harmonic,frequency,x,y``, that :func:`read_lockin_table` reads back to
round-off). Both write every number with ``repr`` (the shortest text that reads back as
the same float), rows in the order each sweep visited its frequencies, and leave out the
points a sweep did not settle on (``settled`` or ``periodic`` 0) and those not measured
(NaN), which their :class:`WriteReport` counts.
"""

from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import __version__
from ..core.config import read_text
from ..drivers.fit import SweepMeasurements
from ..errors import ConfigError, HertzsweepError, MeasurementError
from ..output.paths import atomic_path
from .measured import DIRECTIONS, MAX_MEASUREMENT_BYTES, csv_rows

SEPARATORS = (",", ";", "\t")  # CSV separators a lock-in's table may use (LabOne: ";")
PAIRS = (("x", "y"), ("r", "phase"))  # the two ways a lock-in gives R e^{i theta}
OPTIONAL = ("harmonic", "direction", "sigma")  # quantities a file may hold or options give
RMS_TO_PEAK = math.sqrt(2.0)  # a sine's peak over its RMS
DATASET_KINDS = ("sweep", "measured", "fit")  # datasets that hold readings of harmonics
LOCKIN_HEADER = ("direction", "sigma", "harmonic", "frequency", "x", "y")  # write_lockin_csv
LEFT_OUT_REASON = "not settled or not measured"  # what write reports call a point left out


# --------------------------------------------------------------------------- tables
@dataclass(frozen=True)
class _Table:
    """The cells of a file: column names, and per row its place and its cells by name.

    Attributes
    ----------
    source : str
        The file, for messages.
    header_line : int
        The line of the CSV header (0: JSON).
    names : list of str
        The columns (CSV header cells, JSON keys).
    rows : list of (int, str, dict)
        Per reading: its line (0: JSON), its label for messages (``"row N: "`` in JSON, else
        empty) and its cells by column name.
    """

    source: str
    header_line: int
    names: list[str]
    rows: list[tuple[int, str, dict[str, Any]]]

    def error(self, row: int, column: str, reason: str) -> MeasurementError:
        """The error of a row's cell (``row`` -1: the header)."""
        if row < 0:
            return MeasurementError(self.source, self.header_line, column, reason)
        line, label, _ = self.rows[row]
        return MeasurementError(self.source, line, label + column, reason)

    def place(self, row: int) -> str:
        """A row for messages: ``line N`` (CSV) or ``row N`` (JSON)."""
        line, label, _ = self.rows[row]
        return f"line {line}" if line else label.removesuffix(": ")

    def cell(self, row: int, column: str) -> Any:
        """A row's cell (a JSON object may lack a key)."""
        cells = self.rows[row][2]
        if column not in cells:
            raise self.error(row, column, "missing (every reading holds every mapped column)")
        return cells[column]


def _separator(header: str) -> str:
    """The separator of :data:`SEPARATORS` that splits ``header`` into the most cells
    (``,`` when none splits it)."""
    counts = [len(next(csv.reader([header], delimiter=sep), [])) for sep in SEPARATORS]
    return SEPARATORS[int(np.argmax(counts))]


def _csv_table(source: str, text: str) -> _Table:
    """The table of a CSV text (module notes)."""
    lines = text.splitlines()
    header = next((s for s in lines if s.strip() and not s.lstrip().startswith("#")), None)
    if header is None:
        raise MeasurementError(source, 0, "", "no header line (and no readings)")
    found = csv_rows(source, text, _separator(header))
    if not found:
        raise MeasurementError(source, 0, "", "no header line (and no readings)")
    (header_line, names), body = found[0], found[1:]
    rows = []
    for line, cells in body:
        if len(cells) != len(names):
            reason = f"expected {len(names)} cells as the header, got {len(cells)}"
            raise MeasurementError(source, line, "", reason)
        rows.append((line, "", dict(zip(names, cells, strict=True))))
    return _Table(source, header_line, names, rows)


def _json_table(source: str, text: str) -> _Table:
    """The table of a JSON text: a list of objects, or an object of columns."""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MeasurementError(source, exc.lineno, "", f"not JSON ({exc.msg})") from None
    if isinstance(data, list):
        rows = []
        for i, item in enumerate(data):
            if not isinstance(item, dict):
                reason = f"expected an object {{column: value}}, got {type(item).__name__}"
                raise MeasurementError(source, 0, f"row {i + 1}", reason)
            rows.append((0, f"row {i + 1}: ", item))
        names = list(dict.fromkeys(name for _, _, item in rows for name in item))
        return _Table(source, 0, names, rows)
    for name, values in data.items():  # an object (the text starts with "[" or "{")
        if not isinstance(values, list) or len(values) != len(next(iter(data.values()))):
            reason = "an object of columns holds lists of one length, one value per reading"
            raise MeasurementError(source, 0, name, reason)
    count = len(next(iter(data.values()), []))
    rows = [(0, f"row {i + 1}: ", {k: v[i] for k, v in data.items()}) for i in range(count)]
    return _Table(source, 0, list(data), rows)


def _table(path: str | os.PathLike) -> _Table:
    """The table of a file, CSV or JSON by its first character."""
    source = str(path)
    try:  # a regular UTF-8 text file (never a FIFO or a device), a BOM allowed
        text = read_text(path, MAX_MEASUREMENT_BYTES).removeprefix("\ufeff")
    except ConfigError as exc:
        raise MeasurementError(source, 0, "", exc.reason) from None
    if text.lstrip()[:1] in ("[", "{"):
        table = _json_table(source, text)
    else:
        table = _csv_table(source, text)
    if not table.rows:
        raise table.error(-1, "", "no readings after the header")
    return table


# --------------------------------------------------------------------------- columns
def _column_map(table: _Table, options: Any, given: dict[str, str]) -> dict[str, str]:
    """Quantity -> the file's column, each one checked to be in the file."""
    columns = dict(options.columns)
    if not columns:  # no map: the columns named as the quantities
        lower = {name.lower(): name for name in table.names}
        names = ("frequency", *(q for pair in PAIRS for q in pair), *OPTIONAL)
        columns = {q: lower[q] for q in names if q in lower}
    pairs = [pair for pair in PAIRS if any(q in columns for q in pair)]
    if "frequency" not in columns or len(pairs) != 1 or not all(q in columns for q in pairs[0]):
        have = ", ".join(f"{q}={c}" for q, c in columns.items()) or "none"
        reason = (
            "map frequency and either x and y or r and phase, e.g. "
            f"--columns frequency=freq,x=X,y=Y (or a --preset); mapped: {have}"
        )
        raise MeasurementError(table.source, 0, "--columns", reason)
    found = {}
    for quantity, name in columns.items():
        found[quantity] = _find(table, quantity, name, _origin(options, quantity, given))
    return found


def _origin(options: Any, quantity: str, given: dict[str, str]) -> str:
    """Where a column's name comes from, for messages."""
    if quantity in given:
        return "--columns"
    if options.preset is not None:
        return f"the preset {options.preset}"
    return "the header"


def _find(table: _Table, quantity: str, name: str, origin: str) -> str:
    """The column of the file ``name`` means: itself, or the one column equal but for case."""
    if name in table.names:
        if table.names.count(name) > 1:
            raise table.error(-1, name, "column named twice in the header")
        return name
    same = [n for n in table.names if n.lower() == name.lower()]
    if len(same) == 1:
        return same[0]
    where = "header" if table.header_line else "keys"
    reason = f"missing column (the {quantity} of {origin}); the {where} has " + ", ".join(
        repr(n) for n in table.names
    )
    raise table.error(-1, name, reason)


# --------------------------------------------------------------------------- cells
def _float(table: _Table, row: int, column: str) -> float:
    """A cell as a finite number (a JSON number, or a text holding one)."""
    raw = table.cell(row, column)
    value = None
    if isinstance(raw, int | float) and not isinstance(raw, bool):
        value = float(raw)
    elif isinstance(raw, str):
        try:
            value = float(raw.strip())
        except ValueError:
            value = None
    if value is None:
        raise table.error(row, column, f"not a number: {raw!r}")
    if not math.isfinite(value):
        raise table.error(row, column, f"expected a finite number, got {raw!r}")
    return value


def _positive(table: _Table, row: int, column: str) -> float:
    value = _float(table, row, column)
    if value <= 0.0:
        raise table.error(row, column, f"must be positive, got {value!r}")
    return value


def _harmonic(table: _Table, row: int, column: str) -> int:
    value = _float(table, row, column)
    if value < 1 or not value.is_integer():
        raise table.error(row, column, f"expected a whole number >= 1, got {value!r}")
    return int(value)


def _direction(table: _Table, row: int, column: str) -> str:
    raw = table.cell(row, column)
    text = raw.strip().lower() if isinstance(raw, str) else None
    if text not in DIRECTIONS:
        raise table.error(row, column, f"unknown direction {raw!r} (expected up or down)")
    return text


# --------------------------------------------------------------------------- reading
def read_lockin_table(path: str | os.PathLike, options: Any) -> SweepMeasurements:
    """The readings of a lock-in table, as peak harmonics of N/F_s (module notes).

    Parameters
    ----------
    path : path
        A CSV or JSON file.
    options : ImportOptions
        The column map and conversions (:class:`~hertzsweep.io.import_options.ImportOptions`;
        its preset is applied and its values checked here). Not imported here:
        :mod:`~hertzsweep.io.formats` imports this module, and modules import one way.

    Returns
    -------
    SweepMeasurements
        One reading per row, in the file's order, frequencies in Hz.

    Raises
    ------
    MeasurementError
        The file is missing, unreadable or too large, or it or an option breaks a rule: one
        line naming the file, the line (0: the file or an option) and the column or option.
    """
    source = str(path)
    given = dict(options.columns)
    options = options.resolved(source)
    table = _table(path)
    columns = _column_map(table, options, given)
    level, direction = _checked_options(table, options, columns)
    n = len(table.rows)
    frequency = np.array([_positive(table, i, columns["frequency"]) for i in range(n)])
    sigma = _per_row(table, columns, "sigma", _positive, level)
    harmonic = _per_row(table, columns, "harmonic", _harmonic, 1)
    known = _per_row(table, columns, "direction", _direction, direction)
    directions = _sweep_directions(table, columns["frequency"], frequency, sigma, harmonic, known)
    amplitude, phase = _harmonics(table, columns, options)
    return SweepMeasurements(
        direction=np.array(directions, dtype=str),
        sigma=np.array(sigma, dtype=float),
        frequency=frequency,
        harmonic=np.array(harmonic, dtype=np.int64),
        amplitude=amplitude,
        phase=phase,
        in_hertz=True,
        source=source,
    )


def _checked_options(
    table: _Table, options: Any, columns: dict[str, str]
) -> tuple[float | None, str | None]:
    """The level and direction the options give, checked against the file's columns."""
    source = table.source
    if options.sensitivity is not None and options.static_load is None:
        reason = (
            "needed with --sensitivity: volts / sensitivity are newtons, and newtons / "
            "static load are N/F_s"
        )
        raise MeasurementError(source, 0, "--static-load", reason)
    level = options.level(source)
    if "sigma" in columns and level is not None:
        option = "--sigma" if options.sigma is not None else "--force-amplitude"
        reason = f"the file holds the level (column {columns['sigma']!r}); give no {option}"
        raise MeasurementError(source, 0, option, reason)
    if "sigma" not in columns and level is None:
        raise MeasurementError(source, 0, "--sigma", "no level: give --sigma or --force-amplitude")
    if "direction" in columns and options.direction is not None:
        reason = f"the file holds the direction (column {columns['direction']!r})"
        raise MeasurementError(source, 0, "--direction", reason)
    return level, options.direction


def _per_row(table: _Table, columns: dict[str, str], quantity: str, cell, default) -> list:
    """A quantity's value in every row: its column's cells, else ``default``."""
    if quantity not in columns:
        return [default] * len(table.rows)
    return [cell(table, i, columns[quantity]) for i in range(len(table.rows))]


def _sweep_directions(
    table: _Table,
    column: str,
    frequency: np.ndarray,
    sigma: Sequence[float],
    harmonic: Sequence[int],
    known: Sequence[str | None],
) -> list[str]:
    """Each row's direction, every sweep checked to visit its frequencies in one sense:
    rising (up) or falling (down), strictly."""
    sweeps: dict[tuple, list[int]] = {}
    for i, key in enumerate(zip(known, sigma, harmonic, strict=True)):
        sweeps.setdefault(key, []).append(i)
    out: list[str] = [""] * len(frequency)
    for (direction, level, k), rows in sweeps.items():
        if direction is None:
            if len(rows) < 2:
                reason = (
                    f"one reading at sigma {level:g}, harmonic {k}: the order of one "
                    "frequency gives no direction; give --direction"
                )
                raise MeasurementError(table.source, 0, "--direction", reason)
            direction = "up" if frequency[rows[1]] > frequency[rows[0]] else "down"
        sense = 1.0 if direction == "up" else -1.0
        for before, row in zip(rows, rows[1:], strict=False):
            if sense * (frequency[row] - frequency[before]) <= 0.0:
                what = "increasing" if direction == "up" else "decreasing"
                now, then = float(frequency[row]), float(frequency[before])
                reason = (
                    f"frequencies not {what} within one sweep ({direction}, sigma {level:g}, "
                    f"harmonic {k}): {now!r} Hz after {then!r} Hz on "
                    f"{table.place(before)} (a sweep's rows go in the order it visited them)"
                )
                raise table.error(row, column, reason)
        for row in rows:
            out[row] = direction
    return out


def _harmonics(
    table: _Table, columns: dict[str, str], options: Any
) -> tuple[np.ndarray, np.ndarray]:
    """Peak amplitudes of N/F_s and phase lags phi_k [degree, in [0, 360)] of every row."""
    n = len(table.rows)
    if "x" in columns:
        x = np.array([_float(table, i, columns["x"]) for i in range(n)])
        y = np.array([_float(table, i, columns["y"]) for i in range(n)])
        magnitude, theta = np.hypot(x, y), np.degrees(np.arctan2(y, x))
        zero_column = columns["x"]
    else:
        magnitude = np.array([_float(table, i, columns["r"]) for i in range(n)])
        theta = np.array([_float(table, i, columns["phase"]) for i in range(n)])
        if options.phase_unit == "rad":
            theta = np.degrees(theta)
        zero_column = columns["r"]
    for i in range(n):
        if not magnitude[i] > 0.0:  # negative R, or a zero reading, which has no phase
            reason = f"expected a reading R > 0 (a phase needs one), got R = {magnitude[i]!r}"
            raise table.error(i, zero_column, reason)
    amplitude = magnitude * RMS_TO_PEAK if options.rms else magnitude.copy()
    if options.sensitivity is not None:
        amplitude = amplitude / float(options.sensitivity) / float(options.static_load)
    lag = -theta if options.phase_convention == "lock-in" else theta
    phase = np.mod(lag, 360.0)
    phase[phase >= 360.0] = 0.0  # a lag of -1e-17 is 360 - 1e-17, which rounds to 360
    return amplitude, phase


# --------------------------------------------------------------------------- writing
@dataclass(frozen=True)
class WriteReport:
    """What a writer wrote: the points (one reading of one harmonic) and those it left out.

    Attributes
    ----------
    path : str
        The file written.
    written : int
        Points written.
    total : int
        Points of the dataset (every direction, sigma, frequency and harmonic).
    left_out : int
        Points not settled (``settled`` or ``periodic`` 0) or not measured (NaN).
    fractional : int
        Points of an order that is not a whole number (``harmonic`` 1/2, 3/2, ...), which
        the tables cannot hold.
    """

    path: str
    written: int
    total: int
    left_out: int = 0
    fractional: int = 0

    def line(self) -> str:
        """One line for the user: what was left out, or that nothing was."""
        if self.written == self.total:
            return f"wrote all {self.total} points"
        text = f"left out {self.total - self.written} of {self.total} points ({LEFT_OUT_REASON})"
        if self.fractional:
            text = (
                f"left out {self.total - self.written} of {self.total} points "
                f"({self.left_out} {LEFT_OUT_REASON}, {self.fractional} of a fractional order)"
            )
        return text


@dataclass(frozen=True)
class _Points:
    """The readings a dataset holds, in the order the sweeps visited them."""

    direction: list[str]
    sigma: np.ndarray
    frequency: np.ndarray
    harmonic: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    reference: list[str] | None
    frequency_name: str
    total: int
    left_out: int
    fractional: int


def _dataset_kind(ds: Any, what: str) -> str:
    kind = ds.attrs.get("hertzsweep_kind")
    if kind not in DATASET_KINDS or "amplitude" not in ds or "phase" not in ds:
        raise HertzsweepError(
            f"{what}: expected a sweep, measured or fit dataset with amplitude and phase, "
            f"got a {kind or 'non-hertzsweep'} dataset"
        )
    return kind


def _points(ds: Any, what: str, need_phase: bool) -> _Points:
    """Every reading of a dataset that settled and was measured (module notes)."""
    kind = _dataset_kind(ds, what)
    axis = next(d for d in ds["amplitude"].dims if d not in ("direction", "sigma", "harmonic"))
    in_hertz = axis == "frequency" or (kind == "sweep" and "frequency" in ds.coords)
    frequency = np.asarray(ds["frequency"] if in_hertz else ds[axis], dtype=float)
    order = ("direction", "sigma", axis, "harmonic")
    a, p = _values(ds, "amplitude", order), _values(ds, "phase", order)
    harmonics = np.asarray(ds["harmonic"].values if "harmonic" in ds.coords else [1])
    ok = np.isfinite(a) & (a > 0.0)
    if need_phase:
        ok &= np.isfinite(p)
    for flag in ("settled", "periodic"):
        if flag in ds:
            ok &= ds[flag].transpose(*order[:3]).values.astype(bool)[..., None]
    whole = np.array([float(k).is_integer() and k >= 1 for k in harmonics])
    index = []
    for d, direction in enumerate(ds["direction"].values):
        step = 1 if direction == "up" else -1  # the order the sweep visited its frequencies
        for s in range(ds["sigma"].size):
            for f in range(frequency.size)[::step]:
                index.extend((d, s, f, k) for k in np.flatnonzero(whole & ok[d, s, f]))
    d, s, f, k = np.array(index, dtype=int).reshape(-1, 4).T
    references = _references(ds)
    return _Points(
        direction=[str(x) for x in ds["direction"].values[d]],
        sigma=np.asarray(ds["sigma"].values, dtype=float)[s],
        frequency=frequency[f],
        harmonic=harmonics[k].astype(np.int64),
        amplitude=a[d, s, f, k],
        phase=p[d, s, f, k],
        reference=list(references[d, s]) if references is not None else None,
        frequency_name="frequency" if in_hertz else "frequency_ratio",
        total=a.size,
        left_out=int(np.count_nonzero(~ok[..., whole])),
        fractional=int(np.count_nonzero(~whole)) * a[..., 0].size,
    )


def _values(ds: Any, name: str, order: tuple[str, ...]) -> np.ndarray:
    """A variable on ``order`` (a fit's, without harmonics, on harmonic 1)."""
    values = ds[name]
    if "harmonic" not in values.dims:
        values = values.expand_dims(harmonic=1, axis=-1)
    return np.asarray(values.transpose(*order).values, dtype=float)


def _references(ds: Any) -> np.ndarray | None:
    """A measured dataset's ``reference`` texts per (direction, sigma), if any is given."""
    if "reference" not in ds:
        return None
    texts = ds["reference"].transpose("direction", "sigma").values
    return texts if any(str(t) for t in texts.ravel()) else None


def _number(value: float) -> str:
    """Full precision: the shortest text that reads back as the same float."""
    return repr(float(value))


def _write_rows(path: str | os.PathLike, comment: str, header, rows: Iterator) -> None:
    """A CSV file, complete or absent: a comment line, the header and the rows."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as handle:
        handle.write(f"# {comment}\n")
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)


def write_measurement_csv(ds: Any, path: str | os.PathLike) -> WriteReport:
    """Write a ``sweep``, ``measured`` or ``fit`` dataset as hertzsweep's own measurement
    CSV (module notes), which :func:`~hertzsweep.io.measured.read_measurements` reads
    back with the same values.

    Columns ``direction,sigma,frequency,amplitude,phase,harmonic`` (``frequency`` in Hz; a
    dataset measured in frequency ratios writes ``frequency_ratio``), and ``reference``
    when a measured dataset has one; a phase not measured is an empty cell. A fit
    dataset's rows are its data (``amplitude`` and ``phase``), not its model.

    Parameters
    ----------
    ds : xarray.Dataset
        Of kind ``sweep``, ``measured`` (sweeps) or ``fit`` (of sweeps).
    path : path
        The CSV file to write (complete or absent).

    Returns
    -------
    WriteReport
        The points written and those left out.

    Raises
    ------
    HertzsweepError
        Another kind of dataset (jump frequencies among them).
    OSError
        The file cannot be written.
    """
    points = _points(ds, str(path), need_phase=False)
    header = ["direction", "sigma", points.frequency_name, "amplitude", "phase", "harmonic"]
    if points.reference is not None:
        header.append("reference")

    def rows() -> Iterator[list[str]]:
        for i, direction in enumerate(points.direction):
            phase = points.phase[i]
            row = [
                direction,
                _number(points.sigma[i]),
                _number(points.frequency[i]),
                _number(points.amplitude[i]),
                _number(phase) if math.isfinite(phase) else "",
                str(int(points.harmonic[i])),
            ]
            if points.reference is not None:
                row.append(str(points.reference[i]))
            yield row

    comment = (
        f"hertzsweep {__version__}: {ds.attrs.get('hertzsweep_kind')} dataset; amplitude: "
        "peak A_k of N/F_s; phase: lag phi_k [degree] of A_k sin(k w tau - phi_k)"
    )
    _write_rows(path, comment, header, rows())
    return _report(path, points)


def _report(path: str | os.PathLike, points: _Points) -> WriteReport:
    return WriteReport(
        path=str(path),
        written=len(points.direction),
        total=points.total,
        left_out=points.left_out,
        fractional=points.fractional,
    )


def write_lockin_csv(
    ds: Any,
    path: str | os.PathLike,
    sensitivity: float,
    static_load: float | None = None,
    rms: bool = True,
) -> WriteReport:
    """Write a ``sweep``, ``measured`` or ``fit`` dataset as a lock-in's table in volts
    (module notes), which :func:`read_lockin_table` reads back to round-off.

    Columns ``direction,sigma,harmonic,frequency,x,y``: ``x + i y = R e^{i theta}`` with
    ``theta = -phi_k`` (the lock-in's lead) and ``R = A_k F_s sensitivity / sqrt(2)`` (RMS;
    the peak with ``rms=False``), frequency in Hz. Read it back with
    ``ImportOptions(columns={q: q for q in LOCKIN_HEADER}, sensitivity=..., static_load=...)``.

    Parameters
    ----------
    ds : xarray.Dataset
        Of kind ``sweep``, ``measured`` or ``fit``, with frequencies in Hz.
    path : path
        The CSV file to write (complete or absent).
    sensitivity : float
        [V/N] of the force transducer the table pretends to read.
    static_load : float, optional
        [N] F_s; default: the dataset's ``static_load`` attribute.
    rms : bool
        Write RMS values, as a lock-in reads them (False: peak values).

    Returns
    -------
    WriteReport
        The points written and those left out (a phase not measured leaves its point out).

    Raises
    ------
    HertzsweepError
        Another kind of dataset; frequencies as ratios only; no static load; a sensitivity
        or static load that is not a positive number.
    OSError
        The file cannot be written.
    """
    what = str(path)
    if static_load is None:
        static_load = ds.attrs.get("static_load")
        if static_load is None:
            raise HertzsweepError(f"{what}: the dataset has no static_load: give static_load [N]")
    for name, value in (("sensitivity", sensitivity), ("static_load", static_load)):
        if isinstance(value, bool) or not (
            isinstance(value, int | float | np.floating) and math.isfinite(value) and value > 0
        ):
            raise HertzsweepError(f"{what}: {name} must be a positive number, got {value!r}")
    points = _points(ds, what, need_phase=True)
    if points.frequency_name != "frequency":
        raise HertzsweepError(
            f"{what}: the dataset holds frequency ratios only; a lock-in's table is in Hz"
        )
    scale = float(static_load) * float(sensitivity) / (RMS_TO_PEAK if rms else 1.0)
    magnitude = points.amplitude * scale
    theta = np.radians(-points.phase)
    x, y = magnitude * np.cos(theta), magnitude * np.sin(theta)

    def rows() -> Iterator[list[str]]:
        for i, direction in enumerate(points.direction):
            yield [
                direction,
                _number(points.sigma[i]),
                str(int(points.harmonic[i])),
                _number(points.frequency[i]),
                _number(x[i]),
                _number(y[i]),
            ]

    comment = (
        f"hertzsweep {__version__}: {ds.attrs.get('hertzsweep_kind')} dataset as a lock-in "
        f"reads it: x, y [V {'RMS' if rms else 'peak'}] of the force transducer "
        f"({_number(sensitivity)} V/N, F_s = {_number(static_load)} N); phase: the lead"
    )
    _write_rows(path, comment, LOCKIN_HEADER, rows())
    return _report(path, points)


__all__ = [
    "LOCKIN_HEADER",
    "WriteReport",
    "read_lockin_table",
    "write_lockin_csv",
    "write_measurement_csv",
]
