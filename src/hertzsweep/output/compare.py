"""A run against a reference dataset: the tolerance model and the report.

Pure functions over xarray Datasets (no files are opened here): :func:`compare` checks
that both are of one ``hertzsweep_kind``, that their dimensions and coordinates agree,
then every data variable within its tolerance, and lists the configuration differences.
The :class:`Report` it returns renders as text (:meth:`Report.text`) or JSON
(:meth:`Report.as_dict`). How each variable is compared is ONE table,
:data:`TOLERANCES`; ``--rtol``, ``--atol`` and ``--var`` of ``hertzsweep compare``
override it.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from ..core.config import RigConfig, Scene
from ..errors import HertzsweepError
from .frame import load_xarray

xr = load_xarray()  # xarray with its dask probe kept quiet

# Modes of comparison (``allowed = atol + rtol |reference|`` at each point):
RELATIVE = "relative"  # |run - reference| <= allowed
PHASE = "phase"  # the same, the difference first wrapped into [-180, 180) degrees
GRID = "grid"  # |run - reference| <= steps x the frequency grid step (in Hz: x f0)
EXACT = "exact"  # equal
SKIP = "skip"  # not compared
# Everywhere: NaN in both at a point is equal there, NaN in one only is a failing point.
GRID_SLACK = 1.0 + 1e-9  # grid values are decimals: 0.9925 - 0.99 is 0.0025 within 1e-9


@dataclass(frozen=True)
class Tolerance:
    """One entry of :data:`TOLERANCES`.

    Attributes
    ----------
    mode : one of ``relative``, ``phase``, ``grid``, ``exact``, ``skip``.
    rtol, atol : relative and absolute parts of the allowed difference (``atol`` in the
        variable's units).
    steps : for ``grid``: the allowed difference in grid steps.
    """

    mode: str
    rtol: float = 0.0
    atol: float = 0.0
    steps: float = 0.0


# The tolerance model. Keys: a variable name (looked up first), then the kind of values
# (<flag>: integers with flag_values, <integer>, <string>), then the units ([degree],
# [1], ...); <other> for any other numeric variable, <coordinate> for coordinates.
TOLERANCES: dict[str, Tolerance] = {
    # A jump is read at a dwell of the stepped sine: jumping one dwell earlier or later is
    # the resolution of the measurement itself (one step; in Hz the step times f0).
    "jump_frequency_ratio": Tolerance(GRID, steps=1.0),
    "jump_frequency": Tolerance(GRID, steps=1.0),
    "subharmonic_onset_frequency_ratio": Tolerance(GRID, steps=1.0),  # jumps too
    "subharmonic_end_frequency_ratio": Tolerance(GRID, steps=1.0),
    # Folds located by continuation are finer than the grid, but a fold that moves by less
    # than a sweep step changes no sweep: the same resolution.
    "bifurcation_frequency_ratio": Tolerance(GRID, steps=1.0),
    "bifurcation_frequency": Tolerance(GRID, steps=1.0),
    # Wall-clock time measures the machine and its load, not the result; so does the
    # Pareto front of wall time and error an accuracy run draws from it.
    "wall_time": Tolerance(SKIP),
    "pareto": Tolerance(SKIP),
    # Flags (settled, periodic, stable, case_failed, ...): a flipped flag is a changed
    # result; there is no "nearly settled".
    "<flag>": Tolerance(EXACT),
    # Counts and indices (cost_steps, flight_count, bifurcation_point): discrete, so a
    # difference of one is a different run.
    "<integer>": Tolerance(EXACT),
    # Labels (bifurcation_kind, branch_end, case_id): equal or not.
    "<string>": Tolerance(EXACT),
    # Phases: absolute, in degrees, the difference taken modulo 360 (359.9 and 0.1 are 0.2
    # apart). 0.5 degree is orders of magnitude above rounding and below what a change of
    # the model does near resonance, where the phase turns by 180 degrees.
    "[degree]": Tolerance(PHASE, atol=0.5),
    # Amplitudes, forces, fractions (units of F_s, or 1): rounding differences (operations
    # reordered, FMA contraction, another LLVM) stay below 1e-10 (1e-13 over a dwell,
    # tests/test_golden.py; 1e-11 at most after a rewrite of the kernels), while a change
    # of the model, the scheme or a constant by 1e-6 moves them by more than 1e-6. The atol
    # floor is for values that are zero in exact arithmetic (no loss of contact, H2 of a
    # linear response), where rounding leaves about 1e-16.
    "[1]": Tolerance(RELATIVE, rtol=1e-6, atol=1e-10),
    # Flight times (ms): relative, as [1]; the floor, 1 ps, is far below a time step
    # (about 17 us at 256 steps per period).
    "[s]": Tolerance(RELATIVE, rtol=1e-6, atol=1e-12),
    # Frequencies in Hz (w f0): relative, as [1].
    "[Hz]": Tolerance(RELATIVE, rtol=1e-6, atol=1e-9),
    # Any other numeric variable (units not listed here): relative, as [1], no floor.
    "<other>": Tolerance(RELATIVE, rtol=1e-6),
    # Coordinates (the grids): built from the same few config numbers and rounded to 12
    # digits, so 1e-9 absorbs decimal round-off and still catches any real change of grid.
    "<coordinate>": Tolerance(RELATIVE, rtol=1e-9),
}

# Global attributes of study datasets that describe the configuration (beyond the scene's).
STUDY_CONFIG_ATTRIBUTES = ("study_kind", "study_grid", "study_split_sigma")
# Keys of ``config_json`` that say where a run came from, not how it was configured.
PROVENANCE_KEYS = frozenset({"source", "scene_file", "history", "output"})


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class Rule:
    """The tolerance one variable is compared with, resolved for the datasets at hand.

    Attributes
    ----------
    mode : as :class:`Tolerance` (``grid`` is resolved to an ``atol``).
    rtol, atol : the numbers used; ``atol`` in the variable's units.
    units : the variable's units attribute ("" if none).
    origin : where the rule came from: a key of :data:`TOLERANCES`, ``--rtol/--atol`` or
        ``--var``.
    note : what ``atol`` stands for, e.g. ``"one grid step"``.
    """

    mode: str
    rtol: float = 0.0
    atol: float = 0.0
    units: str = ""
    origin: str = ""
    note: str = ""

    def describe(self) -> str:
        """The rule in words, for the text report."""
        if self.mode == EXACT:
            return "must be equal"
        if self.mode == SKIP:
            return "not compared"
        parts = []
        if self.rtol:
            parts.append(f"rtol {_number(self.rtol)}")
        if self.atol or not self.rtol:
            parts.append(f"atol {_number(self.atol)}{_unit(self.units)}")
        if self.note:
            parts.append(self.note)
        if self.mode == PHASE:
            parts.append("difference wrapped to [-180, 180)")
        return ", ".join(parts)

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        out: dict[str, Any] = {
            "mode": self.mode,
            "rtol": self.rtol,
            "atol": self.atol,
            "units": self.units,
            "rule": self.origin,
        }
        return _with_note(out, self.note)


@dataclass(frozen=True)
class WorstPoint:
    """The point of a variable furthest outside (or nearest to) its tolerance.

    Attributes
    ----------
    coords : ``{dim: coordinate value}`` (the position along a dimension without an index
        coordinate, plus the coordinates that label that dimension).
    run, reference : the two values there.
    difference : ``run - reference`` (phases wrapped); None for strings or a NaN in one.
    allowed : the allowed absolute difference there.
    """

    coords: dict[str, Any]
    run: Any
    reference: Any
    difference: float | None
    allowed: float


@dataclass(frozen=True)
class VariableResult:
    """The comparison of one data variable.

    Attributes
    ----------
    name : the variable.
    passed : True within tolerance everywhere, False if not, None when not compared.
    failing, total : points outside tolerance, and points compared.
    rule : the tolerance used.
    worst : the worst point (None when the two are identical or not compared).
    note : why it was not compared, or what else went wrong.
    """

    name: str
    passed: bool | None
    failing: int
    total: int
    rule: Rule
    worst: WorstPoint | None = None
    note: str = ""

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form: ``passed``, ``failing``, ``total``, ``tolerance``,
        ``worst`` (``coords``, ``run``, ``reference``, ``difference``, ``tolerance``)."""
        out: dict[str, Any] = {
            "passed": self.passed,
            "failing": self.failing,
            "total": self.total,
            "tolerance": self.rule.as_dict(),
        }
        if self.worst is None:
            out["worst"] = None
        else:
            worst = {"coords": {k: _json_value(v) for k, v in self.worst.coords.items()}}
            worst |= {k: _json_value(v) for k, v in asdict(self.worst).items() if k != "coords"}
            worst["tolerance"] = {**self.rule.as_dict(), "allowed": worst.pop("allowed")}
            out["worst"] = worst
        return _with_note(out, self.note)


@dataclass(frozen=True)
class CoordinateMismatch:
    """A dimension or coordinate that differs.

    Attributes
    ----------
    name : the dimension or coordinate.
    message : what differs, e.g. ``"61 values vs 31 in the reference"``.
    dims : the dimensions whose values can no longer be compared point by point (empty
        when the coordinate only labels a dimension that has an index coordinate, like
        ``frequency`` in Hz on ``frequency_ratio``).
    """

    name: str
    message: str
    dims: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {"name": self.name, "message": self.message, "blocks": list(self.dims)}


@dataclass(frozen=True)
class ConfigDifference:
    """One configuration value that differs (``None``: absent from that file)."""

    key: str
    run: Any
    reference: Any

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {
            "key": self.key,
            "run": _json_value(self.run),
            "reference": _json_value(self.reference),
        }


@dataclass
class Report:
    """Everything :func:`compare` found.

    Attributes
    ----------
    kind : the datasets' ``hertzsweep_kind``.
    names : labels of the run and the reference (their file names).
    coordinate_mismatches : dimensions and coordinates that differ.
    variables : ``{name: VariableResult}`` in the reference's order.
    missing : data variables of the reference absent from the run (each a failure).
    new : data variables only in the run (listed, not compared, not a failure).
    config_differences : configuration values that differ (they explain, never fail).
    config_source : ``"config_json"`` or ``"attributes"``: what they were read from.
    """

    kind: str
    names: tuple[str, str] = ("run", "reference")
    coordinate_mismatches: list[CoordinateMismatch] = field(default_factory=list)
    variables: dict[str, VariableResult] = field(default_factory=dict)
    missing: list[str] = field(default_factory=list)
    new: list[str] = field(default_factory=list)
    config_differences: list[ConfigDifference] = field(default_factory=list)
    config_source: str = "attributes"

    @property
    def failing(self) -> list[VariableResult]:
        """The variables compared and found outside tolerance."""
        return [v for v in self.variables.values() if v.passed is False]

    @property
    def equal(self) -> bool:
        """True when the run matches the reference within tolerance."""
        return not (self.coordinate_mismatches or self.missing or self.failing)

    def summary(self) -> str:
        """The one summary line."""
        compared = [v for v in self.variables.values() if v.passed is not None]
        where = f"({self.kind}; {self.names[0]} against {self.names[1]})"
        skipped = len(self.variables) - len(compared)
        not_compared = f", {skipped} not compared" if skipped else ""
        if self.equal:
            return f"equal: {len(compared)} variables within tolerance{not_compared} {where}"
        parts = [f"{len(self.failing)} of {len(compared)} variables outside tolerance"]
        if skipped:
            parts.append(f"{skipped} not compared")
        if self.coordinate_mismatches:
            parts.append(
                _count(
                    len(self.coordinate_mismatches), "coordinate mismatch", "coordinate mismatches"
                )
            )
        if self.missing:
            parts.append(_count(len(self.missing), "variable", "variables") + " missing")
        return f"differ: {', '.join(parts)} {where}"

    def text(self) -> str:
        """The text report: coordinate mismatches, one line per failing variable, the
        variables not compared, the configuration differences, a summary line."""
        lines = [f"coordinate mismatch: {m.name}: {m.message}" for m in self.coordinate_mismatches]
        for result in self.failing:
            lines.append(_failure_line(result))
        blocked = [v.name for v in self.variables.values() if v.passed is None and v.note]
        if blocked:
            notes = {self.variables[n].note for n in blocked}
            lines.append(f"not compared ({'; '.join(sorted(notes))}): {', '.join(blocked)}")
        if self.missing:
            lines.append(f"missing in {self.names[0]}: {', '.join(self.missing)}")
        if self.new:
            lines.append(f"only in {self.names[0]} (not compared): {', '.join(self.new)}")
        for d in self.config_differences:
            lines.append(
                f"config: {d.key}: run {_display(d.run)}, reference {_display(d.reference)}"
            )
        lines.append(self.summary())
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        """The report as a JSON-friendly dict (NaN and absent values are null,
        infinities the strings ``"inf"``/``"-inf"``)."""
        return {
            "equal": self.equal,
            "kind": self.kind,
            "run": self.names[0],
            "reference": self.names[1],
            "coordinate_mismatches": [m.as_dict() for m in self.coordinate_mismatches],
            "variables": {name: v.as_dict() for name, v in self.variables.items()},
            "missing_variables": list(self.missing),
            "new_variables": list(self.new),
            "config_differences": [d.as_dict() for d in self.config_differences],
            "config_source": self.config_source,
            "summary": self.summary(),
        }

    def to_json(self) -> str:
        """:meth:`as_dict` as indented JSON."""
        return json.dumps(self.as_dict(), indent=2)


# --------------------------------------------------------------------------- compare
def compare(
    run: xr.Dataset,
    reference: xr.Dataset,
    rtol: float | None = None,
    atol: float | None = None,
    variables: Mapping[str, tuple[float, float | None]] | None = None,
    names: tuple[str, str] = ("run", "reference"),
) -> Report:
    """Compare a run with a reference dataset of the same kind.

    Parameters
    ----------
    run, reference : datasets written by hertzsweep (any ``hertzsweep_kind``).
    rtol, atol : replace the defaults of every variable compared relatively (units
        ``1``, ``s``, ``Hz``, ...); phases, jump frequencies, flags and strings keep
        theirs (use ``variables`` for those).
    variables : ``{name: (rtol, atol or None)}``: per variable, ``|run - reference| <=
        atol + rtol |reference|`` (phases: the wrapped difference); ``atol`` None keeps
        the variable's default (one grid step for jump frequencies).
    names : labels of the two datasets in messages (their file names).

    Returns
    -------
    Report
        ``report.equal`` says whether the run is within tolerance.

    Raises
    ------
    HertzsweepError
        A dataset without ``hertzsweep_kind``, datasets of different kinds, an unknown
        variable in ``variables``, or a negative or NaN tolerance.
    """
    kind = _common_kind(run, reference, names)
    overrides = dict(variables or {})
    for option, value in (("--rtol", rtol), ("--atol", atol)):
        if value is not None:
            _check_tolerance(option, value)
    known = list(reference.data_vars) + [n for n in run.data_vars if n not in reference]
    for name, (var_rtol, var_atol) in overrides.items():
        if name not in run.data_vars and name not in reference.data_vars:
            raise HertzsweepError(
                f"--var {name}: no such variable in {names[0]} or {names[1]} "
                f"(variables: {', '.join(str(n) for n in known)})"
            )
        _check_tolerance(f"--var {name}", var_rtol)
        if var_atol is not None:
            _check_tolerance(f"--var {name}", var_atol)
        var = reference[name] if name in reference.data_vars else run[name]
        if var.dtype.kind in "OUS":
            raise HertzsweepError(f"--var {name}: a string variable is compared exactly")

    report = Report(kind=kind, names=names)
    report.coordinate_mismatches = check_coordinates(run, reference)
    blocked = {d for m in report.coordinate_mismatches for d in m.dims}
    for name in reference.data_vars:
        if name not in run.data_vars:
            report.missing.append(str(name))
            continue
        rule = resolve_rule(
            reference[name], str(name), reference, rtol, atol, overrides.get(str(name))
        )
        report.variables[str(name)] = compare_variable(
            run[name], reference[name], rule, reference, blocked
        )
    report.new = [str(n) for n in run.data_vars if n not in reference.data_vars]
    report.config_source, report.config_differences = config_differences(run, reference)
    return report


def _common_kind(run: xr.Dataset, reference: xr.Dataset, names: tuple[str, str]) -> str:
    """The datasets' common ``hertzsweep_kind`` (with ``study_kind`` for studies)."""
    kinds = []
    for ds, label in zip((run, reference), names, strict=True):
        kind = ds.attrs.get("hertzsweep_kind")
        if not isinstance(kind, str) or not kind:
            raise HertzsweepError(
                f"{label}: not a hertzsweep dataset (no hertzsweep_kind attribute)"
            )
        kinds.append(kind)
    if kinds[0] != kinds[1]:
        raise HertzsweepError(
            f"{names[0]}: a {kinds[0]} dataset, but {names[1]} is a {kinds[1]} dataset "
            "(compare datasets of one kind)"
        )
    study = [ds.attrs.get("study_kind") for ds in (run, reference)]
    if study[0] != study[1]:
        raise HertzsweepError(
            f"{names[0]}: a study of kind {study[0]}, but {names[1]} is a study of kind "
            f"{study[1]} (compare datasets of one kind)"
        )
    return kinds[0]


def _check_tolerance(option: str, value: float) -> None:
    if not value >= 0.0:  # also refuses NaN
        raise HertzsweepError(f"{option}: expected a tolerance >= 0, got {value!r}")


def parse_variable_tolerance(text: str) -> tuple[str, tuple[float, float | None]]:
    """Parse ``--var NAME=RTOL[,ATOL]``.

    Parameters
    ----------
    text : e.g. ``"amplitude=1e-4"`` or ``"phase=0,1"``.

    Returns
    -------
    tuple
        ``(name, (rtol, atol or None))``.

    Raises
    ------
    HertzsweepError
        Not of that form, or a tolerance that is not a number >= 0.
    """
    name, sep, rest = text.partition("=")
    numbers = rest.split(",")
    usage = f"--var {text!r}: expected NAME=RTOL[,ATOL], e.g. amplitude=1e-4 or phase=0,1"
    if not sep or not name.strip() or not rest.strip() or len(numbers) > 2:
        raise HertzsweepError(usage)
    values: list[float] = []
    for number in numbers:
        try:
            value = float(number)
        except ValueError:
            raise HertzsweepError(usage) from None
        _check_tolerance(f"--var {name.strip()}", value)
        values.append(value)
    return name.strip(), (values[0], values[1] if len(values) == 2 else None)


# --------------------------------------------------------------------------- tolerances
def default_key(var: xr.DataArray, name: str) -> str:
    """The key of :data:`TOLERANCES` that applies to a data variable."""
    if name in TOLERANCES:
        return name
    kind = var.dtype.kind
    if kind in "OUS":
        return "<string>"
    if "flag_values" in var.attrs or kind == "b":
        return "<flag>"
    if kind in "iu":
        return "<integer>"
    units = f"[{var.attrs.get('units', '')}]"
    return units if units in TOLERANCES else "<other>"


def grid_step(ds: xr.Dataset) -> float | None:
    """The frequency-ratio grid step: the ``sweep_step`` attribute, else the smallest
    spacing of the ``frequency_ratio`` coordinate; None when neither is there."""
    step = ds.attrs.get("sweep_step")
    if isinstance(step, int | float | np.number) and math.isfinite(step) and step > 0:
        return float(step)
    if "frequency_ratio" in ds.coords and ds["frequency_ratio"].ndim == 1:
        spacing = np.abs(np.diff(np.asarray(ds["frequency_ratio"].values, dtype=float)))
        spacing = spacing[np.isfinite(spacing) & (spacing > 0)]
        if spacing.size:
            return float(spacing.min())
    return None


def resolve_rule(
    var: xr.DataArray,
    name: str,
    reference: xr.Dataset,
    rtol: float | None = None,
    atol: float | None = None,
    override: tuple[float, float | None] | None = None,
) -> Rule:
    """The :class:`Rule` a variable is compared with: its :data:`TOLERANCES` entry, the
    grid step for ``grid`` entries, then ``--rtol/--atol`` (relative entries only) and
    ``--var`` (``override``)."""
    key = default_key(var, name)
    entry = TOLERANCES[key]
    units = str(var.attrs.get("units", ""))
    rule = Rule(entry.mode, entry.rtol, entry.atol, units, key)
    if entry.mode == GRID:
        step = grid_step(reference)
        scale = 1.0
        if step is not None and units == "Hz":
            f0 = reference.attrs.get("natural_frequency")
            if isinstance(f0, int | float | np.number) and math.isfinite(f0):
                scale = float(f0)
            else:
                step = None
        if step is None:  # no grid to measure by: compare relatively, as <other>
            other = TOLERANCES["<other>"]
            rule = Rule(RELATIVE, other.rtol, other.atol, units, key, "grid step unknown")
        else:
            what = "one grid step" if entry.steps == 1 else f"{_number(entry.steps)} grid steps"
            rule = Rule(GRID, 0.0, entry.steps * step * scale, units, key, what)
    elif entry.mode == RELATIVE and (rtol is not None or atol is not None):
        rule = Rule(
            RELATIVE,
            entry.rtol if rtol is None else rtol,
            entry.atol if atol is None else atol,
            units,
            "--rtol/--atol",
        )
    if override is not None:
        var_rtol, var_atol = override
        mode = PHASE if rule.mode == PHASE else RELATIVE
        rule = Rule(
            mode,
            var_rtol,
            rule.atol if var_atol is None else var_atol,
            units,
            "--var",
            rule.note if var_atol is None else "",
        )
    return rule


# --------------------------------------------------------------------------- coordinates
def check_coordinates(run: xr.Dataset, reference: xr.Dataset) -> list[CoordinateMismatch]:
    """Dimensions and coordinates that differ between the run and the reference.

    A dimension in one only, of another length, or whose index coordinate (or, for a
    dimension without one, a coordinate along it: ``setting_label``, ``tau``) differs
    beyond the ``<coordinate>`` tolerance blocks the comparison of every variable along
    it. Any other coordinate that differs (``frequency`` in Hz on ``frequency_ratio``) is
    reported without blocking.
    """
    out: list[CoordinateMismatch] = []
    run_sizes, ref_sizes = dict(run.sizes), dict(reference.sizes)
    bad: set[str] = set()
    for dim in list(ref_sizes) + [d for d in run_sizes if d not in ref_sizes]:
        if dim not in run_sizes:
            out.append(CoordinateMismatch(str(dim), "dimension only in the reference", (dim,)))
        elif dim not in ref_sizes:
            out.append(CoordinateMismatch(str(dim), "dimension only in the run", (dim,)))
        elif run_sizes[dim] != ref_sizes[dim]:
            message = f"{run_sizes[dim]} values vs {ref_sizes[dim]} in the reference"
            out.append(CoordinateMismatch(str(dim), message, (dim,)))
        else:
            continue
        bad.add(str(dim))
    names = list(reference.coords) + [c for c in run.coords if c not in reference.coords]
    names.sort(key=lambda c: c not in reference.indexes and c not in run.indexes)  # index first
    for name in names:
        in_run, in_ref = name in run.coords, name in reference.coords
        var = reference[name] if in_ref else run[name]
        if set(var.dims) & bad:
            continue  # the dimension is already reported
        blocks = _blocked_dims(reference if in_ref else run, str(name))
        if not (in_run and in_ref):
            where = "run" if in_run else "reference"
            out.append(CoordinateMismatch(str(name), f"coordinate only in the {where}", blocks))
            continue
        a, b = run[name], reference[name]
        if set(a.dims) != set(b.dims):
            message = f"on dims ({', '.join(map(str, a.dims))}) vs ({', '.join(map(str, b.dims))})"
            out.append(CoordinateMismatch(str(name), message, tuple(map(str, b.dims))))
            continue
        message = _coordinate_difference(a.transpose(*b.dims).values, b.values, b)
        if message:
            out.append(CoordinateMismatch(str(name), message, blocks))
            bad.update(blocks)  # its other coordinates are not reported again
    return out


def _blocked_dims(ds: xr.Dataset, name: str) -> tuple[str, ...]:
    """The dims a differing coordinate leaves uncomparable: its own dim if it is the index
    coordinate, or the dim it lies along when that dim has no index coordinate."""
    var = ds[name]
    if name in ds.indexes:
        return (name,)
    if var.ndim == 1 and var.dims[0] not in ds.indexes:
        return (str(var.dims[0]),)
    return ()


def _coordinate_difference(a: np.ndarray, b: np.ndarray, ref: xr.DataArray) -> str:
    """What differs between two coordinate arrays; empty when they are equal within the
    ``<coordinate>`` tolerance (strings and integers: exactly)."""
    if a.dtype.kind in "OUS" or b.dtype.kind in "OUS":
        same = np.asarray(a).astype(str) == np.asarray(b).astype(str)
    else:
        entry = TOLERANCES["<coordinate>"]
        mode = EXACT if b.dtype.kind in "iub" else RELATIVE
        rule = Rule(mode, entry.rtol, entry.atol)
        same = _numeric_check(a, b, rule)[0]
    if bool(np.all(same)):
        return ""
    flat = int(np.flatnonzero(~np.asarray(same).ravel())[0])
    index = np.unravel_index(flat, b.shape)
    at = ", ".join(f"{d}[{i}]" for d, i in zip(ref.dims, index, strict=True))
    first = f"first at {at}: " if at else ""
    count = f" ({int(np.size(same) - np.count_nonzero(same))} of {np.size(same)} values differ)"
    return f"{first}run {_display(a[index])}, reference {_display(b[index])}" + (
        count if np.size(same) > 1 else ""
    )


# --------------------------------------------------------------------------- variables
def compare_variable(
    run: xr.DataArray,
    reference: xr.DataArray,
    rule: Rule,
    reference_ds: xr.Dataset,
    blocked: set[str] | frozenset[str] = frozenset(),
) -> VariableResult:
    """Compare one data variable point by point.

    Parameters
    ----------
    run, reference : the variable in each dataset.
    rule : the tolerance (:func:`resolve_rule`).
    reference_ds : the reference dataset, for the coordinates of the worst point.
    blocked : dimensions with a coordinate mismatch: a variable along one is not compared.
    """
    name = str(reference.name)
    if set(run.dims) != set(reference.dims):
        note = (
            f"dimensions ({', '.join(map(str, run.dims))}) vs "
            f"({', '.join(map(str, reference.dims))}) in the reference"
        )
        return VariableResult(name, False, 0, 0, rule, note=note)
    along = [str(d) for d in reference.dims if d in blocked]
    if along:
        return VariableResult(name, None, 0, 0, rule, note="coordinate mismatch")
    if rule.mode == SKIP:
        return VariableResult(
            name, None, 0, 0, rule, note="skipped by default; --var NAME=RTOL compares it"
        )
    a = run.transpose(*reference.dims).values
    b = reference.values
    text_a, text_b = a.dtype.kind in "OUS", b.dtype.kind in "OUS"
    if text_a != text_b:
        note = f"strings in one dataset, numbers in the other ({a.dtype} vs {b.dtype})"
        return VariableResult(name, False, int(b.size), int(b.size), rule, note=note)
    if text_a:
        a_text, b_text = np.asarray(a).astype(str), np.asarray(b).astype(str)
        ok = a_text == b_text
        score = (~ok).astype(float)
        difference = allowed = None
    else:
        ok, score, difference, allowed = _numeric_check(a, b, rule)
    failing = int(ok.size - np.count_nonzero(ok))
    worst = None
    if score.size and float(np.max(score)) > 0.0:
        flat = int(np.argmax(score.ravel()))  # the first of the largest
        index = np.unravel_index(flat, b.shape)
        worst = WorstPoint(
            coords=point_coords(reference_ds, reference, index),
            run=_python(a[index]),
            reference=_python(b[index]),
            difference=None if difference is None else _finite_or_none(difference[index]),
            allowed=0.0 if allowed is None else float(allowed[index]),
        )
    return VariableResult(name, failing == 0, failing, int(b.size), rule, worst)


def _numeric_check(
    a: np.ndarray, b: np.ndarray, rule: Rule
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(ok, score, difference, allowed)`` of two numeric arrays under a rule.

    ``score`` orders the points for the worst one: |difference| / allowed (infinite for
    any difference where nothing is allowed, or a NaN in one only), ties broken towards
    the larger |difference|; 0 where the values are equal.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    both_nan = np.isnan(a) & np.isnan(b)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        same = (a == b) | both_nan
        difference = a - b
        if rule.mode == PHASE:
            difference = np.mod(difference + 180.0, 360.0) - 180.0
        size = np.abs(difference)
        if rule.mode == EXACT:
            allowed = np.zeros_like(b)
        else:
            # an infinite reference (error_jump: a jump missed) is matched only by itself
            allowed = np.where(np.isinf(b), 0.0, rule.atol + rule.rtol * np.abs(b))
        # a jump one grid step away differs by the step up to decimal round-off
        slack = GRID_SLACK if rule.mode == GRID else 1.0
        ok = same | (size <= allowed * slack)
        ratio = np.where(allowed > 0, size / allowed, np.where(size > 0, np.inf, 0.0))
    ratio = np.where(np.isnan(ratio) | np.isnan(size), np.inf, ratio)
    ratio[same] = 0.0
    # rank by ratio, then by |difference|: one score in (0, inf], equal ratios kept apart
    size_rank = np.where(np.isnan(size), np.inf, size)
    size_rank[same] = 0.0
    score = _lexicographic_score(ratio, size_rank)
    return ok, score, difference, allowed


def _lexicographic_score(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """A score ordering points by ``primary``, then ``secondary`` (both >= 0); 0 where
    both are 0."""
    if primary.size == 0:
        return primary.astype(float)
    order = np.lexsort((secondary.ravel(), primary.ravel()))
    rank = np.empty(order.size, dtype=float)
    rank[order] = np.arange(1, order.size + 1, dtype=float)
    rank[(primary.ravel() == 0) & (secondary.ravel() == 0)] = 0.0
    return rank.reshape(primary.shape)


def point_coords(ds: xr.Dataset, var: xr.DataArray, index: tuple[int, ...]) -> dict[str, Any]:
    """``{dim: value}`` of a point of ``var``: the index coordinate's value, or the position
    along a dimension without one, followed by the 1-d coordinates along that dimension
    (``setting_label``, ``tau``, ``time``)."""
    out: dict[str, Any] = {}
    for dim, i in zip(var.dims, index, strict=True):
        if dim in ds.indexes:
            out[str(dim)] = _python(ds[dim].values[i])
            continue
        out[str(dim)] = int(i)
        for name, coord in ds.coords.items():
            if coord.dims == (dim,):
                out[str(name)] = _python(coord.values[i])
    return out


# --------------------------------------------------------------------------- configuration
def config_differences(
    run: xr.Dataset, reference: xr.Dataset
) -> tuple[str, list[ConfigDifference]]:
    """The configuration values that differ, and where they were read from.

    From ``config_json`` (the whole resolved configuration, flattened to dotted keys) when
    both datasets carry it, else from the flat config attributes (``damping_ratio``,
    ``steps_per_period``, ...).
    """
    texts = [ds.attrs.get("config_json") for ds in (run, reference)]
    if all(isinstance(t, str) and t for t in texts):
        try:
            configs = [json.loads(t) for t in texts]  # type: ignore[arg-type]
        except ValueError:
            configs = []
        if len(configs) == 2 and all(isinstance(c, dict) for c in configs):
            flat = [_flatten(c) for c in configs]
            keys = list(flat[1]) + [k for k in flat[0] if k not in flat[1]]
            keys = [k for k in keys if k.rsplit(".", 1)[-1] not in PROVENANCE_KEYS]
            return "config_json", _differences(keys, flat[0], flat[1])
    names = config_attribute_names()
    keys = [k for k in reference.attrs if k in names]
    keys += [k for k in run.attrs if k in names and k not in reference.attrs]
    return "attributes", _differences(keys, run.attrs, reference.attrs)


@functools.cache
def config_attribute_names() -> frozenset[str]:
    """The names of the flat config attributes every dataset carries (those of
    :meth:`Scene.attributes`), plus the study's."""
    rig = RigConfig(ball_radius=1.0, youngs_modulus=1.0, poisson_ratio=0.0, mass=1.0)
    sine = Scene(rig=rig)
    random = replace(sine, excitation=replace(sine.excitation, kind="random"))
    names = set(sine.attributes()) | set(random.attributes())  # a random scene's own too
    return frozenset(names) | frozenset(STUDY_CONFIG_ATTRIBUTES)


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for key, item in value.items():
            out.update(_flatten(item, f"{prefix}.{key}" if prefix else str(key)))
        return out
    return {prefix: value}


def _differences(
    keys: list[str], run: Mapping[str, Any], reference: Mapping[str, Any]
) -> list[ConfigDifference]:
    out = []
    for key in keys:
        a, b = run.get(key), reference.get(key)
        if not _same_value(a, b):
            out.append(ConfigDifference(key, _python(a), _python(b)))
    return out


def _same_value(a: Any, b: Any) -> bool:
    if a is None or b is None:
        return a is None and b is None
    x, y = np.asarray(a), np.asarray(b)
    if x.shape != y.shape:
        return False
    if x.dtype.kind in "iufb" and y.dtype.kind in "iufb":
        return bool(np.array_equal(x.astype(float), y.astype(float), equal_nan=True))
    return bool(np.all(x.astype(str) == y.astype(str)))


# --------------------------------------------------------------------------- formatting
def _failure_line(result: VariableResult) -> str:
    """``NAME: F of T points outside tolerance; worst at d=v, ...: run X, reference Y
    (difference D; allowed A: rule)``."""
    head = f"{result.name}: {result.failing} of {result.total} points outside tolerance"
    if result.worst is None:
        return f"{head}; {result.note}" if result.note else head
    w = result.worst
    at = ", ".join(f"{k}={_display(v)}" for k, v in w.coords.items())
    unit = _unit(result.rule.units)
    where = f"; worst at {at}" if at else ""
    text = f"{head}{where}: run {_display(w.run)}{unit}, reference {_display(w.reference)}{unit}"
    if result.rule.mode == EXACT:
        return f"{text} (must be equal)"
    diff = "NaN in one only" if w.difference is None else f"difference {_number(w.difference)}"
    return f"{text} ({diff}; allowed {_number(w.allowed)}{unit}: {result.rule.describe()})"


def _count(n: int, one: str, many: str) -> str:
    return f"{n} {one if n == 1 else many}"


def _unit(units: str) -> str:
    return "" if units in ("", "1") else f" {units}"


def _number(value: float) -> str:
    return f"{value:.10g}"


def _display(value: Any) -> str:
    """A value for the text report: numbers to 10 digits, strings quoted, None absent."""
    if value is None:
        return "(absent)"
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return _display(value.item())
        return "[" + ", ".join(_display(v) for v in value.tolist()) + "]"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_display(v) for v in value) + "]"
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return _number(value)
    if isinstance(value, bytes):
        value = value.decode(errors="replace")
    if isinstance(value, str):
        return value if value and value.strip() == value and " " not in value else repr(value)
    return str(value)


def _python(value: Any) -> Any:
    """numpy scalars and arrays as Python values."""
    if isinstance(value, np.ndarray):
        return value.item() if value.ndim == 0 else value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, bytes):
        return value.decode(errors="replace")
    return value


def _finite_or_none(value: Any) -> float | None:
    value = float(value)
    return None if math.isnan(value) else value


def _with_note(out: dict[str, Any], note: str) -> dict[str, Any]:
    """A JSON form with ``note`` added last, when there is one."""
    return {**out, "note": note} if note else out


def _json_value(value: Any) -> Any:
    """NaN -> None, +-inf -> "inf"/"-inf", numpy -> Python (recursively for lists)."""
    value = _python(value)
    if isinstance(value, list):
        return [_json_value(v) for v in value]
    if isinstance(value, float):
        if math.isnan(value):
            return None
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
    return value
