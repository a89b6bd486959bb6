"""A study's files and its dataset: the parts of its cases and their combination.

A finished case is written atomically to ``OUT.parts/<hash>.nc`` as soon as it finishes
(:class:`PartWriter`, the ``on_case`` of :func:`hertzsweep.drivers.study.run_study`), a
failed one to ``OUT.parts/<hash>.error.json`` (its grid values, its whole resolved config
and the error), so a study stopped at any point keeps every finished case and
``--resume`` recomputes only the rest (:func:`resumable`). A part that cannot be
written (no space, I/O error) makes its case a failed one, recorded like any other.
:func:`combine` makes ONE dataset of the parts (:func:`study_dataset`), with the grid
keys as dimensions.
"""

from __future__ import annotations

import copy
import json
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.config import Scene, scene_from_dict
from ..core.kinds import KINDS
from ..core.rig import derive
from ..drivers.study import (
    LEVEL_DIMS,
    RMS_KEY,
    Case,
    CaseOutcome,
    Engine,
    Runner,
    Study,
    StudyRun,
    error_record,
    json_default,
    run_study,
    whole_cases,
)
from ..errors import HertzsweepError
from ..output.dataset import (
    INDEX,
    atomic_path,
    attributes,
    attrs,
    global_attributes,
    merge_attributes,
    open_dataset,
    to_json,
    write_atomic,
)
from ..output.frame import Frame, load_xarray
from ..output.paths import parts_folder

xr = load_xarray()  # xarray with its dask probe kept quiet

Builder = Callable[[Any, Scene, str | None], xr.Dataset]  # result, scene, history -> dataset
GRID_UNITS = {  # units of grid coordinates that are SI config values
    "rig.ball_radius": "m",
    "rig.youngs_modulus": "Pa",
    "rig.mass": "kg",
    "rig.static_load": "N",
    "rig.ball_mass": "kg",
    "rig.ball_density": "kg m-3",
}
CASE_BINS = ("force_bin",)  # coordinates a run places itself (the random histogram's bins
# span 1 + 10 linear RMS of the run's largest level): a study holds them per case
FLAGS = np.array([0, 1], dtype=np.int8)  # flag_values of a yes/no variable
FLAGS_WITH_MISSING = np.array([-1, 0, 1], dtype=np.int8)  # and where a case failed


# --------------------------------------------------------------------------- parts
def part_path(folder: Path, case: Case) -> Path:
    """``<hash>.nc``: the dataset of a finished case."""
    return folder / f"{case.hash}.nc"


def error_path(folder: Path, case: Case) -> Path:
    """``<hash>.error.json``: the record of a failed case."""
    return folder / f"{case.hash}.error.json"


def read_part(path: Path, expected_hash: str | None = None) -> xr.Dataset | None:
    """The dataset of a part file, or None when it is absent, unreadable or not the
    expected case."""
    if not path.exists():
        return None
    try:
        ds = open_dataset(path)
    except Exception:  # a file that does not open is no part
        return None
    if expected_hash is not None and ds.attrs.get("study_case_hash") != expected_hash:
        return None
    return ds


def read_case_part(folder: Path, case: Case) -> xr.Dataset | None:
    """The part of a case (:func:`read_part`); a sub-case's only with its group's sums
    (:func:`hertzsweep.jobs.realisations.is_group_part`)."""
    ds = read_part(part_path(folder, case), case.hash)
    if ds is None or case.whole is None:
        return ds
    from .realisations import is_group_part

    return ds if is_group_part(ds) else None


def resumable(cases: Sequence[Case], output: str | os.PathLike) -> list[Case]:
    """The cases whose part exists and is readable (what ``--resume`` skips)."""
    folder = parts_folder(output)
    return [case for case in cases if read_case_part(folder, case) is not None]


@dataclass(frozen=True)
class PartWriter:
    """Keeps each finished case of a study: ``writer(case, outcome)`` builds the case's
    dataset and writes it to its part, or records the error (see the module docstring).

    Attributes
    ----------
    study : the study the cases belong to.
    folder : ``OUT.parts/`` (:func:`parts_folder`).
    build : the dataset builder of the study's kind, ``(result, scene, history)``.
    history : the ``history`` attribute of every part.
    """

    study: Study
    folder: Path
    build: Builder
    history: str | None = None

    def __call__(self, case: Case, outcome: CaseOutcome) -> CaseOutcome:
        """Write the case's part (or its error record); returns the outcome as kept: a
        result whose dataset cannot be built or whose part cannot be written (no space,
        I/O error) is recorded as the case's error, and the others go on. When even the
        error record cannot be written, the error says so (``record_error``)."""
        if outcome.error is None:
            try:
                dataset = self.build(outcome.result, case.scene, self.history)
                if case.whole is not None:  # a group of a case's realisations: its sums too
                    from .realisations import add_group_variables

                    add_group_variables(dataset, outcome.result, case.scene)
                self.write_part(case, dataset)
            except Exception as exc:  # a failed case is recorded, the others go on
                outcome = CaseOutcome(error=_write_error(exc), seconds=outcome.seconds)
            else:
                return outcome
        try:
            self.write_error(case, outcome.error)
        except (OSError, HertzsweepError) as exc:
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
            error = dict(outcome.error, record_error=reason)
            outcome = CaseOutcome(error=error, seconds=outcome.seconds)
        return outcome

    def write_part(self, case: Case, dataset: Frame | xr.Dataset) -> Path:
        """Write a finished case atomically, with its grid values and hash as attributes
        (added to ``dataset``, built for this part; an older error record of the same case
        is removed)."""
        dataset.attrs.update(
            study_case_hash=case.hash,
            study_case=json.dumps(case.values, default=json_default),
            study_kind=self.study.kind,
            study_file=self.study.source,
        )
        path = write_atomic(dataset, part_path(self.folder, case))
        error_path(self.folder, case).unlink(missing_ok=True)
        return path

    def write_error(self, case: Case, error: dict[str, str]) -> Path:
        """Record a failed case: its grid values, its whole resolved config and the error
        (an older part of the same case is removed, so the output marks it failed)."""
        record = {
            "hash": case.hash,
            "study": self.study.source,
            "kind": self.study.kind,
            "grid": case.values,
            "config": case.scene.attributes(),
            "error": error,
        }
        path = error_path(self.folder, case)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(record, indent=2, default=json_default))
        part_path(self.folder, case).unlink(missing_ok=True)
        return path


def run_kind_parts(
    study: Study, cases: Sequence[Case], output: str | os.PathLike, engine: Engine, **options: Any
) -> StudyRun:
    """The study kind's driver: :func:`run_parts` with the case driver and the dataset
    builder of the study's kind (:data:`hertzsweep.core.kinds.KINDS`)."""
    case_kind = KINDS[study.kind]
    runner = case_kind.case.resolve()
    return run_parts(study, cases, output, engine, runner, case_kind.build, **options)


def run_parts(
    study: Study,
    cases: Sequence[Case],
    output: str | os.PathLike,
    engine: Engine,
    runner: Runner,
    build: Builder,
    history: str | None = None,
    resumed: Sequence[Case] = (),
    progress: Callable[[int], None] | None = None,
    stop_requested: Callable[[], int] | None = None,
) -> StudyRun:
    """Run the cases not in ``resumed`` on the engine, each to its part in
    ``OUT.parts/`` as it finishes (:func:`hertzsweep.drivers.study.run_study`).

    ``runner`` and ``build`` are the driver and the dataset builder of the study's kind;
    ``progress`` and ``stop_requested`` are passed on to the driver.
    """
    folder = parts_folder(output)
    folder.mkdir(parents=True, exist_ok=True)
    writer = PartWriter(study, folder, build, history)
    return run_study(
        cases,
        engine,
        runner,
        on_case=writer,
        skip=resumed,
        progress=progress,
        stop_requested=stop_requested,
    )


def failure_lines(run: StudyRun, folder: Path) -> list[str]:
    """One line per failed case: its grid values, the error, the record's file (or why
    the record could not be written)."""
    lines = []
    for case, error in run.failed:
        message = error["message"].splitlines()[0] if error["message"] else ""
        if "record_error" in error:
            where = f"its record could not be written: {error['record_error']}"
        else:
            where = f"config and traceback in {error_path(folder, case)}"
        lines.append(f"{case.label}: {error['type']}: {message} ({where})")
    return lines


def _write_error(exc: Exception) -> dict[str, str]:
    """The error record of a case whose dataset could not be built or written; a write
    that failed reads as the path and the OS's reason."""
    error = error_record(exc)
    if isinstance(exc, OSError) and exc.strerror:
        error["message"] = f"{exc.filename}: cannot write its part: {exc.strerror}"
    return error


# --------------------------------------------------------------------------- the dataset
def combine(
    study: Study,
    cases: Sequence[Case],
    output: str | os.PathLike,
    history: str | None = None,
    failures: Sequence[str] = (),
) -> xr.Dataset | None:
    """ONE dataset of every case's part (:func:`study_dataset`), or None when no case
    has one. The sub-cases of a case (``split_realisations``) are merged into the case's
    dataset (:func:`case_part`)."""
    folder = parts_folder(output)
    wholes = whole_cases(cases)
    parts = {whole.index: case_part(folder, whole, cases, history) for whole in wholes}
    if all(ds is None for ds in parts.values()):
        return None
    return study_dataset(study, wholes, parts, history, failures)


def case_part(
    folder: Path, whole: Case, cases: Sequence[Case], history: str | None = None
) -> xr.Dataset | None:
    """The dataset of a case: its part, or, when it ran as sub-cases, the merge of
    theirs (:func:`hertzsweep.jobs.realisations.merged_part`: bit for bit the unsplit
    case's); None when it, or one of its sub-cases, has no part."""
    groups = [case for case in cases if case.whole is whole]
    if not groups:
        return read_case_part(folder, whole)
    parts = [read_case_part(folder, case) for case in groups]
    if any(ds is None for ds in parts):
        return None
    from .realisations import merged_part

    return merged_part(whole.scene, parts, folder, history)


def varying_attributes(cases: Sequence[Case]) -> list[str]:
    """Names of the global attributes (config values and rig constants) that differ
    between cases: the study dataset leaves them out (they are its coordinates)."""

    def flat(case: Case) -> dict[str, str]:
        values = dict(case.scene.attributes())
        values.update(derive(case.scene.rig).as_dict())
        return {k: json.dumps(v, default=json_default) for k, v in values.items()}

    if not cases:
        return []
    first = flat(cases[0])
    varying = set()
    for case in cases[1:]:
        varying.update(k for k, v in flat(case).items() if first.get(k) != v)
    return sorted(varying)


def study_dataset(
    study: Study,
    cases: Sequence[Case],
    parts: Mapping[tuple[int, ...], xr.Dataset | None],
    history: str | None = None,
    failures: Sequence[str] = (),
) -> xr.Dataset:
    """ONE dataset of a study's cases, concatenated along the grid dimensions.

    Parameters
    ----------
    study : Study
        The study: its kind (that of every part) and its grid.
    cases : sequence of Case
        Every case of the study (:func:`hertzsweep.drivers.study.expand`).
    parts : mapping
        ``{case index: dataset or None}``; None (a failed case) becomes fill values
        (NaN; -1 for integers and flags; "" for strings).
    history : str, optional
        The ``history`` attribute.
    failures : sequence of str
        One line per failed case (:func:`failure_lines`), kept as ``study_failures``.

    Notes
    -----
    Dimensions: ``direction`` first (sweep studies), then the grid dims in study order,
    then the rest of the part's dims (``frequency_ratio``, ``harmonic``; ``point``, ...).
    Dims without coordinates in the parts (``point``, ``bifurcation``) are padded to the
    longest part. ``case_failed`` (grid dims) is 1 where a case failed; ``case_id`` holds
    each case's hash. The config values that vary along the grid are coordinates, not
    global attributes. A sweep study keeps the parts'
    ``jump_frequency_ratio(direction, ...grid...)``. A random study's dims are the grid's
    and the parts' ``rms``, ``frequency_ratio`` and ``force_bin``; as the bins of N/F_s are
    each run's own (they differ along a grid over ``damping.ratio``, ``excitation.band``
    or the split levels), ``force_bin`` numbers them and ``force_bin_centre(<case dims>,
    force_bin)`` holds each case's centres (:func:`_case_bins`; NaN where a case failed).
    """
    parts, per_case = _case_bins(parts)
    ds = _concatenate(study, parts).set_coords(per_case)
    for axis in study.grid:
        if axis.key != study.level_key:
            if ds[axis.dim].dtype.kind in "iu":  # the integer type of every index and count
                ds = ds.assign_coords({axis.dim: ds[axis.dim].astype(INDEX)})
            labels = ds[axis.dim].dtype.kind in "OUS"
            ds[axis.dim].attrs = _grid_attrs(axis.key, axis.dim, labels)
    _mark_cases(ds, study, cases, parts)
    steps = [int(p.attrs.get("integration_steps", 0)) for p in parts.values() if p is not None]
    scene = next(case.scene for case in cases if parts[case.index] is not None)
    title = f"Parameter study ({study.kind}) of a preloaded Hertzian contact"
    out = global_attributes(scene, title, "study", history, {"command": "study"})
    out["config_json"] = to_json(study_config(study))
    for name in varying_attributes(cases):
        out.pop(name, None)
    out.pop("scene_file", None)
    out.update(study_kind=study.kind, integration_steps=int(sum(steps)))
    ds.attrs = out
    extra = {
        "study_file": study.source,
        "study_grid": ", ".join(axis.key for axis in study.grid),
        "study_split_sigma": int(study.split_sigma),
        **({"study_split_rms": int(study.split_rms)} if study.level_key == RMS_KEY else {}),
        **(
            {"study_split_realisations": study.split_realisations}
            if study.split_realisations != 1
            else {}
        ),
        "study_cases": len(cases),
        "study_failed": len(failures),
        "study_failures": "\n".join(failures),
    }
    return merge_attributes(ds, extra)


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


def study_config(study: Study) -> dict[str, Any]:
    """``config_json`` of a study: its file's content (``kind``, ``split_sigma``, a random
    study's ``split_rms`` and, when not 1, ``split_realisations``, ``grid``) with the base
    scene resolved in place of the file it names (``scene``: the tables of
    :meth:`~hertzsweep.core.config.Scene.to_dict`, the study's inline tables and any
    overrides applied)."""
    base = scene_from_dict(copy.deepcopy(study.base), source=study.source)
    split = {"split_rms": study.split_rms} if study.level_key == RMS_KEY else {}
    if study.split_realisations != 1:
        split["split_realisations"] = study.split_realisations
    return {
        "kind": study.kind,
        "split_sigma": study.split_sigma,
        **split,
        "grid": {axis.key: list(axis.values) for axis in study.grid},
        "scene": base.to_dict(),
    }


def _grid_attrs(key: str, dim: str, labels: bool = False) -> dict[str, Any]:
    """CF attributes of a grid coordinate: from :func:`attributes` when the dimension is
    named there, else the config key itself; string values are labels, without units."""
    if dim in attributes():
        out = attrs(dim)
    else:
        out = {"long_name": f"study grid value of {key}", "units": GRID_UNITS.get(key, "1")}
    if labels:
        out.pop("units", None)
    out["config_key"] = key
    return out


def _case_bins(
    parts: Mapping[tuple[int, ...], xr.Dataset | None],
) -> tuple[dict[tuple[int, ...], xr.Dataset | None], list[str]]:
    """The parts with each coordinate of :data:`CASE_BINS` they hold made a data variable
    ``NAME_centre`` on a bare ``NAME`` dimension (the bins' numbers), so that the parts
    concatenate bin by bin rather than on the union of their centres, whichever cases
    finished; and the names so made (coordinates of the combined dataset)."""
    present = [ds for ds in parts.values() if ds is not None]
    out = dict(parts)
    made = []
    for name in CASE_BINS:
        if not all(name in ds.indexes for ds in present):
            continue
        centre = f"{name}_centre"
        for index, ds in out.items():
            if ds is not None:
                values = ds[name]
                note = "per case: each run's bins span its own range; the dimension numbers them"
                meta = {**values.attrs, "comment": note}
                out[index] = ds.drop_vars(name).assign({centre: (name, values.values, meta)})
        made.append(centre)
    return out, made


def _concatenate(study: Study, parts: Mapping[tuple[int, ...], xr.Dataset | None]) -> xr.Dataset:
    """The parts along the case dimensions (fill values for a failed case), in the
    dimension order of :func:`study_dataset`."""
    level = LEVEL_DIMS[study.level_key]  # a case dim the parts hold (split levels)
    case_dims = [axis.dim for axis in study.case_axes]
    values_of = {axis.dim: list(axis.values) for axis in study.grid}
    template = next(ds for ds in parts.values() if ds is not None)
    fills = {name: _fill_value(var.dtype) for name, var in template.variables.items()}
    present = [ds for ds in parts.values() if ds is not None]
    bare_dims = {d for ds in present for d in ds.dims if d not in ds.indexes}

    def prepared(index: tuple[int, ...]) -> xr.Dataset:
        ds = parts.get(index)
        missing = ds is None
        if missing:
            ds = template.copy(deep=True)
            for name in list(ds.data_vars):
                var = ds[name]
                ds[name] = var.copy(data=np.full(var.shape, fills[name], dtype=var.dtype))
        ds = ds.assign_coords({d: np.arange(ds.sizes[d]) for d in bare_dims if d in ds.dims})
        new = {}
        for dim, i in zip(case_dims, index, strict=True):
            value = values_of[dim][i]
            if dim != level:
                new[dim] = [value]
            elif missing:
                ds = ds.isel({level: [0]}).assign_coords({level: [value]})
        return ds.expand_dims(new) if new else ds

    shape = [len(values_of[d]) for d in case_dims]

    def nested(prefix: tuple[int, ...]) -> Any:
        if len(prefix) == len(shape):
            return prepared(prefix)
        return [nested(prefix + (i,)) for i in range(shape[len(prefix)])]

    if case_dims:
        combined = xr.combine_nested(
            nested(()),
            concat_dim=case_dims,
            data_vars="all",
            coords="different",
            compat="equals",
            join="outer",
            fill_value=fills,
            combine_attrs="override",
        )
    else:
        combined = prepared(())
    combined = combined.drop_vars([d for d in bare_dims if d in combined.coords])
    grid_dims = [axis.dim for axis in study.grid]
    order = [d for d in ("direction", *grid_dims) if d in combined.dims]
    order += [d for d in template.dims if d not in order]
    return combined.transpose(*order)


def _mark_cases(
    ds: xr.Dataset,
    study: Study,
    cases: Sequence[Case],
    parts: Mapping[tuple[int, ...], xr.Dataset | None],
) -> None:
    """Add ``case_failed`` (grid dims) and ``case_id`` (case dims); where a case failed,
    the yes/no flags of the parts gain the value -1 (missing)."""
    grid_dims = [axis.dim for axis in study.grid]
    case_dims = tuple(axis.dim for axis in study.case_axes)
    failed = xr.DataArray(
        np.zeros([len(axis.values) for axis in study.grid], dtype=np.int8),
        dims=grid_dims,
        coords={d: ds[d] for d in grid_dims},
        attrs=attrs("case_failed"),
    )
    ids = np.empty([len(axis.values) for axis in study.case_axes], dtype=object)
    for case in cases:
        ids[case.index] = case.hash
        if parts.get(case.index) is None:
            where = {
                axis.dim: axis.values[i]
                for axis, i in zip(study.case_axes, case.index, strict=True)
            }
            failed.loc[where] = 1
    failed.attrs.update(flag_values=FLAGS, flag_meanings="no yes")
    ds["case_failed"] = failed
    ds["case_id"] = (case_dims, ids, attrs("case_id"))
    if not bool(failed.any()):
        return
    for name, var in ds.data_vars.items():
        if var.attrs.get("flag_meanings") == "no yes" and name != "case_failed":
            var.attrs.update(flag_values=FLAGS_WITH_MISSING, flag_meanings="missing no yes")


__all__ = [
    "PartWriter",
    "combine",
    "error_path",
    "failure_lines",
    "part_path",
    "parts_folder",
    "case_part",
    "read_case_part",
    "read_part",
    "resumable",
    "run_parts",
    "study_config",
    "study_dataset",
    "varying_attributes",
]
