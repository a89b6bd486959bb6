"""hertzsweep's Python API: scenes in, :class:`xarray.Dataset` out.

Every verb returns what its command writes: ``hs.sweep(scene)`` is the Dataset of
``hertzsweep sweep SCENE -o OUT.nc``, with the same variables, attributes and values,
bit for bit, apart from ``history``, which records the Python call instead of the
command line. The command line is a thin layer on these functions: it parses its
options, calls them (through :mod:`hertzsweep.api.runs`) and writes what they return.

What the API never does: call :func:`sys.exit`, print to standard output, or install
signal handlers. A bad scene, key, value or file raises the typed exception of
:mod:`hertzsweep.errors` with the message the command line prints after
``hertzsweep: error:``. Ctrl-C raises :class:`KeyboardInterrupt` once the compiled call
in flight returns (a dwell of a sweep, a few milliseconds to a second); an interrupted
sweep's :class:`~hertzsweep.errors.Interrupted` carries the dwells it finished
(``exc.partial``).

Examples
--------
>>> import hertzsweep as hs
>>> scene = hs.load_scene("configs/smoke.toml", overrides={"excitation.sigma": [0.01]})
>>> ds = hs.sweep(scene)                                  # doctest: +SKIP
>>> fig = hs.plot(ds)                                     # doctest: +SKIP
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .. import _API as PUBLIC_API
from ..core.config import Scene
from ..errors import HertzsweepError
from . import runs
from .runs import call_text, python_history

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

    from ..drivers.study import Study
    from ..output.compare import Report


# --------------------------------------------------------------------------- scenes
def load_scene(path: str | os.PathLike, overrides: Mapping[str, Any] | None = None) -> Scene:
    """Read and check a scene file, as every command that runs one does.

    Parameters
    ----------
    path : path
        A scene file (TOML). Its ``rig = "file.toml"`` is relative to the scene file.
    overrides : mapping, optional
        Dotted keys and their values, e.g. ``{"excitation.sigma": [0.01]}``: the meaning
        of the command line's ``--set excitation.sigma=[0.01]``.

    Returns
    -------
    Scene
        The resolved scene (frozen; :meth:`Scene.with_overrides` gives changed copies).

    Raises
    ------
    ConfigError
        A file, table, key or value is wrong, or the run it describes is refused
        (budgets, stability): the command line's message, naming the file and the key
        (``--set`` for an override).
    """
    from ..core.checks import load_checked_scene

    return load_checked_scene(os.fspath(path), overrides or {})[0]


def example_scene(name: str = "default", overrides: Mapping[str, Any] | None = None) -> Scene:
    """A scene shipped with the package: ``"default"`` (the paper's Figures 4 and 5) or
    ``"smoke"`` (the same on a reduced grid, a few seconds).

    Raises
    ------
    HertzsweepError
        No example of that name.
    """
    from ..core.examples import example_path

    return load_scene(example_path(name), overrides)


def example_path(name: str = "default") -> Path:
    """The file of a scene shipped with the package (see :func:`example_scene`)."""
    from ..core.examples import example_path as path

    return path(name)


def rig(scene: Scene | str | os.PathLike) -> dict[str, float]:
    """The rig's derived constants (eq. 2, 3, 12, 15): what ``hertzsweep rig --json``
    prints, units as in the reference (N/m^1.5 is not used: k in N/m, z_s in m, f0 in Hz).

    Parameters
    ----------
    scene : Scene or path
        A scene, or a rig or scene file. A scene also gives its stability limit
        (``stability_limit_steps_per_period``) and margin.
    """
    return runs.rig_constants(scene)


# --------------------------------------------------------------------------- runs
def sweep(scene: Scene, *, progress: bool = False) -> xr.Dataset:
    """Stepped-sine sweeps, up and/or down, for every sigma (``hertzsweep sweep``).

    Parameters
    ----------
    scene : Scene
    progress : bool
        Show a progress bar (tqdm's; its notebook widget in Jupyter).

    Returns
    -------
    xarray.Dataset
        Of kind ``sweep``: the harmonics of N/F_s on (direction, sigma,
        frequency_ratio, harmonic), the jumps, force extremes and flights.

    Raises
    ------
    ConfigError
        The scene's run is refused (budgets, stability).
    Interrupted
        Ctrl-C (a :class:`KeyboardInterrupt`); ``exc.partial`` holds the finished dwells.
    """
    history = python_history(call_text("sweep", scene))
    return runs.run_sweep(scene, progress, history).dataset()


def random(scene: Scene, *, progress: bool = False) -> xr.Dataset:
    """Random excitation of a scene with ``[excitation] kind = "random"`` (``hertzsweep
    random``): Gaussian band-limited forcing at each RMS level, its realisations in
    lockstep; the PSD of N/F_s, the FRF estimate and coherence, the moments, PDF, extremes
    and contact-loss figures of N/F_s, each statistic with its standard error across
    realisations.

    Returns
    -------
    xarray.Dataset
        Of kind ``random``, on ``rms`` (and ``frequency_ratio``, ``force_bin``).

    Raises
    ------
    ConfigError
        A scene that is not random, or whose run is refused (budgets, stability).
    Interrupted
        Ctrl-C (a :class:`KeyboardInterrupt`); ``exc.partial`` holds the finished segments.
    """
    history = python_history(call_text("random", scene))
    return runs.run_random(scene, progress, history).dataset()


def trace(
    scene: Scene,
    frequency_ratio: float,
    *,
    periods: int | None = None,
    branch: str = "upper",
    samples_per_period: int | None = None,
    progress: bool = False,
) -> xr.Dataset:
    """The settled time history at one frequency ratio, its spectrum and its flights
    (``hertzsweep trace``).

    Parameters
    ----------
    scene : Scene
    frequency_ratio : float
        w = f/f0 to record at.
    periods : int, optional
        Whole excitation periods to record (default 8).
    branch : {"upper", "lower"}
        Reach w as a down sweep from ``sweep.stop`` (upper) or an up sweep from
        ``sweep.start`` (lower).
    samples_per_period : int, optional
        Samples kept per period, a divisor of ``solver.steps_per_period`` (default:
        every step).
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        Of kind ``trace``.
    """
    from ..drivers.trace import BRANCHES, DEFAULT_PERIODS

    if branch not in BRANCHES:
        raise HertzsweepError(f"branch: expected one of {', '.join(BRANCHES)}, got {branch!r}")
    periods = DEFAULT_PERIODS if periods is None else periods
    call = call_text(
        "trace",
        scene,
        frequency_ratio=frequency_ratio,
        periods=periods,
        branch=branch,
        samples_per_period=samples_per_period,
    )
    run = runs.run_trace(
        scene,
        float(frequency_ratio),
        periods,
        branch,
        samples_per_period,
        progress,
        python_history(call),
    )
    return run.dataset()


def branch(
    scene: Scene, *, follow_period_doubling: bool | None = None, progress: bool = False
) -> xr.Dataset:
    """Periodic orbits by shooting with arclength continuation across the sweep's span,
    for every sigma: stability (Floquet multipliers), folds, period doublings and
    Neimark-Sacker points (``hertzsweep branch``).

    Parameters
    ----------
    scene : Scene
    follow_period_doubling : bool, optional
        Also continue the period-doubled branches from every period-doubling point,
        recursively down to period 8 (``hertzsweep branch --follow-pd``; default: the
        scene's ``[branch] follow_period_doubling``).
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        Of kind ``branch``; with period-doubled branches, a ``branch`` dimension.
    """
    history = python_history(
        call_text("branch", scene, follow_period_doubling=follow_period_doubling)
    )
    if follow_period_doubling is not None:
        scene = scene.with_overrides({"branch.follow_period_doubling": follow_period_doubling})
    return runs.run_branch(scene, progress, history).dataset()


def accuracy(
    scene: Scene,
    target: float | None = None,
    *,
    steps: Sequence[int] | None = None,
    settle: Sequence[int | str] | None = None,
    methods: Sequence[str] | None = None,
    quick: bool = False,
    progress: bool = False,
) -> xr.Dataset:
    """Error against cost for the solver settings of a scene (``hertzsweep accuracy``).

    Parameters
    ----------
    scene : Scene
    target : float, optional
        Recommend the fastest setting whose H1 error (relative to the largest H1) is at
        most this.
    steps, settle, methods : sequence, optional
        The ladder's rungs, as the command's ``--steps``, ``--settle`` (periods,
        ``"auto"`` or ``"auto:TOL"``) and ``--methods``.
    quick : bool
        Fewer rungs.
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        Of kind ``accuracy`` (its ``wall_time`` is a measurement of this machine).
    """
    if target is not None and not float(target) > 0:
        raise HertzsweepError(f"--target: must be positive, got {target!r}")
    ladder = runs.accuracy_ladder(scene, steps, settle, methods, quick)
    call = call_text("accuracy", scene, target=target)
    arguments = repr(os.path.abspath(scene.source) if os.path.exists(scene.source) else "")
    run = runs.run_accuracy(
        scene, ladder, target, progress, python_history(call), scene_arguments=arguments
    )
    return run.dataset()


def study(
    study_or_path: Study | str | os.PathLike,
    workers: int | None = None,
    scheduler: str | None = None,
    *,
    parts: str | os.PathLike | None = None,
    progress: bool = False,
) -> xr.Dataset:
    """A grid of scenes in parallel, combined into ONE dataset with the grid's keys as
    dimensions (``hertzsweep study``).

    Parameters
    ----------
    study_or_path : path or Study
        A study file (TOML: ``kind``, ``scene`` and ``[grid]``).
    workers : int, optional
        Local worker processes (default: the number of cores).
    scheduler : str, optional
        The address of a running Dask scheduler (``tcp://HOST:8786``, or a
        ``LocalCluster``'s ``scheduler_address``) to run on instead.
    parts : path, optional
        A folder to keep each finished case in (``PARTS/study.nc.parts/``, as the command
        keeps them in ``OUT.parts/``): a second call with the same folder runs only the
        cases not yet there. Default: a temporary folder, removed on return.
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        Of kind ``study``. Cases that failed are marked ``case_failed = 1`` and named in
        one warning (:class:`RuntimeWarning`).

    Raises
    ------
    Failed
        Every case failed.
    """
    import tempfile
    import warnings

    from ..errors import Failed

    study_file = None
    if isinstance(study_or_path, str | os.PathLike):
        study_file = os.fspath(study_or_path)
        study_or_path = runs.load_study(study_file)
    history = python_history(call_text("study", None, path=study_file, workers=workers))
    engine = runs.engine_for(workers, scheduler)
    with tempfile.TemporaryDirectory(prefix="hertzsweep-study-") as scratch:
        output = Path(parts if parts is not None else scratch) / "study.nc"
        output.parent.mkdir(parents=True, exist_ok=True)
        try:
            outcome = runs.run_study(
                study_or_path, output, engine, progress, history, resume=parts is not None
            )
        finally:
            engine.close()
    failures, count = outcome.failures, len(outcome.cases)
    if outcome.dataset is None:
        raise Failed(f"{len(failures)} of {count} cases failed: {'; '.join(failures)}")
    if failures:
        warnings.warn("; ".join(f"case failed: {line}" for line in failures), RuntimeWarning, 2)
    from ..output.dataset import as_written

    return as_written(outcome.dataset)


# --------------------------------------------------------------------------- measurements
def import_measurements(
    path: str | os.PathLike,
    *,
    columns: Mapping[str, str] | None = None,
    preset: str | None = None,
    rms: bool | None = None,
    phase_convention: str | None = None,
    phase_unit: str | None = None,
    sensitivity: float | None = None,
    static_load: float | None = None,
    sigma: float | None = None,
    force_amplitude: float | None = None,
    direction: str | None = None,
    moving_mass: float | None = None,
    rig: str | os.PathLike | None = None,
) -> xr.Dataset:
    """Measurements into a dataset of kind ``measured`` (``hertzsweep import``). The kind
    of file is found from its content:

    - hertzsweep's CSV: sweeps (``direction,sigma,frequency,amplitude,phase[,harmonic]``,
      peak A_k of N/F_s and phi_k in the SPEC's convention) or jump frequencies
      (``direction,sigma,jump_frequency``);
    - UFF 58 or 58b: ``func_type`` 4 is H1 = N1/F1, ``func_type`` 0 with ``func_id`` k
      harmonic k; an accelerance, mobility or receptance is converted with the rig's
      moving mass (``rig``);
    - a lock-in table (CSV or JSON rows): ``columns`` maps ``frequency``, ``x`` and
      ``y`` (or ``r`` and ``phase``), optionally ``harmonic``, ``direction`` and
      ``sigma``, to the file's columns, or ``preset`` (``"labone-sweeper"``, ``"sr8xx"``)
      names an instrument's.

    Parameters
    ----------
    path : path
    columns, preset : optional
        A lock-in table's columns (see above).
    rms : bool, optional
        A lock-in's values are RMS (default) or, False, peak.
    phase_convention : {"lock-in", "spec"}, optional
        The phase column is the instrument's lead theta (default: phi_k = -theta) or the
        SPEC's lag phi_k.
    phase_unit : {"deg", "rad"}, optional
    sensitivity : float, optional
        [V/N] of the force transducer: volts become newtons.
    static_load : float, optional
        [N] F_s: newtons become N/F_s (default: the rig's, with ``rig``).
    sigma, force_amplitude : float, optional
        The level of a file that holds none: F/F_s, or [N] with ``static_load``.
    direction : {"up", "down"}, optional
        Of a file of one sweep without a direction (default: by its frequencies' order).
    moving_mass : float, optional
        [kg] the rig's moving mass m, for a UFF accelerance, mobility or receptance
        (default: the rig's, with ``rig``).
    rig : path, optional
        A rig or scene file: its moving mass and static load.

    Raises
    ------
    MeasurementError
        A bad file or option: the message names the file, the line (or UFF set) and the
        column (or key or option).
    """
    options = runs.import_options(
        rig,
        columns=dict(columns) if columns else None,
        preset=preset,
        rms=rms,
        phase_convention=phase_convention,
        phase_unit=phase_unit,
        sensitivity=sensitivity,
        static_load=static_load,
        sigma=sigma,
        force_amplitude=force_amplitude,
        direction=direction,
        moving_mass=moving_mass,
    )
    history = python_history(call_text("import_measurements", None, path=os.fspath(path)))
    return runs.run_import(path, options, history).dataset()


def export(
    ds: xr.Dataset | str | os.PathLike,
    path: str | os.PathLike,
    format: str = "uff58b",
    *,
    sensitivity: float | None = None,
    static_load: float | None = None,
) -> str:
    """Write a sweep, measured or fit dataset in a format rigs read (``hertzsweep
    export``): ``"uff58b"`` (binary Universal File Format 58, with 151 and 164 headers),
    ``"uff58"`` (its ASCII form), ``"csv"`` (hertzsweep's measurement CSV, which
    :func:`import_measurements` reads back) or ``"lockin-csv"`` (X and Y in volts RMS of
    a transducer of ``sensitivity`` V/N, F_s the dataset's unless ``static_load``).

    H1 goes out as an FRF (UFF ``func_type`` 4) of the transmitted force over the
    excitation force, ``N1/F1 = A_1 exp(-i phi_1) / sigma``; higher harmonics as
    ``func_type`` 0 with the order in ``func_id``; the direction in ``ver_num``, sigma in
    ``z_axis_value``. Points not settled, not periodic or not measured are left out.

    Returns
    -------
    str
        One line: what was written and how many points were left out.
    """
    report = runs.export(_dataset(ds), path, format, sensitivity, static_load)
    return report.line()


def fit(
    measured: xr.Dataset | str | os.PathLike,
    scene: Scene,
    free: Sequence[str],
    *,
    method: str = "auto",
    compare_laws: bool = False,
    progress: bool = False,
) -> xr.Dataset:
    """Fit ``rig.natural_frequency``, ``damping.ratio`` and/or ``damping.exponent`` to
    measurements by least squares (``hertzsweep fit``).

    Parameters
    ----------
    measured : xarray.Dataset or path
        A ``measured`` dataset (:func:`import_measurements`), its file, or a CSV file.
    scene : Scene
        The rig, damping law and solver; its values start the search.
    free : sequence of str
        The parameters to fit.
    method : {"auto", "linear", "shooting", "fold"}
        How the model is evaluated (``auto`` picks by the data).
    compare_laws : bool
        Also fit with the contact law's exponent fixed at 0, 1/2, 1, 3/2 and free.
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        Of kind ``fit``: the estimates, their standard errors and correlations, the data
        and the fitted model at every measured point.
    """
    from ..drivers.fit import METHODS

    if method not in METHODS:
        raise HertzsweepError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if isinstance(free, str):
        free = free.split(",")
    history = python_history(call_text("fit", scene, free=list(free), method=method))
    return runs.run_fit(measured, scene, free, method, compare_laws, progress, history).dataset()


# --------------------------------------------------------------------------- datasets
def open_dataset(path: str | os.PathLike) -> xr.Dataset:
    """Read any hertzsweep file (fully into memory; the file is closed on return).

    Raises
    ------
    FileNotFoundError
        No such file.
    HertzsweepError
        The file is not netCDF.
    """
    from .files import read_dataset

    return read_dataset(path)


def save(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write a dataset as the commands write theirs: through a temporary file renamed
    into place, so the file is complete or absent. Returns the path written."""
    from ..output.dataset import write_atomic

    return write_atomic(ds, path)


SUMMARISED = ("sweep", "trace", "study")  # the kinds whose printed table a dataset holds


def summary(ds: xr.Dataset) -> str:
    """The table the command that made a dataset prints: per direction and sigma, a
    sweep's H1 peak, jump, force extremes and contact loss; per sigma, a trace's
    harmonics, forces and flights; a sweep study's jumps at every grid point.

    Raises
    ------
    HertzsweepError
        A dataset of another kind (a branch's, an accuracy run's or a fit's table is
        made from its run, which the dataset does not keep: read its variables).
    """
    from ..output.figures import kind_of

    kind = kind_of(ds)
    if kind.name not in SUMMARISED:
        raise HertzsweepError(
            f"summary: {kind.name} datasets have no summary here (kinds: {', '.join(SUMMARISED)})"
        )
    return kind.summary(None, ds)


@dataclass(frozen=True)
class Comparison:
    """The outcome of :func:`compare`.

    Attributes
    ----------
    ok : bool
        Every variable within tolerance, the coordinates equal.
    worst : dict or None
        The worst point of the first variable outside tolerance: ``variable``,
        ``coords``, ``run``, ``reference``, ``difference``, ``tolerance``; None when ok.
    text : str
        The report ``hertzsweep compare`` prints.
    report : Report
        Every variable's result (:class:`hertzsweep.output.compare.Report`; ``as_dict()``
        is the ``--json`` form).
    """

    ok: bool
    worst: dict[str, Any] | None
    text: str
    report: Report

    def __str__(self) -> str:
        return self.text


def compare(
    run: xr.Dataset | str | os.PathLike,
    reference: xr.Dataset | str | os.PathLike,
    rtol: float | None = None,
    atol: float | None = None,
    variables: Mapping[str, tuple[float, float | None]] | None = None,
) -> Comparison:
    """A run against a reference dataset (``hertzsweep compare``).

    Parameters
    ----------
    run, reference : xarray.Dataset or path
    rtol, atol : float, optional
        Tolerance of the variables compared relatively (amplitudes, forces, times;
        default 1e-6 and 1e-10 in units of F_s).
    variables : mapping, optional
        Per variable ``(rtol, atol)``, as ``--var NAME=RTOL[,ATOL]`` (atol None keeps
        its default).

    Raises
    ------
    HertzsweepError
        Datasets of different kinds, an unknown variable, a bad tolerance.
    """
    from ..output.compare import compare as compare_datasets

    names = tuple(_name(x, default) for x, default in ((run, "run"), (reference, "reference")))
    run, reference = (
        open_dataset(x) if isinstance(x, str | os.PathLike) else x for x in (run, reference)
    )
    report = compare_datasets(
        run, reference, rtol=rtol, atol=atol, variables=dict(variables or {}), names=names
    )
    worst = None
    for result in report.failing:
        worst = {"variable": result.name, **(result.as_dict().get("worst") or {})}
        break
    return Comparison(report.equal, worst, report.text(), report)


def _dataset(x: Any) -> xr.Dataset:
    return open_dataset(x) if isinstance(x, str | os.PathLike) else x


def _name(x: Any, default: str) -> str:
    return os.fspath(x) if isinstance(x, str | os.PathLike) else default


def plot(
    ds: xr.Dataset | str | os.PathLike,
    view: str | None = None,
    *,
    harmonics: Sequence[float | str] | None = None,
    sigmas: Sequence[float] | None = None,
    overlay: xr.Dataset | str | os.PathLike | None = None,
    wrap_phase: bool = False,
) -> Figure:
    """The paper-style figure of any hertzsweep dataset (``hertzsweep plot``), as a
    :class:`matplotlib.figure.Figure`; nothing is written or shown.

    Parameters
    ----------
    ds : xarray.Dataset or path
        A dataset, or a file of one.
    view : str, optional
        One of the kind's views (default the first): sweep ``harmonics``,
        ``amplitude``, ``forces``; trace ``both``, ``time``, ``spectrum``; branch
        ``harmonics``, ``amplitude``; study ``jumps``, ``subharmonic``; accuracy
        ``errors``; measured and fit ``auto``, ``harmonics``, ``amplitude``, ``jumps``;
        random ``psd``, ``pdf``, ``loss``.
    harmonics : sequence of orders, optional
        Draw only these harmonics (sweep, branch): numbers, or texts such as ``"2"``,
        ``"1/2"``.
    sigmas : sequence of float, optional
        Draw only these input levels.
    overlay : xarray.Dataset or path, optional
        A sweep drawn as markers over a branch, or measurements over a simulation.
    wrap_phase : bool
        Phases as stored, in [0, 360) (default: unwrapped along each curve).

    Raises
    ------
    HertzsweepError
        An unknown view, a harmonic or sigma the dataset does not hold, a dataset that
        is not hertzsweep's or not complete (named by its file when given one).
    """
    from ..output.figures import figure
    from ..output.plot import UNWRAPPED, WRAPPED, phase_convention

    where = os.fspath(ds) if isinstance(ds, str | os.PathLike) else None
    ds = _dataset(ds)
    overlay = _dataset(overlay) if overlay is not None else None
    harmonics = list(harmonics) if harmonics else None
    try:
        with phase_convention(WRAPPED if wrap_phase else UNWRAPPED):
            return figure(ds, view, harmonics, list(sigmas) if sigmas else None, overlay)
    except HertzsweepError as exc:
        raise (exc.with_context(where) if where else exc) from None
    except (KeyError, AttributeError) as exc:  # a variable or coordinate the kind needs
        kind = ds.attrs.get("hertzsweep_kind")
        error = HertzsweepError(f"not a complete {kind} dataset ({exc})")
        raise (error.with_context(where) if where else error) from None


__all__ = list(PUBLIC_API)  # the names hertzsweep hands out (hertzsweep._API)
