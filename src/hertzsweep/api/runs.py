"""Runs: a scene (or a study, or measurements) through its driver into the dataset its
command writes. The public verbs (:mod:`hertzsweep.api`) and the command line both call
these, so a Dataset from Python and the file of the command hold the same variables,
attributes and values, bit for bit, apart from ``history`` (the command line, or the
Python call, that made it).

A :class:`Run` keeps the driver's result beside its dataset: the command line prints the
kind's summary from both, and keeps an interrupted sweep's finished dwells from the
result it carries.

Progress: ``progress`` is ``False`` (no bar), ``True`` (the API's bar: tqdm's, or its
notebook widget in Jupyter) or :data:`TERMINAL` (the command line's: a tqdm bar on stderr
when it is a terminal).
"""

from __future__ import annotations

import datetime as _dt
import os
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from .. import __version__
from ..core.checks import check_record, require_excitation
from ..core.config import Scene
from ..core.kinds import KINDS, Kind
from ..core.model import check_stability
from .progress import progress_bar

if TYPE_CHECKING:
    import xarray as xr

    from ..drivers.study import Engine, Study

TERMINAL = "terminal"  # the command line's bar: shown only when stderr is a terminal
Progress = bool | str  # False, True or TERMINAL


def meter(
    total: int, desc: str, progress: Progress, **options: Any
) -> AbstractContextManager[Callable[[int], None] | None]:
    """The progress bar of a run (see the module's docstring)."""
    return progress_bar(total, desc, bool(progress), terminal_only=progress == TERMINAL, **options)


def kind(name: str) -> Kind:
    """The registry entry of a dataset kind (:data:`hertzsweep.core.kinds.KINDS`)."""
    return KINDS[name]


def checked(name: str, scene: Scene) -> Kind:
    """The kind ``name`` after its scene checks: the scene's excitation is the kind's
    (:func:`hertzsweep.core.checks.require_excitation`) and it passes the kind's
    preflight."""
    entry = KINDS[name]
    if entry.excitation is not None:
        require_excitation(scene, entry.excitation, entry.command)
    entry.preflight(scene)
    return entry


def python_history(call: str) -> str:
    """``history`` (CF section 2.6.2) of a dataset made from Python: the UTC time, the
    call, the working folder and the version, as the command line's
    (:func:`hertzsweep.output.dataset.history_line`) records its command."""
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    return f"{now}: python: {call} (in {os.getcwd()}; hertzsweep {__version__})"


def call_text(name: str, scene: Scene | None = None, **arguments: Any) -> str:
    """``hertzsweep.sweep('/abs/scene.toml', periods=8)``: a call as ``history`` records it
    (a scene by its source, made absolute when it names a file)."""
    parts = []
    if scene is not None:
        source = scene.source
        parts.append(repr(os.path.abspath(source) if os.path.exists(source) else source))
    parts += [f"{key}={value!r}" for key, value in arguments.items() if value is not None]
    return f"hertzsweep.{name}({', '.join(parts)})"


@dataclass
class Run:
    """A driver's result and the dataset built from it.

    Attributes
    ----------
    kind : Kind
        The dataset kind (:data:`hertzsweep.core.kinds.KINDS`).
    scene : Scene or None
        The scene it ran (None for measurements).
    result : object
        The driver's result.
    frame : Frame or xarray.Dataset
        The dataset, as the writer takes it.
    """

    kind: Kind
    scene: Scene | None
    result: Any
    frame: Any

    def dataset(self) -> xr.Dataset:
        """The :class:`xarray.Dataset` that reading the written file gives, bit for bit
        (:func:`hertzsweep.output.dataset.as_written`)."""
        from ..output.dataset import as_written

        return as_written(self.frame)

    def summary(self) -> str:
        """What the command prints about it."""
        return self.kind.summary(self.result, self.frame)

    def warning(self) -> str:
        """The warning of a sweep's or a trace's largest ball-mode figure above the
        threshold (its sigma, w and, for a sweep, direction), or "" where none is
        (:mod:`hertzsweep.core.ballmode`)."""
        import numpy as np

        from ..core.ballmode import THRESHOLD, warning_text
        from ..core.rig import derive

        result = self.result
        errors = getattr(result, "ball_mode_error", None)
        if errors is None or not np.any(errors > THRESHOLD):
            return ""
        at = np.unravel_index(np.nanargmax(errors), errors.shape)
        if len(at) == 3:  # a sweep: (direction, sigma, frequency_ratio)
            d, s, p = at
            w, after = result.frequency_ratio[p], f" ({result.directions[d]} sweep)"
        else:  # a trace: (sigma,) at its one frequency ratio
            (s,), w, after = at, result.frequency_ratio, ""
        where = f"sigma = {result.sigma[s]:g}, w = {w:g}{after}"
        return warning_text(float(errors[at]), where, derive(self.scene.rig).ball_mode_frequency)


def parse_overrides(texts: Sequence[str]) -> dict[str, Any]:
    """``--set table.key=value`` texts (TOML values) as the API's ``{key: value}``
    overrides; the last of a key wins, as when the texts are applied in order.

    Raises
    ------
    ConfigError
        A text that is not ``table.key=value``, named under ``--set``.
    """
    from ..core.config import parse_override

    return dict(parse_override(text) for text in texts)


def run_sweep(scene: Scene, progress: Progress = False, history: str | None = None) -> Run:
    """Stepped-sine sweeps of a checked scene (``hertzsweep sweep``).

    Raises
    ------
    Interrupted
        Stopped by a signal (a ``KeyboardInterrupt``); its ``partial`` holds the finished
        dwells.
    """
    from ..drivers.sweep import dwell_count

    sweep = checked("sweep", scene)
    with meter(dwell_count(scene), "sweep", progress) as bar:
        result = sweep.run(scene, bar)
    return Run(sweep, scene, result, sweep.build(result, scene, history))


def run_trace(
    scene: Scene,
    frequency_ratio: float,
    periods: int,
    branch: str,
    samples_per_period: int | None,
    progress: Progress = False,
    history: str | None = None,
    sink: Any = None,
) -> Run:
    """A settled time history at one frequency ratio (``hertzsweep trace``); ``sink``, a
    record stream the command line writes a long record into as it is integrated."""
    from ..drivers.trace import trace_count

    trace = checked("trace", scene)
    check_trace(scene, periods, samples_per_period)
    with meter(trace_count(scene, frequency_ratio, branch), "trace", progress) as bar:
        result = trace.run(
            scene,
            frequency_ratio,
            periods=periods,
            branch=branch,
            samples_per_period=samples_per_period,
            progress=bar,
            sink=sink,
        )
    return Run(trace, scene, result, trace.build(result, scene, history))


FINISHED_ATTRS = {"long_name": "that sweep ran to its end", "units": "1"}  # OUT.partial.nc's


@dataclass(frozen=True)
class Partial:
    """What an interrupted run finished: its dataset (attribute ``complete = 0``), what
    it holds (``kept``, e.g. "12 finished dwell(s), 1 whole sweep(s)") and what it is
    called in a message (``what``, "the finished dwells")."""

    dataset: Any
    kept: str
    what: str


def partial_sweep(exc: BaseException, scene: Scene) -> Partial | None:
    """The finished dwells of an interrupted sweep (those not reached NaN, ``finished``
    marking the sweeps that ran to their end); None when none finished."""
    import numpy as np

    result = getattr(exc, "partial", None)
    if result is None or not np.isfinite(result.amplitude).any():
        return None
    ds = kind("sweep").build(result, scene)
    ds["finished"] = (("direction", "sigma"), result.finished.astype(np.int8), FINISHED_ATTRS)
    ds.attrs["complete"] = 0
    dwells = int(np.isfinite(result.amplitude[..., 0]).sum())
    kept = f"{dwells} finished dwell(s), {int(result.finished.sum())} whole sweep(s),"
    return Partial(ds, kept, "the finished dwells")


def run_random(scene: Scene, progress: Progress = False, history: str | None = None) -> Run:
    """Random excitation (``hertzsweep random``): every level's realisations in lockstep,
    the spectra, statistics and contact-loss figures of N/F_s.

    Raises
    ------
    Interrupted
        Stopped by a signal (a ``KeyboardInterrupt``); ``exc.partial`` holds the
        statistics of the segments finished.
    """
    from ..drivers.random import step_count

    random = checked("random", scene)
    with meter(step_count(scene), "random", progress, unit="step") as bar:
        result = random.run(scene, bar)
    return Run(random, scene, result, random.build(result, scene, history))


def partial_random(exc: BaseException, scene: Scene) -> Partial | None:
    """The statistics of the segments an interrupted random run finished; None when no
    measured segment finished."""
    result = getattr(exc, "partial", None)
    if result is None or not result.segments:
        return None
    ds = kind("random").build(result, scene)
    ds.attrs["complete"] = 0
    kept = f"{int(result.segments)} finished segment(s) of every realisation"
    return Partial(ds, kept, "the finished segments")


def check_trace(
    scene: Scene, periods: int, samples_per_period: int | None, source: str = "trace"
) -> bool:
    """Check a trace's record against the budgets; whether the command line streams it to
    its file (:func:`hertzsweep.core.checks.check_record`)."""
    return check_record(scene, periods, samples_per_period, source=source)


def run_branch(scene: Scene, progress: Progress = False, history: str | None = None) -> Run:
    """Periodic orbits by shooting and continuation (``hertzsweep branch``)."""
    from ..drivers.continuation import progress_total

    branch = checked("branch", scene)
    with meter(progress_total(scene), "branch", progress, unit="%") as bar:
        result = branch.run(scene, bar)
    return Run(branch, scene, result, branch.build(result, scene, history))


def check_accuracy(scene: Scene) -> None:
    """The checks of an accuracy run: the scene's, and its own setting stable."""
    checked("accuracy", scene)
    check_stability(scene)


def accuracy_ladder(
    scene: Scene,
    steps: Sequence[int] | str | None = None,
    settle: Sequence[Any] | str | None = None,
    methods: Sequence[str] | str | None = None,
    quick: bool = False,
) -> Any:
    """The ladder of settings ``hertzsweep accuracy`` measures: each of ``steps``,
    ``settle`` and ``methods`` as the command's option text (``"64,128"``) or a sequence."""
    from ..drivers.accuracy import build_ladder, parse_methods, parse_settle_list, parse_steps

    def text(value: Any) -> str | None:
        if value is None or isinstance(value, str):
            return value
        return ",".join(str(item) for item in value)

    steps, settle, methods = text(steps), text(settle), text(methods)
    return build_ladder(
        scene,
        parse_steps(steps) if steps is not None else None,
        parse_settle_list(settle) if settle is not None else None,
        quick,
        methods=parse_methods(methods) if methods is not None else None,
    )


def run_accuracy(
    scene: Scene,
    ladder: Any,
    target: float | None = None,
    progress: Progress = False,
    history: str | None = None,
    scene_arguments: str = "",
) -> Run:
    """Error against cost over a ladder of solver settings (``hertzsweep accuracy``);
    ``scene_arguments``, how the report's reproduction line names the scene."""
    check_accuracy(scene)
    accuracy = kind("accuracy")
    with meter(len(ladder.settings), "accuracy", progress, unit="setting") as bar:
        report = accuracy.run(scene, ladder, target, bar)
    report.scene_arguments = scene_arguments
    return Run(accuracy, scene, report, accuracy.build(report, scene, history))


STUDY_SMOOTHING = 0.1  # a study's cases take seconds to minutes each: an ETA over many


@dataclass
class StudyOutcome:
    """A study that ran: the engine's record of its cases (``run.stopped_by``: the signal
    that stopped it, 0 if none), the cases, the ONE combined dataset (None when stopped
    or when no case finished) and one line per failed case."""

    run: Any
    cases: list[Any]
    dataset: Any
    failures: list[str]

    def summary(self) -> str:
        """The study kind's table (empty when there is no dataset)."""
        if self.dataset is None:
            return ""
        return kind("study").summary(self.run, self.dataset)


def run_study(
    study: Study,
    output: str | os.PathLike,
    engine: Engine,
    progress: Progress = False,
    history: str | None = None,
    resume: bool = False,
    stop_requested: Callable[[], int] | None = None,
) -> StudyOutcome:
    """A study's cases on an engine into their parts beside ``output`` (``OUT.parts/``),
    then the ONE dataset combined from them; ``resume`` skips the cases whose part is
    there and readable, ``stop_requested`` (a callable returning a signal number, 0 while
    none) ends the run early, the finished parts kept."""
    from ..drivers.study import case_unit, expand
    from ..jobs.study import failure_lines, resumable
    from ..output.paths import parts_folder

    cases = expand(study)
    study_kind = kind("study")
    history = history or python_history("hertzsweep.study()")
    resumed = resumable(cases, output) if resume else []
    unit = case_unit(cases)
    bar = meter(
        len(cases), "study", progress, unit=unit, initial=len(resumed), smoothing=STUDY_SMOOTHING
    )
    with bar as update:
        run = study_kind.run(
            study,
            cases,
            output,
            engine,
            history=history,
            resumed=resumed,
            progress=update,
            stop_requested=stop_requested,
        )
    failures = failure_lines(run, parts_folder(output))
    if run.stopped_by:
        return StudyOutcome(run, cases, None, failures)
    return StudyOutcome(
        run, cases, study_kind.build(study, cases, output, history, failures), failures
    )


def load_study(path: str | os.PathLike) -> Study:
    """A study file, it and every case checked before any worker starts.

    Raises
    ------
    ConfigError
        A bad study file, key or value, or a case's scene refused.
    """
    from ..drivers.study import CASE_KINDS
    from ..drivers.study import load_study as load

    return load(os.fspath(path), CASE_KINDS)


def study_inputs(study_file: str | os.PathLike) -> tuple[str, ...]:
    """The files a study reads: the study file, the scene file it names and their rig
    files (an output must be none of them)."""
    from pathlib import Path

    from ..core.config import read_scene_files, read_toml

    files = read_scene_files(study_file)[1]
    scene = read_toml(study_file).get("scene")
    if isinstance(scene, str):
        files += read_scene_files(Path(study_file).parent / scene)[1]
    return files


def counted_cases(cases: Any) -> str:
    """``N cases``, or ``N sub-cases`` when a study's cases run as sub-cases
    (``split_realisations``): what its progress and an interruption count."""
    from ..drivers.study import case_unit

    return f"{len(cases)} {case_unit(cases)}s"


def cases_summary(run: Any) -> str:
    """``N cases: F finished, ...``: the line a study ends with."""
    from ..drivers.study import cases_summary as summary

    return summary(run)


def check_engine(workers: int | None, scheduler: str | None) -> None:
    """Refuse both ``workers`` and ``scheduler``, or an empty address.

    Raises
    ------
    HertzsweepError
    """
    from ..errors import HertzsweepError

    if workers is not None and scheduler is not None:
        raise HertzsweepError("--workers and --scheduler exclude each other")
    if scheduler is not None and not str(scheduler).strip():
        raise HertzsweepError("--scheduler: empty address (give tcp://HOST:PORT)")


def engine_for(workers: int | None = None, scheduler: str | None = None) -> Engine:
    """The engine a study runs on: a Dask cluster at ``scheduler``, else a local pool of
    ``workers`` processes (default: the number of cores).

    Raises
    ------
    HertzsweepError
        Both given, or an empty address.
    """
    from ..drivers.study import DaskCluster, LocalPool

    check_engine(workers, scheduler)
    return DaskCluster(str(scheduler)) if scheduler else LocalPool(workers)


def run_import(path: str | os.PathLike, options: Any = None, history: str | None = None) -> Run:
    """Measurements of a file (hertzsweep's CSV, UFF 58/58b, a lock-in table) into a
    ``measured`` dataset (``hertzsweep import``); ``options``, an
    :class:`~hertzsweep.io.import_options.ImportOptions`."""
    measured = kind("measured")
    data = measured.run(os.fspath(path), options)
    return Run(measured, None, data, measured.build(data, None, history))


DATASET_SUFFIXES = (".nc", ".nc4", ".cdf")  # measurements read as a dataset; else as CSV


def read_measurements(measured: Any) -> tuple[Any, str]:
    """The measurements of a measured dataset's file (by the suffix), of any measurement
    file :func:`hertzsweep.io.formats.read_any` reads (its levels in the file), or of a
    measured :class:`xarray.Dataset`; and their name (the file, absolute)."""
    from pathlib import Path

    from ..io.formats import read_any
    from ..io.measured import measurements_from_dataset

    if not isinstance(measured, str | os.PathLike):
        return measurements_from_dataset(measured, "<dataset>"), "<dataset>"
    path = os.fspath(measured)
    if Path(path).suffix.lower() in DATASET_SUFFIXES:
        from .files import read_dataset

        return measurements_from_dataset(read_dataset(path), path), str(Path(path).resolve())
    return read_any(path), str(Path(path).resolve())


class _Meter:
    """A progress callback that stops short of the bar's end until the fit is done (the
    number of model evaluations is known only then)."""

    def __init__(self, update: Callable[[int], None] | None, total: int) -> None:
        self.update, self.total, self.done = update, total, 0

    def __call__(self, count: int) -> None:
        step = min(count, self.total - 1 - self.done)
        if self.update is not None and step > 0:
            self.update(step)
            self.done += step


def run_fit(
    measured: Any,
    scene: Scene,
    free: Sequence[str],
    method: str = "auto",
    compare_laws: bool = False,
    progress: Progress = False,
    history: str | None = None,
) -> Run:
    """The model's parameters identified from measurements (``hertzsweep fit``)."""
    from ..drivers.fit import expected_evaluations

    fit = checked("fit", scene)
    data, name = read_measurements(measured)
    free = [key.strip() for key in free if key.strip()]
    total = expected_evaluations(len(free), compare_laws)
    with meter(total, "fit", progress, unit="evaluation") as bar:
        counter = _Meter(bar, total)
        result = fit.run(scene, data, free, method, counter, compare_laws)
        if bar is not None:
            bar(total - counter.done)  # the bar's end: the fit is done
    command = {
        "command": "fit",
        "measured": name,
        "free": list(result.keys),
        "method": method,
        "compare_laws": compare_laws,
    }
    return Run(fit, scene, result, fit.build(result, scene, history, command=command))


if TYPE_CHECKING:
    pass


def fit_json(result: Any, output: str) -> dict[str, Any]:
    """``hertzsweep fit --json``'s object (:func:`hertzsweep.io.measured.fit_json`)."""
    from ..io.measured import fit_json as as_json

    return as_json(result, output)


def parse_variable_tolerances(texts: Sequence[str]) -> dict[str, tuple[float, float | None]]:
    """``--var NAME=RTOL[,ATOL]`` texts as :func:`hertzsweep.api.compare`'s
    ``variables``."""
    from ..output.compare import parse_variable_tolerance

    return dict(parse_variable_tolerance(text) for text in texts)


def rig_constants(
    scene: Scene | str | os.PathLike, rig: tuple[Any, str] | None = None
) -> dict[str, float]:
    """The rig's derived constants, and a scene's stability limit and margin
    (:func:`hertzsweep.api.rig`); ``rig``, the ``(rig, source)`` of a file already read."""
    from ..core.checks import check_rig, load_checked_scene, rig_source
    from ..core.config import read_rig, read_toml
    from ..core.model import stability_limit

    if not isinstance(scene, Scene):
        path = os.fspath(scene)
        rig_config, source = rig or read_rig(path)
        constants = check_rig(rig_config, source).as_dict()
        if set(read_toml(path)) == {"rig"}:
            return constants
        scene = load_checked_scene(path)[0]
    else:
        constants = check_rig(scene.rig, rig_source(scene)).as_dict()
    limit = stability_limit(scene)
    constants["stability_limit_steps_per_period"] = limit
    constants["stability_margin"] = scene.solver.steps_per_period / limit
    return constants


def rig_report(path: str | os.PathLike) -> tuple[dict[str, float], bool]:
    """``hertzsweep rig``'s constants of a rig or scene file (:func:`rig_constants`), and
    whether the rig gives a measured f0 (``natural_frequency`` is the rig's own then)."""
    from ..core.config import read_rig

    rig, source = read_rig(path)
    return rig_constants(path, (rig, source)), rig.natural_frequency is not None


def validate(path: str | os.PathLike, overrides: Mapping[str, Any]) -> tuple[Scene, Any]:
    """``hertzsweep validate``: the checked scene of a file and its figures (points,
    steps, memory, stability margin: :class:`hertzsweep.core.checks.Figures`)."""
    from ..core.checks import load_checked_scene

    return load_checked_scene(path, overrides)


def paper(
    config_dir: str | os.PathLike, out_dir: str | os.PathLike, quick: bool, echo: Any
) -> None:
    """The paper's figures and validation table (``hertzsweep paper``,
    :func:`hertzsweep.jobs.paper.run_paper`), each step's line given to ``echo``."""
    from ..jobs.paper import run_paper

    run_paper(config_dir, out_dir, quick, echo=echo)


def bench(quick: bool = False) -> dict[str, Any]:
    """The project's speed figures (``hertzsweep bench``, :mod:`hertzsweep.drivers.bench`)."""
    from ..drivers.bench import run_all

    return run_all(quick=quick)


def import_options(rig: str | os.PathLike | None = None, **values: Any) -> Any:
    """The :class:`~hertzsweep.io.import_options.ImportOptions` of the given values (None:
    not given); ``rig``, a rig or scene file whose moving mass converts a UFF
    accelerance, mobility or receptance."""
    from ..io.import_options import ImportOptions

    given = {key: value for key, value in values.items() if value is not None}
    if rig is not None:
        from ..core.config import read_rig
        from ..core.rig import derive

        rig_config = read_rig(rig)[0]
        given.setdefault("moving_mass", rig_config.mass)
        given.setdefault("static_load", derive(rig_config).static_load)
    return ImportOptions(**given)


EXPORT_FORMATS = ("uff58b", "uff58", "csv", "lockin-csv")  # hertzsweep export --format


def export(
    ds: Any,
    path: str | os.PathLike,
    format: str = "uff58b",
    sensitivity: float | None = None,
    static_load: float | None = None,
) -> Any:
    """Write a sweep, measured or fit dataset in a measurement format (``hertzsweep
    export``): UFF 58b or 58 (:func:`hertzsweep.io.uff.export_uff`), hertzsweep's
    measurement CSV or a lock-in-style CSV in volts RMS
    (:mod:`hertzsweep.io.lockin_table`); returns the report of the points written
    and left out.

    Raises
    ------
    HertzsweepError
        An unknown format, a dataset of another kind, a lock-in CSV without a sensitivity.
    """
    from ..core.kinds import EXPORT_KINDS, kind_named, names
    from ..errors import HertzsweepError

    if format not in EXPORT_FORMATS:
        known = ", ".join(EXPORT_FORMATS)
        raise HertzsweepError(f"--format: expected one of {known}, got {format!r}")
    name = kind_named(ds.attrs.get("hertzsweep_kind")).name
    if name not in EXPORT_KINDS:
        raise HertzsweepError(f"cannot export a {name} dataset ({names(EXPORT_KINDS)} only)")
    if format in ("uff58b", "uff58"):
        from ..io.uff import export_uff

        return export_uff(ds, path, binary=format == "uff58b")
    from ..io import lockin_table

    if format == "csv":
        return lockin_table.write_measurement_csv(ds, path)
    if sensitivity is None:
        raise HertzsweepError("--sensitivity: a lock-in CSV is in volts: give the V/N")
    return lockin_table.write_lockin_csv(ds, path, sensitivity, static_load)


def read_option_file(path: str | os.PathLike, keys: Sequence[str]) -> dict[str, Any]:
    """The options of a small TOML file (``import --map``): its ``[columns]`` table and
    the option keys named in ``keys`` (as the options' names with underscores).

    Raises
    ------
    ConfigError
        Not TOML, a key that is no option, or columns that are not a table of strings.
    """
    from ..core.config import read_toml
    from ..errors import ConfigError

    raw = read_toml(path)
    for key in raw:
        if key not in keys:
            raise ConfigError(str(path), key, f"unknown key (known: {', '.join(keys)})")
    columns = raw.get("columns", {})
    if not isinstance(columns, dict) or not all(isinstance(v, str) for v in columns.values()):
        raise ConfigError(str(path), "columns", 'expected a table of QUANTITY = "COLUMN"')
    return raw
