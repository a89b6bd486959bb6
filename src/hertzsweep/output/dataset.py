"""Datasets: results -> self-describing xarray Datasets with CF-1.11 attributes.

The one table of output attributes is :data:`ATTRIBUTES`; every builder takes names
from it, so a variable means the same thing in every dataset. Only this layer knows
xarray; only the CLI opens and writes files, through :func:`write_atomic`.
"""

from __future__ import annotations

import datetime as _dt
import os
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .. import __version__
from ..core.config import Scene
from ..core.rig import RigConstants, derive
from ..drivers.sweep import SweepResult

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
    # trace
    "tau": ("dimensionless time tau = Omega t from the first recorded sample", "1"),
    "time": ("time from the first recorded sample", "s"),
    "displacement": ("dimensionless displacement q = 3/2 (z - z_s)/z_s", "1"),
    "velocity": ("dimensionless velocity dq/dtau", "1"),
    "normal_force": ("transmitted normal force N/F_s", "1"),
    "in_contact": ("in contact (1) or in flight (0)", "1"),
    "harmonic_order": ("frequency of the spectral line over the excitation frequency", "1"),
    "spectrum_frequency": ("frequency of the spectral line", "Hz"),
    "spectrum": ("amplitude spectrum of N/F_s (peak; the mean at order 0)", "1"),
    "flight_start": ("start of the flight (loss of contact) in tau", "1"),
    "flight_end": ("end of the flight (loss of contact) in tau", "1"),
    "flight_start_time": ("start of the flight (loss of contact)", "s"),
    "flight_duration": ("duration of the flight (loss of contact)", "s"),
    "flight_complete": ("flight lies wholly inside the record", "1"),
    "flight_count": ("number of flights in the record", "1"),
    # --- trace attributes (insert above this line)
    # branch
    "point": ("index of the point along the branch, in arclength order", "1"),
    "multiplier": ("index of the Floquet multiplier, largest modulus first", "1"),
    "bifurcation": ("index of the located bifurcation along the branch", "1"),
    "multiplier_real": ("real part of the Floquet multiplier of the periodic orbit", "1"),
    "multiplier_imag": ("imaginary part of the Floquet multiplier of the periodic orbit", "1"),
    "stable": (
        "periodic orbit asymptotically stable (both multipliers inside the unit circle); -1 pads",
        "1",
    ),
    "arclength": (
        "pseudo-arclength along the branch in the scaled coordinates "
        "(w, q/Q, q'/(w Q)), Q = sigma/(2 zeta)",
        "1",
    ),
    "branch_complete": ("branch continued across the whole frequency span", "1"),
    "branch_end": (
        "how the branch ended: end, start (left the span where it began), "
        "stalled, retraced, max-points",
        "1",
    ),
    "branch_bridges": (
        "gaps of the branch crossed at fixed frequency (discontinuous contact damping)",
        "1",
    ),
    "bifurcation_frequency_ratio": ("frequency ratio of the bifurcation", "1"),
    "bifurcation_frequency": ("frequency of the bifurcation", "Hz"),
    "bifurcation_kind": (
        "kind of bifurcation: fold, period-doubling or neimark-sacker (empty pads)",
        "1",
    ),
    "bifurcation_amplitude": ("amplitude of harmonic 1 of N/F_s at the bifurcation (peak)", "1"),
    "bifurcation_point": ("index of the branch point at the bifurcation (-1 pads)", "1"),
    # --- branch attributes (insert above this line)
    # study
    "damping_ratio": ("damping ratio zeta (eq. 4)", "1"),
    "damping_exponent": ("exponent n of the contact damping law (eq. 11)", "1"),
    "damping_law": ("damping law: viscous (eq. 8) or contact (eq. 11)", "1"),
    "case_failed": ("the study case failed or has no result (its values are fill values)", "1"),
    "case_id": ("sha256 of the case's resolved configuration: its part OUT.parts/<id>.nc", "1"),
    # --- study attributes (insert above this line)
    # accuracy
    "setting_label": ("solver settings of the rung", "1"),
    "steps_per_period": ("integration steps per excitation period", "1"),
    "settle": ("settling: periods, or auto:tolerance", "1"),
    "steady_state": ("steady-state method: settle or shooting", "1"),
    "error_h1": (
        "max abs error of the H1 amplitude over the sweep, relative to the reference's largest H1",
        "1",
    ),
    "error_h2": (
        "max abs error of the H2 amplitude over the sweep, relative to the reference's largest H2",
        "1",
    ),
    "error_force": ("max abs error of force_max and force_min over the sweep", "1"),
    "error_jump": ("max abs error of the jump frequency ratio (inf: a jump missed or added)", "1"),
    "cost_steps": ("integration steps of the sweep", "1"),
    "wall_time": ("wall-clock time of the sweep", "s"),
    "pareto": ("on the Pareto front of cost_steps and error_h1", "1"),
    "order_h1": ("observed order of accuracy of H1 from N, 2N, 4N (steps rungs)", "1"),
    "settled_fraction": ("share of the dwells that reached the steady state", "1"),
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
def trace_dataset(result: Any, scene: Scene, history: str | None = None) -> xr.Dataset:
    """The trace dataset of a :class:`hertzsweep.trace.TraceResult`.

    Dimensions ``sigma``, ``sample`` (coordinates ``tau`` and ``time`` [s]),
    ``harmonic``, ``harmonic_order`` (with ``spectrum_frequency`` [Hz]) and ``flight``;
    the record's columns are views, not copies. Flight variables are NaN padded
    (``flight_complete`` with -1). Times in seconds are ``tau / Omega`` (eq. 6).
    """
    constants = derive(scene.rig)
    omega = constants.natural_circular_frequency
    w = float(result.frequency_ratio)
    tau = result.tau
    record = result.record
    trace = ("sigma", "sample")
    flight = ("sigma", "flight")
    data = {
        "displacement": (trace, record[:, :, 0]),
        "velocity": (trace, record[:, :, 1]),
        "normal_force": (trace, record[:, :, 2]),
        "in_contact": (trace, record[:, :, 3].astype(np.int8)),
        "spectrum": (("sigma", "harmonic_order"), result.spectrum),
        "amplitude": (("sigma", "harmonic"), result.amplitude),
        "phase": (("sigma", "harmonic"), result.phase),
        "mean_force": ("sigma", result.mean_force),
        "force_max": ("sigma", result.force_max),
        "force_min": ("sigma", result.force_min),
        "contact_loss_fraction": ("sigma", result.contact_loss_fraction),
        "flight_time": ("sigma", result.flight_tau / omega),
        "flight_count": ("sigma", result.flight_count.astype(np.int32)),
        "flight_start": (flight, result.flight_start),
        "flight_end": (flight, result.flight_end),
        "flight_start_time": (flight, result.flight_start / omega),
        "flight_duration": (flight, (result.flight_end - result.flight_start) / omega),
        "flight_complete": (flight, result.flight_complete),
        "settled": ("sigma", result.settled.astype(np.int8)),
        "periodic": ("sigma", result.periodic.astype(np.int8)),
        "frequency_ratio": ((), w),
        "frequency": ((), w * constants.natural_frequency),
    }
    coords = {
        "sigma": ("sigma", result.sigma, attrs("sigma")),
        "tau": ("sample", tau, attrs("tau")),
        "time": ("sample", tau / omega, attrs("time")),
        "harmonic": ("harmonic", result.harmonics, attrs("harmonic")),
        "harmonic_order": ("harmonic_order", result.harmonic_order, attrs("harmonic_order")),
        "spectrum_frequency": (
            "harmonic_order",
            result.harmonic_order * w * constants.natural_frequency,
            attrs("spectrum_frequency"),
        ),
    }
    ds = xr.Dataset(
        {name: (dims, values, attrs(name)) for name, (dims, values) in data.items()},
        coords=coords,
        attrs=global_attributes(
            scene, "Time history and spectrum of a preloaded Hertzian contact at one frequency",
            "trace", history,
        ),
    )  # fmt: skip
    for flag in ("settled", "periodic"):
        ds[flag].attrs.update(flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="no yes")
    ds["in_contact"].attrs.update(
        flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="flight contact"
    )
    ds["flight_complete"].attrs.update(
        flag_values=np.array([-1, 0, 1], dtype=np.int8),
        flag_meanings="no_flight cut_by_record complete",
    )
    approach = np.asarray(result.approach)
    ds.attrs.update(
        frequency_ratio=w,
        frequency=w * constants.natural_frequency,
        branch=result.branch,
        periods=int(result.periods),
        samples_per_period=int(result.samples_per_period),
        record_stride=int(result.stride),
        approach_from=float(approach[0]) if approach.size else w,
        approach_dwells=int(approach.size),
        spectrum_backend=result.spectrum_backend,
        integration_steps=int(result.steps),
    )
    return ds


# --------------------------------------------------------------------------- branch
# (branch dataset builders go here)
def branch_dataset(result, scene: Scene, history: str | None = None) -> xr.Dataset:
    """The branch dataset of a :class:`~hertzsweep.continuation.BranchResult`.

    Dimensions ``sigma``, ``point`` (points in arclength order, NaN padded; ``stable``
    padded with -1), ``harmonic``, ``multiplier`` (0, 1: largest modulus first) and
    ``bifurcation`` (located bifurcations in arclength order, padded with NaN, ``""``
    and -1; at least one slot).
    """
    constants = derive(scene.rig)
    branches = result.branches
    n_sigma = len(branches)
    n_points = max(branch.size for branch in branches)
    n_found = max(1, max(len(branch.bifurcations) for branch in branches))
    n_harmonics = result.harmonics.size
    per_point = {
        name: np.full((n_sigma, n_points), np.nan)
        for name in ("frequency_ratio", "mean_force", "force_max", "force_min",
                     "contact_loss_fraction", "flight_tau", "arclength")
    }  # fmt: skip
    amplitude = np.full((n_sigma, n_points, n_harmonics), np.nan)
    phase = np.full((n_sigma, n_points, n_harmonics), np.nan)
    multipliers = np.full((n_sigma, n_points, 2), np.nan + 0j)
    stable = np.full((n_sigma, n_points), -1, dtype=np.int8)
    found_w = np.full((n_sigma, n_found), np.nan)
    found_amplitude = np.full((n_sigma, n_found), np.nan)
    found_kind = np.full((n_sigma, n_found), "", dtype=object)
    found_point = np.full((n_sigma, n_found), -1, dtype=np.int32)
    complete = np.zeros(n_sigma, dtype=np.int8)
    ends = np.array([branch.end for branch in branches], dtype=object)
    bridges = np.array([branch.bridges for branch in branches], dtype=np.int32)
    for s, branch in enumerate(branches):
        size = branch.size
        for name, values in per_point.items():
            values[s, :size] = getattr(branch, name)
        amplitude[s, :size] = branch.amplitude
        phase[s, :size] = branch.phase
        multipliers[s, :size] = branch.multipliers
        stable[s, :size] = branch.stable
        complete[s] = branch.complete
        for i, found in enumerate(branch.bifurcations):
            found_w[s, i] = found.frequency_ratio
            found_amplitude[s, i] = found.amplitude
            found_kind[s, i] = found.kind
            found_point[s, i] = found.point
    f0 = constants.natural_frequency
    at_point = ("sigma", "point")
    data = {
        "frequency_ratio": (at_point, per_point["frequency_ratio"]),
        "frequency": (at_point, per_point["frequency_ratio"] * f0),
        "amplitude": (at_point + ("harmonic",), amplitude),
        "phase": (at_point + ("harmonic",), phase),
        "mean_force": (at_point, per_point["mean_force"]),
        "force_max": (at_point, per_point["force_max"]),
        "force_min": (at_point, per_point["force_min"]),
        "contact_loss_fraction": (at_point, per_point["contact_loss_fraction"]),
        "flight_time": (at_point, per_point["flight_tau"] / constants.natural_circular_frequency),
        "multiplier_real": (at_point + ("multiplier",), multipliers.real),
        "multiplier_imag": (at_point + ("multiplier",), multipliers.imag),
        "stable": (at_point, stable),
        "arclength": (at_point, per_point["arclength"]),
        "branch_complete": (("sigma",), complete),
        "branch_end": (("sigma",), ends),
        "branch_bridges": (("sigma",), bridges),
        "bifurcation_frequency_ratio": (("sigma", "bifurcation"), found_w),
        "bifurcation_frequency": (("sigma", "bifurcation"), found_w * f0),
        "bifurcation_kind": (("sigma", "bifurcation"), found_kind),
        "bifurcation_amplitude": (("sigma", "bifurcation"), found_amplitude),
        "bifurcation_point": (("sigma", "bifurcation"), found_point),
    }
    coords = {
        "sigma": ("sigma", result.sigma, attrs("sigma")),
        "point": ("point", np.arange(n_points, dtype=np.int32), attrs("point")),
        "harmonic": ("harmonic", result.harmonics, attrs("harmonic")),
        "multiplier": ("multiplier", np.arange(2, dtype=np.int32), attrs("multiplier")),
        "bifurcation": ("bifurcation", np.arange(n_found, dtype=np.int32), attrs("bifurcation")),
    }
    ds = xr.Dataset(
        {name: (dims, values, attrs(name)) for name, (dims, values) in data.items()},
        coords=coords,
        attrs=global_attributes(scene, "Periodic orbits of a preloaded Hertzian contact by "
                                "shooting and pseudo-arclength continuation", "branch",
                                history),
    )  # fmt: skip
    ds["stable"].attrs.update(
        flag_values=np.array([-1, 0, 1], dtype=np.int8), flag_meanings="no_point unstable stable"
    )
    ds["branch_complete"].attrs.update(
        flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="no yes"
    )
    ds.attrs["integration_steps"] = int(result.steps)
    ds.attrs["branch_start_frequency_ratio"] = float(result.start_frequency_ratio)
    ds.attrs["branch_end_frequency_ratio"] = float(result.end_frequency_ratio)
    return ds


# --------------------------------------------------------------------------- study
# (study dataset builders go here)
GRID_UNITS = {  # units of grid coordinates that are SI config values
    "rig.ball_radius": "m",
    "rig.youngs_modulus": "Pa",
    "rig.mass": "kg",
    "rig.static_load": "N",
    "rig.ball_mass": "kg",
    "rig.ball_density": "kg m-3",
}


def _fill_value(dtype: np.dtype) -> Any:
    """What a study writes where a case has no result: NaN, -1 for integers and flags,
    "" for strings."""
    if dtype.kind == "f":
        return np.nan
    if dtype.kind in "iu":
        return -1
    if dtype.kind == "b":
        return False
    return ""


def _grid_attrs(key: str, dim: str) -> dict[str, Any]:
    """CF attributes of a grid coordinate: from :data:`ATTRIBUTES` when the dimension is
    named there, else the config key itself."""
    out = attrs(dim) if dim in ATTRIBUTES else {
        "long_name": f"study grid value of {key}", "units": GRID_UNITS.get(key, "1")}  # fmt: skip
    out["config_key"] = key
    return out


def study_dataset(
    study_kind: str,
    grid: Any,
    case_dims: Any,
    parts: Mapping[tuple[int, ...], xr.Dataset | None],
    case_ids: Mapping[tuple[int, ...], str],
    scene: Scene,
    drop_attributes: Any = (),
    history: str | None = None,
    extra: Mapping[str, Any] | None = None,
) -> xr.Dataset:
    """ONE dataset of a study's cases, concatenated along the grid dimensions.

    Parameters
    ----------
    study_kind : ``"sweep"`` or ``"branch"``: the kind of every part.
    grid : ``[(key, dim, values), ...]``, every grid key in study order.
    case_dims : the dims the parts vary along, in grid order: every grid dim but
        ``sigma`` when each case holds all the grid's sigma values.
    parts : ``{index along case_dims: dataset or None}``; None (a failed case) becomes
        fill values (NaN; -1 for integers and flags; "" for strings).
    case_ids : ``{index: hash}``, the ``case_id`` variable.
    scene : a case's scene, for the global attributes; ``drop_attributes`` (the config
        values that vary along the grid) are left out.

    Notes
    -----
    Dimensions: ``direction`` first (sweep studies), then the grid dims in study order,
    then the rest of the part's dims (``frequency_ratio``, ``harmonic``; ``point``, ...).
    Dims without coordinates in the parts (``point``, ``bifurcation``) are padded to the
    longest part. ``case_failed`` (grid dims) is 1 where a case failed. A sweep study
    keeps the parts' ``jump_frequency_ratio(direction, ...grid...)``.
    """
    values_of = {dim: list(values) for _, dim, values in grid}
    template = next(ds for ds in parts.values() if ds is not None)
    fills = {name: _fill_value(var.dtype) for name, var in template.variables.items()}
    bare_dims: set[str] = set()
    for ds in parts.values():
        if ds is not None:
            bare_dims.update(d for d in ds.dims if d not in ds.indexes)

    def prepared(index: tuple[int, ...]) -> xr.Dataset:
        ds = parts.get(index)
        missing = ds is None
        if missing:
            ds = template.copy(deep=True)
            for name in ds.data_vars:
                ds[name] = ds[name].copy(data=np.full(ds[name].shape, fills[name],
                                                      dtype=ds[name].dtype))  # fmt: skip
        ds = ds.assign_coords({d: np.arange(ds.sizes[d]) for d in bare_dims if d in ds.dims})
        new = {}
        for dim, i in zip(case_dims, index, strict=True):
            value = values_of[dim][i]
            if dim == "sigma":
                if missing:
                    ds = ds.isel(sigma=[0]).assign_coords(sigma=[value])
            else:
                new[dim] = [value]
        return ds.expand_dims(new) if new else ds

    shape = [len(values_of[d]) for d in case_dims]

    def nested(prefix: tuple[int, ...]) -> Any:
        if len(prefix) == len(shape):
            return prepared(prefix)
        return [nested(prefix + (i,)) for i in range(shape[len(prefix)])]

    if case_dims:
        ds = xr.combine_nested(
            nested(()), concat_dim=list(case_dims), data_vars="all", coords="different",
            compat="equals", join="outer", fill_value=fills, combine_attrs="override",
        )  # fmt: skip
    else:
        ds = prepared(())
    ds = ds.drop_vars([d for d in bare_dims if d in ds.coords])
    grid_dims = [dim for _, dim, _ in grid]
    head = [d for d in ("direction",) if d in ds.dims]
    order = head + [d for d in grid_dims if d in ds.dims and d not in head]
    order += [d for d in template.dims if d not in order]
    ds = ds.transpose(*order)
    for key, dim, _ in grid:
        if dim != "sigma":
            ds[dim].attrs = _grid_attrs(key, dim)
    failed = xr.DataArray(
        np.zeros([len(values_of[d]) for d in grid_dims], dtype=np.int8),
        dims=grid_dims, coords={d: ds[d] for d in grid_dims}, attrs=attrs("case_failed"),
    )  # fmt: skip
    ids = np.empty(shape, dtype=object)
    for index, ds_part in parts.items():
        ids[index] = case_ids.get(index, "")
        if ds_part is None:
            where = {d: values_of[d][i] for d, i in zip(case_dims, index, strict=True)}
            failed.loc[where] = 1
    failed.attrs.update(flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="no yes")
    ds["case_failed"] = failed
    ds["case_id"] = (tuple(case_dims), ids, attrs("case_id"))
    if bool(failed.any()):
        for name in ds.data_vars:
            meanings = ds[name].attrs.get("flag_meanings")
            if meanings == "no yes" and name != "case_failed":
                ds[name].attrs.update(flag_values=np.array([-1, 0, 1], dtype=np.int8),
                                      flag_meanings="missing no yes")  # fmt: skip
    steps = [int(p.attrs.get("integration_steps", 0)) for p in parts.values() if p is not None]
    title = f"Parameter study ({study_kind}) of a preloaded Hertzian contact"
    out = global_attributes(scene, title, "study", history)
    for name in drop_attributes:
        out.pop(name, None)
    out.pop("scene_file", None)
    out.update(study_kind=study_kind, integration_steps=int(sum(steps)))
    ds.attrs = out
    return merge_attributes(ds, extra or {})


# --------------------------------------------------------------------------- accuracy
# (accuracy dataset builders go here)
def accuracy_dataset(report: Any, scene: Scene, history: str | None = None) -> xr.Dataset:
    """The accuracy dataset of a :class:`hertzsweep.accuracy.AccuracyReport`.

    Dimension ``setting`` (the rungs that ran, reference last) with coordinates
    ``setting_label``, ``steps_per_period``, ``settle`` ("300", "auto:1e-4") and
    ``steady_state``; the errors against the reference, the cost, the Pareto flag and the
    observed order ``order_h1`` per rung. Attributes: ``observed_order``, ``reference_label``, the
    reference's Richardson error estimates ``reference_error_h1`` (``_h2``, ``_force``),
    ``settle_check_h1``, ``scene_setting``, ``target``, ``target_margin`` (the reference's
    error counted against it) and ``recommended`` (label; empty when none meets the target
    or no target was given), ``notes``.
    """
    rungs = report.rungs
    settings = [r.setting for r in rungs]

    def strings(values: list[str]) -> np.ndarray:
        return np.array(values, dtype=object)

    coords = {
        "setting_label": ("setting", strings([s.label for s in settings]),
                          attrs("setting_label")),
        "steps_per_period": ("setting", np.array([s.steps_per_period for s in settings]),
                             attrs("steps_per_period")),
        "settle": ("setting", strings([s.settle for s in settings]), attrs("settle")),
        "steady_state": ("setting", strings([s.steady_state for s in settings]),
                         attrs("steady_state")),
    }  # fmt: skip
    errors = report.errors
    data = {
        "error_h1": np.array([e.h1 for e in errors]),
        "error_h2": np.array([e.h2 for e in errors]),
        "error_force": np.array([e.force for e in errors]),
        "error_jump": np.array([e.jump for e in errors]),
        "cost_steps": np.array([r.cost_steps for r in rungs], dtype=np.int64),
        "wall_time": np.array([r.wall_time for r in rungs]),
        "pareto": np.asarray(report.pareto, dtype=np.int8),
        "order_h1": np.asarray(report.orders, dtype=float),
        "settled_fraction": np.array([float(np.mean(r.result.settled)) for r in rungs]),
    }
    ds = xr.Dataset(
        {name: ("setting", values, attrs(name)) for name, values in data.items()},
        coords=coords,
        attrs=global_attributes(scene, "Error against cost of the solver settings",
                                "accuracy", history),
    )  # fmt: skip
    ds["pareto"].attrs.update(flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="no yes")
    ref_error = report.reference_error
    recommended = report.recommended
    extra = {
        "observed_order": float(report.observed_order),
        "reference_label": rungs[-1].setting.label,
        "scene_setting": report.scene_setting.label,
        "recommended": "" if recommended is None else rungs[recommended].setting.label,
        "target": float("nan") if report.target is None else float(report.target),
        "target_margin": float(report.target_margin),
        "error_metric": "error_h1: max abs H1 error over the sweep / the reference's max H1",
        "notes": "; ".join(report.notes),
    }
    if ref_error is not None:
        extra.update(reference_error_h1=ref_error.h1, reference_error_h2=ref_error.h2,
                     reference_error_force=ref_error.force)  # fmt: skip
    if report.settle_check is not None:
        extra["settle_check_h1"] = report.settle_check.h1
        extra["settle_check_label"] = report.settle_check_label
    return merge_attributes(ds, extra)


# --------------------------------------------------------------------------- files
@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = ".tmp") -> Iterator[Path]:
    """A temporary name in the folder of ``path``: renamed to ``path`` (with the usual
    file mode) when the block succeeds, removed when it fails, so the file at ``path`` is
    complete or absent."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    except OSError as exc:  # name the output the user gave, not a temporary
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; a result is a normal file
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_atomic(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write netCDF4 through :func:`atomic_path`: the output is complete or absent."""
    encoding = {
        name: {"zlib": True, "complevel": 4}
        for name, var in ds.data_vars.items()
        if var.dtype.kind == "f" and var.size > 1
    }
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding)
    return Path(path)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def open_dataset(path: str | os.PathLike) -> xr.Dataset:
    """Open a hertzsweep netCDF file fully into memory (the file is closed on return)."""
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return ds.load()


def merge_attributes(ds: xr.Dataset, extra: Mapping[str, Any]) -> xr.Dataset:
    """Add global attributes, converted for netCDF (bools to 0/1, lists to arrays)."""
    ds.attrs.update({k: _netcdf_value(v) for k, v in extra.items()})
    return ds
