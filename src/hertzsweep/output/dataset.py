"""Datasets: results -> self-describing datasets with CF-1.11 attributes.

The one table of output attributes is ``attributes.toml`` beside this module
(:func:`attributes`); every builder takes names from it, so a variable means the same
thing in every dataset. Builders take a driver's result and the scene and run nothing.
Files are written only by the output layer and the command line, through
:func:`write_atomic` and :func:`~hertzsweep.output.paths.atomic_path`: complete or
absent (:mod:`.paths`: the checks, the lock and the temporary names).

Every dataset is a record of how it was made (:func:`global_attributes`): the code
(``hertzsweep_version``, ``git_commit``, the versions of Python, numpy and numba), the
command line with absolute paths and the working directory (``history``), the whole
resolved configuration as JSON (``config_json``, a scene file's tables) and the command's
own arguments (``command_json``): ``hertzsweep rerun`` runs it again from these.
The global attributes come in one order, in memory and in the file
(:func:`ordered_attributes`): the ACDD and CF ones first (``title``, ``summary``, ...),
then the rig's, the scene's, the solver's, the provenance and a kind's own.

Files are netCDF4 written by the netCDF4 library itself (:func:`write_netcdf`): CF-1.11
clean as the compliance checker reads it (no ``_FillValue`` on coordinates, strings as
character arrays: CF labels), and without xarray's writer, which imports dask to look
for a scheduler. The builders of the sweep, trace, branch and accuracy datasets make a
:class:`~hertzsweep.output.frame.Frame` (numpy arrays), so a command that writes one
never imports xarray or pandas; ``frame.to_xarray()`` is the dataset reading the file
gives (:func:`open_dataset`).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import functools
import json
import os
import shlex
import subprocess
import sys
import tomllib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import fields
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import __version__
from ..core.config import RigConfig, Scene
from ..core.kinds import KINDS
from ..core.rig import RigConstants, derive
from ..drivers.readings import HARMONIC_FIELDS, SCALAR_FIELDS
from .frame import Frame, Variable, load_xarray
from .paths import atomic_path, sync_path, write_file

if TYPE_CHECKING:  # the results' types only: building a dataset runs no driver
    import xarray as xr

    from ..drivers.accuracy import AccuracyReport
    from ..drivers.continuation import BranchResult
    from ..drivers.random import RandomResult
    from ..drivers.sweep import SweepResult
    from ..drivers.trace import TraceResult

CONVENTIONS = "CF-1.11"
REFERENCES = (  # the paper whose rig, model and figures hertzsweep reproduces
    "E. Rigaud and J. Perret-Liaudet, Experiments and numerical results on nonlinear "
    "vibrations of an impacting Hertzian contact. Part 1: harmonic excitation, Journal of "
    "Sound and Vibration 265 (2003) 289-307"
)
SUMMARIES = {name: kind.about for name, kind in KINDS.items()}
"""kind -> the ACDD ``summary`` of its datasets (:attr:`hertzsweep.core.kinds.Kind.about`)."""
RIG_ATTRIBUTES = (  # the rig's attributes: its table (Scene.attributes), its derived constants
    "rig_geometry",
    *(field.name for field in fields(RigConfig) if field.name != "geometry"),
    *(field.name for field in fields(RigConstants)),
)
ATTRIBUTE_ORDER = (  # the order of the global attributes (ordered_attributes); NAME or PREFIX*
    # ACDD 1.3 and CF: what the dataset is and where it comes from, read first
    "title",
    "summary",
    "Conventions",
    "source",
    "history",
    "references",
    "hertzsweep_kind",
    "hertzsweep_version",
    *RIG_ATTRIBUTES,
    # the scene's other tables, as Scene.attributes names them
    "damping_*",
    "excitation_*",
    "sweep_*",
    "lockin_*",
    "model_*",
    "branch_follow_period_doubling",
    # the solver
    "solver_*",
    "steps_per_period",
    # provenance: the code and the whole configuration and command (rerun)
    "git_commit",
    "git_modified",
    "python_version",
    "numpy_version",
    "numba_version",
    "config_json",
    "command_json",
    "scene_file",
)  # then every other attribute (a kind's own), in the order it was added
INDEX = np.int32  # integer type of indices and counts (a point, a multiplier, ...)
ORDER = np.float64  # type of the ``harmonic`` coordinate: orders k, whole or not (1/2, 4/3)
STEP_COUNT = np.int64  # integer type of integration-step counts: a study passes 2**31
GIT_SECONDS = 5.0  # at most this long for each git query of the provenance

ATTRIBUTES_FILE = Path(__file__).with_name("attributes.toml")  # name -> CF attributes


@functools.cache
def attributes() -> dict[str, dict[str, Any]]:
    """name -> CF attributes of every variable and coordinate the datasets hold, read once
    from :data:`ATTRIBUTES_FILE`: ``long_name``, ``units`` (none on a string label) and
    any other attribute the variable always has."""
    return tomllib.loads(ATTRIBUTES_FILE.read_text(encoding="utf-8"))


def attrs(name: str) -> dict[str, Any]:
    """CF attributes of a named variable from :func:`attributes` (a copy to add to)."""
    return dict(attributes()[name])


def ordered_attributes(attributes: Mapping[str, Any]) -> dict[str, Any]:
    """Global attributes in the order of :data:`ATTRIBUTE_ORDER`.

    Parameters
    ----------
    attributes : mapping
        A dataset's global attributes.

    Returns
    -------
    dict
        The same attributes, those :data:`ATTRIBUTE_ORDER` names in its order (those of
        one prefix in their own), then the others in their own order.
    """
    return dict(sorted(attributes.items(), key=lambda item: _attribute_rank(item[0])))


@functools.cache
def _attribute_rank(name: str) -> int:
    """The place of an attribute in :data:`ATTRIBUTE_ORDER`: its first entry that is the
    name or a prefix (``sweep_*``) of it; past the end for the others."""
    for rank, entry in enumerate(ATTRIBUTE_ORDER):
        if name == entry or (entry.endswith("*") and name.startswith(entry[:-1])):
            return rank
    return len(ATTRIBUTE_ORDER)


# --------------------------------------------------------------------------- provenance
PATH_OPTIONS = ("-o", "--output", "--overlay")  # options whose value is a file to write or read


def absolute_arguments(argv: Sequence[str]) -> list[str]:
    """A command line with its files as absolute paths: the values of
    :data:`PATH_OPTIONS` and the arguments that name an existing file or folder (the
    program's name and every other argument unchanged)."""
    out = list(argv[:1])
    after_path_option = False
    for arg in argv[1:]:
        name, equals, value = arg.partition("=")
        if after_path_option or (not arg.startswith("-") and os.path.exists(arg)):
            arg = os.path.abspath(arg)
        elif equals and name in PATH_OPTIONS:
            arg = f"{name}={os.path.abspath(value)}"
        after_path_option = arg in PATH_OPTIONS
        out.append(arg)
    return out


def history_line(argv: Sequence[str] | None = None) -> str:
    """``history`` (CF section 2.6.2): UTC time, the command line with absolute paths,
    the working directory and the version, e.g. ``2026-01-01T12:00:00Z: hertzsweep sweep
    /home/me/scene.toml -o /home/me/out.nc (in /home/me; hertzsweep 0.2.0)``."""
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    argv = list(argv) if argv is not None else ["hertzsweep", *sys.argv[1:]]
    command = shlex.join(absolute_arguments(argv))
    return f"{now}: {command} (in {os.getcwd()}; hertzsweep {__version__})"


def _git(root: Path, *args: str) -> str | None:
    """The output of ``git -C ROOT ARGS`` (stripped), or None when git fails or is
    missing."""
    try:
        done = subprocess.run(
            ["git", "-C", str(root), *args],
            capture_output=True,
            text=True,
            timeout=GIT_SECONDS,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def source_checkout() -> Path | None:
    """The git checkout this package runs from (``ROOT/src/hertzsweep``), or None for an
    installed copy (whose folder may lie inside some other checkout)."""
    package = Path(__file__).resolve().parents[1]
    root = package.parents[1]
    if package != root / "src" / "hertzsweep" or not (root / ".git").exists():
        return None
    return root


@functools.cache
def provenance() -> dict[str, Any]:
    """What identifies the code that makes a dataset: ``hertzsweep_version``,
    ``git_commit`` and ``git_modified`` (1: the package's files differ from that commit)
    when it runs from a git checkout, and the versions of Python, numpy and numba.
    Read once per process."""
    out: dict[str, Any] = {"hertzsweep_version": __version__}
    root = source_checkout()
    commit = _git(root, "rev-parse", "HEAD") if root is not None else None
    if commit:
        status = _git(root, "status", "--porcelain", "--", "src", "pyproject.toml")
        out["git_commit"] = commit
        out["git_modified"] = int(status is None or bool(status))
    out["python_version"] = sys.version.split()[0]
    out["numpy_version"] = np.__version__
    out["numba_version"] = _numba_version()
    return out


def _numba_version() -> str:
    """numba's version, without importing it when no kernel has run yet."""
    numba = sys.modules.get("numba")
    if numba is not None:
        return str(numba.__version__)
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("numba")
    except PackageNotFoundError:
        return "not installed"


def to_json(value: Any) -> str:
    """Compact JSON of a configuration or a command (numpy values as plain numbers)."""
    return json.dumps(value, default=_json_default, separators=(",", ":"))


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {value!r}")


def global_attributes(
    scene: Scene,
    title: str,
    kind: str,
    history: str | None = None,
    command: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The global attributes every dataset carries: conventions, the paper, what the
    dataset holds (``summary``, :data:`SUMMARIES`), the code (:func:`provenance`), how it
    was made (``history``; ``config_json``, the scene's tables with the rig inline,
    :meth:`~hertzsweep.core.config.Scene.to_dict`; ``command_json``, the command and the
    arguments it ran with, by default ``{"command": kind}``), every resolved config value
    as a flat attribute and the rig's derived constants; in the order of
    :func:`ordered_attributes`."""
    constants = derive(scene.rig)
    out: dict[str, Any] = {
        "Conventions": CONVENTIONS,
        "title": title,
        **({"summary": SUMMARIES[kind]} if kind in SUMMARIES else {}),
        "history": history or history_line(),
        "source": f"hertzsweep {__version__}",
        "references": REFERENCES,
        "hertzsweep_kind": kind,
        **provenance(),
        "config_json": to_json(scene.to_dict()),
        "command_json": to_json(dict(command) if command is not None else {"command": kind}),
        "scene_file": _absolute(scene.source),
    }
    for key, value in scene.attributes().items():
        out[key] = _netcdf_value(value)
    for key, value in constants.as_dict().items():
        out[key] = float(value)
    return ordered_attributes(out)


def _absolute(source: str) -> str:
    """A scene's source as an absolute path when it names a file (a study case's label, a
    rerun's ``IN.nc:config_json``, unchanged)."""
    return os.path.abspath(source) if os.path.isfile(source) else source


def _netcdf_value(value: Any) -> Any:
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, list | tuple):
        return np.asarray(value)
    return value


Variables = dict[str, tuple[tuple[str, ...], Any]]  # name -> (dims, values)
YES_NO = np.array([0, 1], dtype=np.int8)  # flag_values of a yes/no variable (int8 in netCDF)


def _readings(get: Callable[[str], Any], dims: tuple[str, ...], omega: float) -> Variables:
    """The reading fields of a result (:mod:`hertzsweep.drivers.readings`) as variables on
    ``dims`` (and ``harmonic`` for the per-harmonic ones); ``flight_tau`` becomes
    ``flight_time`` [s] = tau / Omega (eq. 6)."""
    data: Variables = {name: ((*dims, "harmonic"), get(name)) for name in HARMONIC_FIELDS}
    for name in SCALAR_FIELDS:
        if name == "flight_tau":
            data["flight_time"] = (dims, get(name) / omega)
        else:
            data[name] = (dims, get(name))
    return data


def _ball_readings(extra: Mapping[str, Any], dims: tuple[str, ...], omega: float) -> Variables:
    """The ball model's own readings (:data:`~hertzsweep.drivers.readings.BALL_FIELDS`;
    none for the single model), ``ball_flight_tau`` as ``ball_flight_time`` [s]."""
    return {
        (name.removesuffix("_tau") + "_time" if name.endswith("_tau") else name): (
            dims,
            values / omega if name.endswith("_tau") else values,
        )
        for name, values in extra.items()
    }


def _build(data: Variables, coords: Mapping[str, Any], global_attrs: dict[str, Any]) -> Frame:
    """A dataset whose variables take their CF attributes from :func:`attributes`."""
    variables = {name: (dims, values, attrs(name)) for name, (dims, values) in data.items()}
    return Frame(variables, coords, global_attrs)


def _flags(ds: Frame, names: Sequence[str], values: np.ndarray, meanings: str) -> None:
    """CF flag attributes (``flag_values``, ``flag_meanings``) of integer variables."""
    for name in names:
        ds[name].attrs.update(flag_values=values, flag_meanings=meanings)


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
        "harmonic": ("harmonic", np.asarray(result.harmonics, dtype=ORDER), attrs("harmonic")),
    }


def _period_variables(result: SweepResult | TraceResult, dims: tuple[str, ...]) -> Variables:
    """``response_period`` on ``dims`` (int8: 0 none, n periods) where the result has it,
    and a sweep's subharmonic jumps on (direction, sigma)."""
    data: Variables = {}
    if getattr(result, "response_period", None) is not None:
        data["response_period"] = (dims, np.asarray(result.response_period, dtype=np.int8))
    for name in ("subharmonic_onset_frequency_ratio", "subharmonic_end_frequency_ratio"):
        if getattr(result, name, None) is not None:
            data[name] = (("direction", "sigma"), getattr(result, name))
    return data


def sweep_dataset(result: SweepResult, scene: Scene, history: str | None = None) -> Frame:
    """The SPEC's sweep dataset."""
    constants = derive(scene.rig)
    base = ("direction", "sigma", "frequency_ratio")
    data = _readings(partial(getattr, result), base, constants.natural_circular_frequency)
    jump = result.jump_frequency_ratio
    data.update(
        settled=(base, result.settled.astype(np.int8)),
        periodic=(base, result.periodic.astype(np.int8)),
        jump_frequency_ratio=(("direction", "sigma"), jump),
        jump_frequency=(("direction", "sigma"), jump * constants.natural_frequency),
    )
    data.update(_period_variables(result, base))
    if result.ball_mode_error is not None:
        data["ball_mode_error"] = (base, result.ball_mode_error)
    data.update(_ball_readings(result.extra, base, constants.natural_circular_frequency))
    title = "Stepped-sine sweep of a preloaded Hertzian contact"
    ds = _build(data, _coords(result, constants), global_attributes(scene, title, "sweep", history))
    _flags(ds, ("settled", "periodic"), YES_NO, "no yes")
    merge_attributes(ds, {"integration_steps": int(result.steps)})
    return ds


# --------------------------------------------------------------------------- trace
def trace_dataset(result: TraceResult, scene: Scene, history: str | None = None) -> Frame:
    """The trace dataset of a :class:`hertzsweep.drivers.trace.TraceResult`.

    Dimensions ``sigma``, ``sample`` (coordinates ``tau`` and ``time`` [s]),
    ``harmonic``, ``harmonic_order`` (with ``spectrum_frequency`` [Hz]) and ``flight``;
    the record's float columns are views, not copies. A record streamed to its file
    (:class:`RecordStream`) is there already: its variables and ``tau``, ``time`` are
    placeholders of the right shape (no memory) whose values the writer leaves alone.
    Flight variables are NaN padded (``flight_complete`` with -1). Times in seconds are
    ``tau / Omega`` (eq. 6).
    """
    constants = derive(scene.rig)
    omega = constants.natural_circular_frequency
    f0 = constants.natural_frequency
    w = float(result.frequency_ratio)
    trace = ("sigma", "sample")
    flight = ("sigma", "flight")
    variables = record_variables(result.record_columns)
    if result.record is None:  # streamed (RecordStream): in the file already
        shape = (result.sigma.size, result.samples)
        tau = np.broadcast_to(np.nan, shape[1:])
        columns = [np.broadcast_to(dtype(0), shape) for _, dtype in variables]
    else:
        tau = result.tau
        columns = [
            result.record[:, :, c].astype(dtype, copy=False)
            for c, (_, dtype) in enumerate(variables)
        ]
    data: Variables = {
        name: (trace, column) for (name, _), column in zip(variables, columns, strict=True)
    }
    data["spectrum"] = (("sigma", "harmonic_order"), result.spectrum)
    data.update(_readings(partial(getattr, result), ("sigma",), omega))
    flights = result.flights
    data.update(
        flight_count=("sigma", flights.count.astype(INDEX)),
        flight_start=(flight, flights.start),
        flight_end=(flight, flights.end),
        flight_start_time=(flight, flights.start / omega),
        flight_duration=(flight, (flights.end - flights.start) / omega),
        flight_complete=(flight, flights.complete),
        settled=("sigma", result.settled.astype(np.int8)),
        periodic=("sigma", result.periodic.astype(np.int8)),
        frequency_ratio=((), w),
        frequency=((), w * f0),
    )
    data.update(_period_variables(result, ("sigma",)))
    if result.ball_mode_error is not None:
        data["ball_mode_error"] = ("sigma", result.ball_mode_error)
    data.update(_ball_readings(result.extra, ("sigma",), omega))
    order = result.harmonic_order
    coords = {
        "sigma": ("sigma", result.sigma, attrs("sigma")),
        "tau": ("sample", tau, attrs("tau")),
        "time": ("sample", tau if result.record is None else tau / omega, attrs("time")),
        "harmonic": ("harmonic", np.asarray(result.harmonics, dtype=ORDER), attrs("harmonic")),
        "harmonic_order": ("harmonic_order", order, attrs("harmonic_order")),
        "spectrum_frequency": ("harmonic_order", order * w * f0, attrs("spectrum_frequency")),
    }
    title = "Time history and spectrum of a preloaded Hertzian contact at one frequency"
    command = trace_command(result, scene)
    ds = _build(data, coords, global_attributes(scene, title, "trace", history, command))
    _flags(ds, ("settled", "periodic"), YES_NO, "no yes")
    _flags(
        ds,
        ("in_contact",) + (("upper_in_contact",) if result.extra else ()),
        YES_NO,
        "flight contact",
    )
    complete = np.array([-1, 0, 1], dtype=np.int8)
    _flags(ds, ("flight_complete",), complete, "no_flight cut_by_record complete")
    approach = np.asarray(result.approach)
    extra = dict(
        frequency_ratio=w,
        frequency=w * f0,
        branch=result.branch,
        periods=int(result.periods),
        samples_per_period=int(result.samples_per_period),
        record_stride=int(result.stride),
        approach_from=float(approach[0]) if approach.size else w,
        approach_dwells=int(approach.size),
        spectrum_backend=result.spectrum_backend,
        integration_steps=int(result.steps),
    )
    merge_attributes(ds, extra)
    return ds


# --------------------------------------------------------------------------- branch
def _padded(rows: Sequence[Any], width: int, fill: Any = np.nan, dtype: Any = float) -> np.ndarray:
    """Rows of different lengths as one array ``(len(rows), width, ...)``, padded with
    ``fill`` after each row's end."""
    arrays = [np.asarray(row, dtype=dtype) for row in rows]
    trailing = max(arrays, key=np.ndim).shape[1:]  # e.g. the harmonics of an amplitude
    out = np.full((len(arrays), width, *trailing), fill, dtype=dtype)
    for i, row in enumerate(arrays):
        out[i, : row.shape[0]] = row
    return out


def _branch_coords(result: BranchResult, counts: dict[str, int]) -> dict[str, tuple]:
    """The branch dataset's coordinates: ``sigma``, ``harmonic``, and an index of each of
    ``counts`` (``point``, ``multiplier``, ``bifurcation``, and ``branch`` when the sigmas
    have several)."""
    coords = {
        "sigma": ("sigma", result.sigma, attrs("sigma")),
        "harmonic": ("harmonic", np.asarray(result.harmonics, dtype=ORDER), attrs("harmonic")),
    }
    for name, count in counts.items():
        coords[name] = (name, np.arange(count, dtype=INDEX), attrs(name))
    return coords


def branch_dataset(result: BranchResult, scene: Scene, history: str | None = None) -> Frame:
    """The branch dataset of a :class:`~hertzsweep.drivers.continuation.BranchResult`.

    Dimensions ``sigma``, ``point`` (points in arclength order, NaN padded; ``stable``
    padded with -1), ``harmonic``, ``multiplier`` (largest modulus first: 2 for the single
    model, 4 for the ball model) and
    ``bifurcation`` (located bifurcations in arclength order, padded with NaN, ``""``
    and -1; at least one slot).

    Following period doublings (``result.follows_period_doubling``), every variable on
    ``sigma`` gains a ``branch`` dimension after it (the sigma's branches: the primary
    first, then the period-doubled ones in the order they were started; padded as the
    points are, ``period_multiple`` 0 on a padding branch), with ``period_multiple``,
    ``parent`` and ``parent_bifurcation`` on ``(sigma, branch)`` (-1 on primaries) and
    ``bifurcation_period_multiple``. Without it the layout is that of a single branch per
    sigma, as before period-doubled branches existed.
    """
    constants = derive(scene.rig)
    f0 = constants.natural_frequency
    follow = result.follows_period_doubling
    families = [result.family(s) for s in range(len(result.branches))]
    n_branches = max(len(family) for family in families)
    # one row per (sigma, branch), None where a sigma has fewer branches
    branches = list(result.branches)
    if follow:
        branches = [
            family[b] if b < len(family) else None for family in families for b in range(n_branches)
        ]
    present = [branch for branch in branches if branch is not None]
    n_points = max(branch.size for branch in present)
    n_found = max(1, max(len(branch.bifurcations) for branch in present))
    lead = ("sigma", "branch") if follow else ("sigma",)
    shape = (len(families), n_branches) if follow else (len(families),)

    def shaped(values: np.ndarray) -> np.ndarray:
        return values.reshape(shape + values.shape[1:])

    def per_point(name: str, fill: Any = np.nan, dtype: Any = float) -> np.ndarray:
        rows = [getattr(b, name) if b is not None else _blank(present[0], name) for b in branches]
        return shaped(_padded(rows, n_points, fill, dtype))

    def per_bifurcation(name: str, fill: Any = np.nan, dtype: Any = float) -> np.ndarray:
        rows = [[getattr(f, name) for f in (b.bifurcations if b else [])] for b in branches]
        return shaped(_padded(rows, n_found, fill, dtype))

    def per_branch(get: Callable[[Any], Any], fill: Any, dtype: Any) -> np.ndarray:
        return shaped(np.array([get(b) if b is not None else fill for b in branches], dtype=dtype))

    at_point = (*lead, "point")
    at_found = (*lead, "bifurcation")
    w = per_point("frequency_ratio")
    multipliers = per_point("multipliers", np.nan + 0j, complex)
    found_w = per_bifurcation("frequency_ratio")
    data = _readings(per_point, at_point, constants.natural_circular_frequency)
    data.update(
        frequency_ratio=(at_point, w),
        frequency=(at_point, w * f0),
        multiplier_real=((*at_point, "multiplier"), multipliers.real),
        multiplier_imag=((*at_point, "multiplier"), multipliers.imag),
        stable=(at_point, per_point("stable", -1, np.int8)),
        arclength=(at_point, per_point("arclength")),
        branch_complete=(lead, per_branch(lambda b: b.complete, 0, np.int8)),
        branch_end=(lead, per_branch(lambda b: b.end, "", object)),
        branch_bridges=(lead, per_branch(lambda b: b.bridges, 0, INDEX)),
        bifurcation_frequency_ratio=(at_found, found_w),
        bifurcation_frequency=(at_found, found_w * f0),
        bifurcation_kind=(at_found, per_bifurcation("kind", "", object)),
        bifurcation_amplitude=(at_found, per_bifurcation("amplitude")),
        bifurcation_point=(at_found, per_bifurcation("point", -1, INDEX)),
    )
    if follow:
        data.update(
            period_multiple=(lead, per_branch(lambda b: b.period_multiple, 0, INDEX)),
            parent=(lead, per_branch(lambda b: b.parent, -1, INDEX)),
            parent_bifurcation=(lead, per_branch(lambda b: b.parent_bifurcation, -1, INDEX)),
            parent_frequency_ratio=(
                lead,
                per_branch(_parent_w(families, n_branches), np.nan, float),
            ),
        )
    counts = {"point": n_points, "multiplier": multipliers.shape[-1], "bifurcation": n_found}
    coords = _branch_coords(result, {**counts, **({"branch": n_branches} if follow else {})})
    title = (
        "Periodic orbits of a preloaded Hertzian contact by shooting and pseudo-arclength "
        "continuation"
    )
    ds = _build(data, coords, global_attributes(scene, title, "branch", history))
    stable = np.array([-1, 0, 1], dtype=np.int8)
    _flags(ds, ("stable",), stable, "no_point unstable stable")
    _flags(ds, ("branch_complete",), YES_NO, "no yes")
    extra = {
        "integration_steps": int(result.steps),
        "branch_start_frequency_ratio": float(result.start_frequency_ratio),
        "branch_end_frequency_ratio": float(result.end_frequency_ratio),
    }
    merge_attributes(ds, extra)
    return ds


def _blank(like: Any, name: str) -> np.ndarray:
    """A padding branch's (no points) array of a per-point field, shaped as ``like``'s."""
    values = np.asarray(getattr(like, name))
    return np.empty((0, *values.shape[1:]), dtype=values.dtype)


def _parent_w(families: Sequence[Sequence[Any]], n_branches: int) -> Callable[[Any], float]:
    """The frequency ratio of the period doubling a branch was started from (NaN for a
    primary), looked up in its own sigma's family."""
    owner = {id(b): family for family in families for b in family}

    def w(branch: Any) -> float:
        if branch.parent < 0:
            return float("nan")
        parent = owner[id(branch)][branch.parent]
        return float(parent.bifurcations[branch.parent_bifurcation].frequency_ratio)

    return w


# --------------------------------------------------------------------------- accuracy
def accuracy_dataset(report: AccuracyReport, scene: Scene, history: str | None = None) -> Frame:
    """The accuracy dataset of a :class:`hertzsweep.drivers.accuracy.AccuracyReport`.

    Dimension ``setting`` (the rungs that ran, reference last) with coordinates
    ``setting_label``, ``steps_per_period``, ``settle`` ("300", "auto:1e-4"),
    ``steady_state`` and ``method``; the errors against the reference, the cost, the
    Pareto flag and the observed order ``order_h1`` per rung. Attributes: ``observed_order``,
    ``reference_label``, the reference's Richardson error estimates
    ``reference_error_h1`` (``_h2``, ``_force``), ``settle_check_h1``, ``scene_setting``,
    ``target``, ``target_margin`` (the reference's error counted against it),
    ``recommended`` (label of the fastest setting meeting the target; empty when none
    does or no target was given) and ``recommended_command`` (the ``--set`` options of
    ``hertzsweep sweep`` that reproduce it), ``notes``.
    """
    rungs = report.rungs
    settings = [r.setting for r in rungs]
    setting_values = {
        "setting_label": np.array([s.label for s in settings], dtype=object),
        "steps_per_period": np.array([s.steps_per_period for s in settings], dtype=INDEX),
        "settle": np.array([s.settle for s in settings], dtype=object),
        "steady_state": np.array([s.steady_state for s in settings], dtype=object),
        "method": np.array([s.method for s in settings], dtype=object),
    }
    coords = {name: ("setting", values, attrs(name)) for name, values in setting_values.items()}
    errors = report.errors
    values = {
        "error_h1": np.array([e.h1 for e in errors]),
        "error_h2": np.array([e.h2 for e in errors]),
        "error_force": np.array([e.force for e in errors]),
        "error_jump": np.array([e.jump for e in errors]),
        "cost_steps": np.array([r.cost_steps for r in rungs], dtype=STEP_COUNT),
        "wall_time": np.array([r.wall_time for r in rungs]),
        "pareto": np.asarray(report.pareto, dtype=np.int8),
        "order_h1": np.asarray(report.orders, dtype=float),
        "settled_fraction": np.array([float(np.mean(r.result.settled)) for r in rungs]),
    }
    data: Variables = {name: (("setting",), v) for name, v in values.items()}
    title = "Error against cost of the solver settings"
    command = accuracy_command(report)
    ds = _build(data, coords, global_attributes(scene, title, "accuracy", history, command))
    _flags(ds, ("pareto",), YES_NO, "no yes")
    recommended = report.recommended
    extra: dict[str, Any] = {
        "observed_order": float(report.observed_order),
        "reference_label": rungs[-1].setting.label,
        "scene_setting": report.scene_setting.label,
        "recommended": "" if recommended is None else rungs[recommended].setting.label,
        "recommended_command": ""
        if recommended is None
        else rungs[recommended].setting.set_options,
        "target": float("nan") if report.target is None else float(report.target),
        "target_margin": float(report.target_margin),
        "error_metric": "error_h1: max abs H1 error over the sweep / the reference's max H1",
        "notes": "; ".join(report.notes),
    }
    reference = report.reference_error
    if reference is not None:
        extra["reference_error_h1"] = reference.h1
        extra["reference_error_h2"] = reference.h2
        extra["reference_error_force"] = reference.force
    if report.settle_check is not None:
        extra["settle_check_h1"] = report.settle_check.h1
        extra["settle_check_label"] = report.settle_check_label
    return merge_attributes(ds, extra)


# --------------------------------------------------------------------------- random
def random_dataset(result: RandomResult, scene: Scene, history: str | None = None) -> Frame:
    """The random dataset of a :class:`~hertzsweep.drivers.random.RandomResult`.

    Dimensions ``rms``, ``frequency_ratio`` (the Welch bins inside (0, Nyquist), with
    ``frequency`` [Hz]) and ``force_bin`` (the centres of the histogram's bins of N/F_s).
    Every statistic is the mean over the realisations, ``NAME_stderr`` its standard error
    (NaN for one realisation); the ball model's adds ``ball_flight_fraction``. With
    ``random.trace_periods`` > 0, the time history of realisation 0 of every level over
    its first measured periods: ``trace_force`` (N/F_s) and ``trace_forcing`` (f) on
    ``(rms, trace_sample)``, with the coordinates ``trace_tau`` and ``trace_time`` [s] from
    the first measured step. Attributes: ``integration_steps``, ``realisations``,
    ``welch_segments`` (whole segments in each realisation's spectra), ``measured_periods``
    and ``complete`` (0: an interrupted run's statistics so far).
    """
    constants = derive(scene.rig)
    f0 = constants.natural_frequency
    w = result.frequency_ratio
    data: Variables = {}
    for name, values in result.mean.items():  # per level, per bin, or the histogram's
        on = ("rms",) if values.ndim == 1 else ("rms", "frequency_ratio")
        on = ("rms", "force_bin") if name == "force_pdf" else on
        data[name] = (on, values)
        data[f"{name}_stderr"] = (on, result.stderr[name])
    coords = {
        "rms": ("rms", result.rms, attrs("rms")),
        "frequency_ratio": ("frequency_ratio", w, attrs("frequency_ratio")),
        "frequency": ("frequency_ratio", w * f0, attrs("frequency")),
        "force_bin": ("force_bin", result.force_bin, attrs("force_bin")),
    }
    if result.trace_tau.size:
        tau = result.trace_tau
        data["trace_force"] = (("rms", "trace_sample"), result.trace_force)
        data["trace_forcing"] = (("rms", "trace_sample"), result.trace_forcing)
        coords["trace_tau"] = ("trace_sample", tau, attrs("trace_tau"))
        time = tau / constants.natural_circular_frequency
        coords["trace_time"] = ("trace_sample", time, attrs("trace_time"))
    title = "Response of a preloaded Hertzian contact to band-limited random excitation"
    ds = _build(data, coords, global_attributes(scene, title, "random", history))
    extra = {
        "integration_steps": int(result.steps),
        "realisations": int(result.realisations),
        "welch_segments": int(result.segments),
        "measured_periods": int(result.measured_periods),
        "complete": int(result.complete),
    }
    return merge_attributes(ds, extra)


# --------------------------------------------------------------------------- commands
def trace_command(result: TraceResult, scene: Scene) -> dict[str, Any]:
    """``command_json`` of a trace: the arguments of ``hertzsweep trace`` that made it
    (``samples_per_period`` None: every step)."""
    every_step = int(result.samples_per_period) == scene.solver.steps_per_period
    return {
        "command": "trace",
        "frequency_ratio": float(result.frequency_ratio),
        "periods": int(result.periods),
        "branch": str(result.branch),
        "samples_per_period": None if every_step else int(result.samples_per_period),
    }


def accuracy_command(report: AccuracyReport) -> dict[str, Any]:
    """``command_json`` of an accuracy run: the ``--target`` and the ladder that ran, each
    rung's setting (reference last; the scene's own setting is re-derived from the
    scene). A rung that failed is not in the report and not in the ladder."""
    return {
        "command": "accuracy",
        "target": report.target,
        "settings": [
            {
                "steps_per_period": int(rung.setting.steps_per_period),
                "settle_periods": rung.setting.settle_periods,
                "tolerance": rung.setting.tolerance,
                "steady_state": rung.setting.steady_state,
                "method": rung.setting.method,
            }
            for rung in report.rungs
        ],
    }


# --------------------------------------------------------------------------- files
def write_atomic(ds: Frame | xr.Dataset, path: str | os.PathLike) -> Path:
    """Write netCDF4 (:func:`write_netcdf`) through :func:`.paths.atomic_path`: the output
    is complete or absent; a write that fails (no space, I/O error) ends as one
    ``OSError`` naming ``path``, its temporary removed."""
    with atomic_path(path) as tmp:
        write_netcdf(ds, tmp)
    return Path(path)


COMPRESSION = {"zlib": True, "complevel": 4, "shuffle": True}  # float arrays: about 2x smaller
SLAB_BYTES = 1 << 21  # [bytes] a compressed variable whose last axis is longer than this
# (a long trace's spectrum) is stored in HDF5 chunks of this size along it (one index of
# the others), written chunk by chunk with a cache of one: what netCDF4 and HDF5 copy and
# cache stays this small instead of the variable's size. Others (a sweep's, a study's:
# short last axes) keep netCDF's default chunks and are written whole.


def write_netcdf(ds: Frame | xr.Dataset, path: str | os.PathLike) -> None:
    """Write a dataset as netCDF4 with the netCDF4 library, CF-1.11 clean, so that
    :func:`open_dataset` (xarray) reads back the same variables, coordinates and
    attributes:

    - coordinates have no ``_FillValue`` (CF 2.5.1); float data variables have NaN;
    - strings are character arrays along a ``stringN`` dimension with
      ``_Encoding = "utf-8"`` (CF 6.1 labels; xarray decodes them to strings), so a
      string coordinate such as ``direction`` is a label, not a coordinate variable,
      which CF requires to be numeric;
    - a data variable names the non-dimension coordinates on its dimensions in
      ``coordinates`` (CF 5), which xarray reads back as coordinates;
    - booleans are written as int8; float data arrays are compressed.

    The file is built on a scratch file in memory (:func:`_built`) and written with one
    stream of ``write`` calls and an ``fsync`` (:func:`~hertzsweep.output.paths.write_file`),
    so a write that fails raises the OS's own error (no space, I/O error), not the HDF5
    library's "HDF error".

    Raises
    ------
    OSError
        Writing the file failed.
    TypeError
        A variable of a type netCDF has no place for (complex, datetime, object other
        than strings), or an attribute that is None.
    """
    with _built(ds) as scratch:
        write_file(path, scratch.read_bytes())


SCRATCH_FOLDERS = ("/dev/shm",)  # RAM-backed folders to build a file in; else the temp dir
SCRATCH_ROOM = 1 << 30  # [bytes] free room a scratch folder must have to be used


@contextlib.contextmanager
def _built(ds: Frame | xr.Dataset) -> Iterator[Path]:
    """A netCDF4 file of ``ds`` built on a scratch file (removed on exit), in a RAM-backed
    folder where there is one.

    netCDF's own in-memory files (``memory=``) are created without HDF5's attribute
    creation order, so that more than eight global attributes are listed in the order of
    their names' hashes (Unidata/netcdf-c#3334); a file netCDF creates on a path keeps
    the order in which :func:`_fill` writes them (:func:`ordered_attributes`)."""
    import tempfile

    import netCDF4

    with tempfile.TemporaryDirectory(prefix="hertzsweep-", dir=_scratch_folder()) as folder:
        scratch = Path(folder) / "dataset.nc"
        nc = netCDF4.Dataset(scratch, "w", format="NETCDF4")
        try:
            _fill(nc, ds)
        finally:
            nc.close()
        yield scratch


def _scratch_folder() -> str | None:
    """The first of :data:`SCRATCH_FOLDERS` that is writable with room, else None (the
    system's temporary folder)."""
    for folder in SCRATCH_FOLDERS:
        try:
            room = os.statvfs(folder)
        except OSError:
            continue
        if os.access(folder, os.W_OK) and room.f_bavail * room.f_frsize >= SCRATCH_ROOM:
            return folder
    return None


def as_written(ds: Frame | xr.Dataset) -> xr.Dataset:
    """The :class:`xarray.Dataset` that reading the file :func:`write_netcdf` writes of
    ``ds`` gives (built as it is built and read back: every conversion of the format
    applied, e.g. a one-element attribute read as a number, booleans as int8)."""
    with _built(ds) as scratch:
        return open_dataset(scratch)


def _fill(nc: Any, ds: Frame | xr.Dataset) -> None:
    """The attributes, dimensions and variables of a dataset into an open netCDF4 file;
    a variable the file has already (streamed, :class:`RecordStream`) gets its
    attributes, its values stay. The global attributes are written in the order of
    :func:`ordered_attributes`, whatever order they were added in."""
    for key, value in ordered_attributes(ds.attrs).items():
        nc.setncattr(key, _attribute(key, value))
    for dim, size in ds.sizes.items():
        if str(dim) not in nc.dimensions:
            nc.createDimension(str(dim), size)
    coordinates = _coordinates_attributes(ds)
    names = [*ds.coords, *ds.data_vars]
    for name in names:
        var = ds.variables[name]
        is_coordinate = name in ds.coords
        extra = {"coordinates": coordinates[name]} if name in coordinates else {}
        _write_variable(nc, str(name), var, is_coordinate, extra)


def _coordinates_attributes(ds: Frame | xr.Dataset) -> dict[Any, str]:
    """``coordinates`` of each data variable: the non-dimension coordinates whose
    dimensions are all among its own."""
    auxiliary = [name for name in ds.coords if name not in ds.dims]
    out = {}
    for name, var in ds.data_vars.items():
        mine = [str(c) for c in auxiliary if set(ds[c].dims) <= set(var.dims)]
        if mine:
            out[name] = " ".join(mine)
    return out


def _write_variable(
    nc: Any, name: str, var: Variable | xr.Variable, is_coordinate: bool, extra: Mapping[str, str]
) -> None:
    """One variable: its type, dimensions, fill value, compression and attributes."""
    import netCDF4

    values = np.asarray(var.values)
    kind = values.dtype.kind
    dims = tuple(str(d) for d in var.dims)
    attributes = dict(var.attrs)
    if kind in "OUS":
        values = _utf8(name, values)
        width = max(1, values.dtype.itemsize)
        char_dim = f"string{width}"
        if char_dim not in nc.dimensions:
            nc.createDimension(char_dim, width)
        values = netCDF4.stringtochar(values.astype(f"S{width}"))
        dtype: Any = "S1"
        dims = (*dims, char_dim)
        attributes["_Encoding"] = "utf-8"
    elif kind == "b":
        values, dtype = values.astype(np.int8), np.int8
    elif kind in "iuf":
        dtype = values.dtype
    else:
        raise TypeError(f"{name}: cannot write a {values.dtype} variable to netCDF")
    width = max(1, values.shape[-1]) if values.ndim else 1
    if name in nc.variables:  # streamed: its values are in the file
        variable = nc.variables[name]
        values = None
    else:
        options = _storage(kind, is_coordinate, values.size)
        slab = SLAB_BYTES // values.dtype.itemsize
        if "zlib" in options and values.ndim and values.shape[-1] > slab:  # in slabs, below
            width = slab
            options["chunksizes"] = (1,) * (values.ndim - 1) + (width,)
        variable = nc.createVariable(name, dtype, dims, **options)
        if "chunksizes" in options:
            variable.set_var_chunk_cache(size=SLAB_BYTES, nelems=1)
    encoding = attributes.pop("_Encoding", None)
    if encoding is not None:
        variable.setncattr("_Encoding", encoding)
    for key, value in {**attributes, **extra}.items():
        variable.setncattr(key, _attribute(f"{name}.{key}", value))
    if dtype == "S1":
        variable.set_auto_chartostring(False)  # the character array is written as is
    if values is None:
        return
    if values.ndim == 0:
        variable.assignValue(values)
        return
    for first in range(0, values.shape[-1], width):  # whole chunks, written once
        variable[..., first : first + width] = values[..., first : first + width]


def _storage(kind: str, is_coordinate: bool, size: int) -> dict[str, Any]:
    """``createVariable``'s fill value and compression of a variable of numpy ``kind``."""
    options: dict[str, Any] = {}
    if is_coordinate:
        options["fill_value"] = False  # CF 2.5.1: no _FillValue on coordinate data
    elif kind == "f":
        options["fill_value"] = np.nan
    if kind == "f" and not is_coordinate and size > 1:
        options.update(COMPRESSION)
    return options


# --------------------------------------------------------------------------- streamed record
RECORD_VARIABLES = (  # a trace record's columns (kernels.flights), as variables
    ("displacement", np.float64),
    ("velocity", np.float64),
    ("normal_force", np.float64),
    ("in_contact", np.int8),
)
BALL_RECORD_VARIABLES = RECORD_VARIABLES + (  # the ball model's (kernels.ball)
    ("ball_displacement", np.float64),
    ("ball_velocity", np.float64),
    ("upper_force", np.float64),
    ("upper_in_contact", np.int8),
)


def record_variables(columns: int) -> tuple[tuple[str, Any], ...]:
    """The variables of a record of ``columns`` columns (the single or the ball model's)."""
    return RECORD_VARIABLES if columns == len(RECORD_VARIABLES) else BALL_RECORD_VARIABLES


class RecordStream:
    """A trace's netCDF file written while the trace runs: a
    :class:`~hertzsweep.drivers.trace.RecordSink` writing each recorded chunk (and the
    ``tau``, ``time`` coordinates) into the file, on disk, so that no whole record is
    ever held in memory; :meth:`finish` writes the rest of the dataset
    (:func:`trace_dataset` of the result) and closes it.

    For records too large to hold (:func:`hertzsweep.core.checks.streams_record`); the
    file holds what :func:`write_netcdf` writes (the same variables, attributes and
    values; the record's variables first, in HDF5 chunks of one recorded chunk). Used
    inside :func:`~.paths.atomic_path`, and flushed to the disk before it renames, so
    the output is complete or absent. The netCDF library reports a failed write as "HDF
    error": it becomes the OS's ``OSError`` (no space left, when the disk's free space is
    below :data:`WRITE_MARGIN`; else an I/O error quoting the library).
    """

    def __init__(self, path: str | os.PathLike, omega: float) -> None:
        self.path = os.fspath(path)
        self.omega = float(omega)
        self.nc: Any = None
        self.sample_step = 0.0
        self.variables = RECORD_VARIABLES

    def __enter__(self) -> RecordStream:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.nc is not None:  # not finished: the temporary is discarded anyway
            with contextlib.suppress(Exception):
                self.nc.close()
            self.nc = None

    def open(
        self, sigma: int, samples: int, chunk: int, sample_step: float, columns: int = 4
    ) -> None:
        """Create the file, its ``sigma`` and ``sample`` dimensions and the streamed
        variables, stored in HDF5 chunks of the recorded chunks (one sigma x ``chunk``
        samples), each variable's chunk cache one chunk: every chunk is written whole,
        once, so the file costs no memory that grows with the record."""
        import netCDF4

        self.sample_step = float(sample_step)
        self.variables = record_variables(columns)
        with self._writing():
            nc = self.nc = netCDF4.Dataset(self.path, "w", format="NETCDF4")
            nc.createDimension("sigma", sigma)
            nc.createDimension("sample", samples)
            for name in ("tau", "time"):
                nc.createVariable(name, np.float64, ("sample",), **_storage("f", True, samples))
            for name, dtype in self.variables:
                kind = np.dtype(dtype).kind
                options = _storage(kind, False, sigma * samples)
                variable = nc.createVariable(
                    name, dtype, ("sigma", "sample"), chunksizes=(1, chunk), **options
                )
                variable.set_var_chunk_cache(size=chunk * np.dtype(dtype).itemsize, nelems=1)

    def write(self, s: int, first: int, rows: np.ndarray) -> None:
        """Samples ``first ..`` of sigma ``s`` (float[n, 4], the record's columns)."""
        span = slice(first, first + rows.shape[0])
        with self._writing():
            if s == 0:  # the same arithmetic as TraceResult.tau and trace_dataset
                tau = np.arange(span.start, span.stop) * self.sample_step
                self.nc["tau"][span] = tau
                self.nc["time"][span] = tau / self.omega
            for c, (name, dtype) in enumerate(self.variables):
                self.nc[name][s, span] = rows[:, c].astype(dtype, copy=False)

    def finish(self, ds: Frame) -> None:
        """The rest of the dataset (its streamed variables get their attributes), closed
        and flushed to the disk."""
        with self._writing():
            _fill(self.nc, ds)
            nc, self.nc = self.nc, None
            nc.close()
        sync_path(self.path)  # on the disk before atomic_path renames it

    @contextlib.contextmanager
    def _writing(self) -> Any:
        try:
            yield
        except RuntimeError as exc:  # netCDF4's "NetCDF: HDF error" and the like
            raise _write_error(self.path, exc) from None


WRITE_MARGIN = 1 << 20  # [bytes] free space below which a failed write means a full disk


def _write_error(path: str, exc: Exception) -> OSError:
    """The OS error a failed netCDF write most likely was: no space left when the disk
    holding ``path`` has less than :data:`WRITE_MARGIN` free, else an I/O error quoting
    the library."""
    free = None
    with contextlib.suppress(OSError):
        stat = os.statvfs(os.path.dirname(os.path.abspath(path)))
        free = stat.f_bavail * stat.f_frsize
    if free is not None and free < WRITE_MARGIN:
        return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), path)
    return OSError(errno.EIO, f"{os.strerror(errno.EIO)} (netCDF: {exc})", path)


def _utf8(name: str, values: np.ndarray) -> np.ndarray:
    """Strings as UTF-8 bytes (fixed width)."""
    try:
        return np.char.encode(values.astype(str), "utf-8")
    except (TypeError, ValueError, UnicodeError) as exc:
        raise TypeError(f"{name}: expected strings ({exc})") from None


def _attribute(name: str, value: Any) -> Any:
    """An attribute value netCDF can hold: bools as 0/1, lists as arrays."""
    if value is None:
        raise TypeError(f"attribute {name}: None has no netCDF form")
    value = _netcdf_value(value)
    if isinstance(value, np.ndarray) and value.dtype.kind == "b":
        return value.astype(np.int8)
    return value


def open_dataset(path: str | os.PathLike) -> xr.Dataset:
    """Open a hertzsweep netCDF file fully into memory (the file is closed on return).

    A ``harmonic`` coordinate of integers (a file of a version before orders that are not
    whole, e.g. ``tests/data/golden``) reads as float64, the type of every file since
    (:data:`ORDER`): a dataset read compares, aligns and selects with any other."""
    xr = load_xarray()
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return orders_as_float(ds.load())


def orders_as_float(ds: xr.Dataset) -> xr.Dataset:
    """The dataset with an integer ``harmonic`` coordinate cast to :data:`ORDER` (its
    attributes kept); as it is otherwise."""
    if "harmonic" in ds.coords and ds["harmonic"].dtype.kind in "iu":
        ds = ds.assign_coords(harmonic=ds["harmonic"].astype(ORDER))
    return ds


def read_attributes(path: str | os.PathLike) -> dict[str, Any]:
    """The global attributes of a netCDF file, its variables left unread (netCDF4 directly:
    neither the data nor xarray is loaded)."""
    import netCDF4

    with netCDF4.Dataset(os.fspath(path)) as nc:
        return {key: nc.getncattr(key) for key in nc.ncattrs()}


def merge_attributes(ds: Frame | xr.Dataset, extra: Mapping[str, Any]) -> Frame | xr.Dataset:
    """Add global attributes, converted for netCDF (bools to 0/1, lists to arrays); all
    of them in the order of :func:`ordered_attributes`, the order the file gets."""
    merged = {**ds.attrs, **{k: _netcdf_value(v) for k, v in extra.items()}}
    ds.attrs = ordered_attributes(merged)
    return ds
