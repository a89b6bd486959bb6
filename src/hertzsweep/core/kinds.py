"""The one registry of dataset kinds: :data:`KINDS`, an entry a kind.

Every dataset carries its kind in the ``hertzsweep_kind`` attribute. A :class:`Kind`
holds everything the package keys by a kind: what it runs on, its summary sentence, its
command and help line, its driver, dataset builder, figure and printed summary, its rerun
runner, its study case (level key and excitation), its preflight, what it exports. Every
other table of kinds (the CLI's command list, the study's level keys, the rerun runners,
the UFF export's variables, ...) is derived from here; ``tests/test_layers.py`` checks
that no other module-level mapping is keyed by kind names.

The registry is plain data at the bottom layer, so that every layer may read it. Its
functions live in the layers above and are named by :class:`Ref` (module and attribute),
imported on first call: listing the kinds imports nothing, and a command imports only the
kernels, xarray or matplotlib it uses.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..errors import HertzsweepError

SCENE = "scene"  # a kind that runs on a scene file
STUDY = "study"  # a kind that runs on a study file
MEASURED = "measured"  # a kind made from measurements (a CSV file or a measured dataset)
MEASURED_VIEWS = ("auto", "harmonics", "amplitude", "jumps")  # auto: by what was measured
SIGMA_KEY = "excitation.sigma"  # the levels of a sine scene
RMS_KEY = "excitation.rms"  # the levels of a random scene


@dataclass(frozen=True)
class Ref:
    """A function of a layer above, named by its module and attribute and imported on
    first call; ``keywords`` are passed to it on every call (``functools.partial``'s
    part, kept as data so that the entry stays printable and comparable)."""

    module: str
    name: str
    keywords: tuple[tuple[str, Any], ...] = ()

    def resolve(self) -> Callable[..., Any]:
        """The function itself (a module-level one: it can be sent to a worker)."""
        return getattr(importlib.import_module(self.module), self.name)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.resolve()(*args, **dict(self.keywords), **kwargs)


def _ref(path: str, **keywords: Any) -> Ref:
    """``"drivers.sweep:run_sweep"`` -> the :class:`Ref` of ``hertzsweep.drivers.sweep``'s
    ``run_sweep``."""
    module, _, name = path.partition(":")
    return Ref(f"hertzsweep.{module}", name, tuple(keywords.items()))


@dataclass(frozen=True)
class Kind:
    """One kind of dataset.

    Attributes
    ----------
    name : str
        The ``hertzsweep_kind`` attribute of its datasets.
    source : str
        What it runs on: :data:`SCENE`, :data:`STUDY` or :data:`MEASURED`.
    about : str
        The ACDD ``summary`` of its datasets: what one holds, in a sentence.
    views : tuple of str
        The views of its figure; the first is the default.
    command, help : str
        The ``hertzsweep`` command that makes it (its module in ``hertzsweep.cli`` is
        ``cli_module``) and the line ``hertzsweep --help`` shows for it.
    run : callable
        Its driver: ``run(scene, ...) -> result`` for a scene kind; the study kind's runs
        the cases into their parts with the case driver of the study's kind.
    build : callable
        ``build(result, scene, history=None) -> Dataset``; the study kind's combines parts.
    draw : callable
        ``draw(ds, view, harmonics, overlay) -> Figure``, the view already checked.
    summary : callable
        ``summary(result, ds) -> str``: what a command prints.
    excitation : str, optional
        The ``excitation.kind`` of the scenes it runs on (scene kinds).
    preflight : callable, optional
        ``preflight(scene)``: the checks a scene passes before its run (scene kinds).
    rerun : callable, optional
        ``rerun(scene, command, progress, sink) -> Run``: its driver from a dataset's
        ``command_json`` (``hertzsweep rerun``); None where no simulation made it.
    case : Ref, optional
        For the kinds a study can run: the driver of one case, ``scene -> result``.
    level_key : str, optional
        For those kinds: the list-valued scene key a case takes whole (a dimension).
    exports : tuple of str, optional
        The (amplitude, phase) variables ``hertzsweep export`` writes; None: no export.
    at_frequency : bool
        The driver records at one frequency ratio: ``run(scene, frequency_ratio, ...)``.
    """

    name: str
    source: str
    about: str
    views: tuple[str, ...]
    command: str
    cli_module: str
    help: str
    run: Callable[..., Any]
    build: Callable[..., Any]
    draw: Callable[..., Any]
    summary: Callable[..., str]
    excitation: str | None = None
    preflight: Callable[..., Any] | None = None
    rerun: Callable[..., Any] | None = None
    case: Ref | None = None
    level_key: str | None = None
    exports: tuple[str, str] | None = None
    at_frequency: bool = False


PREFLIGHT = _ref("core.checks:check_scene")  # the preflight, an override named as such

KINDS: dict[str, Kind] = {
    kind.name: kind
    for kind in (
        Kind(
            "sweep",
            SCENE,
            "Lock-in readings of the normalised contact force (harmonic amplitudes and "
            "phases, extremes, loss of contact) at each dwell of stepped-sine sweeps up and "
            "down in frequency, for each input level, with the jump frequencies.",
            ("harmonics", "amplitude", "forces"),
            "sweep",
            "sweep",
            "Stepped-sine sweeps, up and/or down, for every sigma.",
            run=_ref("drivers.sweep:run_sweep", ball_mode=True),
            build=_ref("output.dataset:sweep_dataset"),
            draw=_ref("output.figures:draw_sweep"),
            summary=_ref("output.summary:sweep_summary"),
            excitation="sine",
            preflight=PREFLIGHT,
            rerun=_ref("api.rerun:rerun_sweep"),
            case=_ref("drivers.sweep:run_sweep"),
            level_key=SIGMA_KEY,
            exports=("amplitude", "phase"),
        ),
        Kind(
            "trace",
            SCENE,
            "Time history of the displacement, velocity and contact force at one "
            "frequency, with its spectrum, its lock-in readings and its flights (losses of "
            "contact).",
            ("both", "time", "spectrum"),
            "trace",
            "trace",
            "Settled time history at one frequency, its spectrum, its flights.",
            run=_ref("drivers.trace:run_trace"),
            build=_ref("output.dataset:trace_dataset"),
            draw=_ref("output.figures:draw_trace"),
            summary=_ref("output.summary:trace_summary"),
            excitation="sine",
            preflight=PREFLIGHT,
            rerun=_ref("api.rerun:rerun_trace"),
            at_frequency=True,
        ),
        Kind(
            "branch",
            SCENE,
            "Periodic orbits followed in frequency by shooting and pseudo-arclength "
            "continuation, for each input level: their readings, Floquet multipliers, "
            "stability and bifurcations.",
            ("harmonics", "amplitude"),
            "branch",
            "branch",
            "Periodic orbits by shooting and continuation: stability, folds.",
            run=_ref("drivers.continuation:run_branch"),
            build=_ref("output.dataset:branch_dataset"),
            draw=_ref("output.figures:draw_branch"),
            summary=_ref("output.summary:branch_summary"),
            excitation="sine",
            preflight=PREFLIGHT,
            rerun=_ref("api.rerun:rerun_branch"),
            case=_ref("drivers.continuation:run_branch"),
            level_key=SIGMA_KEY,
        ),
        Kind(
            "random",
            SCENE,
            "Spectra (PSD, FRF, coherence) and statistics (moments, extremes, probability "
            "density, loss of contact and flights) of the normalised contact force under "
            "band-limited Gaussian excitation, for each input RMS level: means over "
            "independent realisations with their standard errors.",
            ("psd", "pdf", "loss"),
            "random",
            "random",
            "Random excitation: spectra, statistics, contact loss of N/F_s.",
            run=_ref("drivers.random:run_random"),
            build=_ref("output.dataset:random_dataset"),
            draw=_ref("output.figures:draw_random"),
            summary=_ref("output.summary:random_summary"),
            excitation="random",
            preflight=PREFLIGHT,
            rerun=_ref("api.rerun:rerun_random"),
            case=_ref("drivers.random:run_random"),
            level_key=RMS_KEY,
        ),
        Kind(
            "study",
            STUDY,
            "The results of one kind of run over a grid of scene values, one case per grid "
            "point, failed cases marked.",
            ("jumps", "subharmonic"),
            "study",
            "study",
            "A grid of scenes on a local pool or a Dask cluster.",
            run=_ref("jobs.study:run_kind_parts"),
            build=_ref("jobs.study:combine"),
            draw=_ref("output.figures:draw_study"),
            summary=_ref("output.summary:study_summary"),
        ),
        Kind(
            "accuracy",
            SCENE,
            "Errors of a sweep against a reference of finer solver settings, with the cost "
            "of each setting, the observed order of the scheme and the recommended setting.",
            ("errors",),
            "accuracy",
            "accuracy",
            "Error against cost for the solver settings.",
            run=_ref("drivers.accuracy:measure_accuracy"),
            build=_ref("output.dataset:accuracy_dataset"),
            draw=_ref("output.figures:draw_accuracy"),
            summary=_ref("output.summary:accuracy_summary"),
            excitation="sine",
            preflight=PREFLIGHT,
            rerun=_ref("api.rerun:rerun_accuracy"),
        ),
        Kind(
            "measured",
            MEASURED,
            "Measurements of a stepped-sine test (harmonic amplitudes and phases, or jump "
            "frequencies) in the layout of a sweep, read from a CSV file.",
            MEASURED_VIEWS,
            "import",
            "importing",
            "Measurements (CSV, UFF 58/58b, lock-in tables) into a dataset.",
            run=_ref("io.formats:read_any"),
            build=_ref("io.measured:measured_dataset"),
            draw=_ref("output.figures:draw_measured"),
            summary=_ref("io.measured:measured_summary"),
            exports=("amplitude", "phase"),
        ),
        Kind(
            "fit",
            MEASURED,
            "Scene values identified by least squares from measurements, with their "
            "standard errors, the fitted model at every measured point and the residuals.",
            MEASURED_VIEWS,
            "fit",
            "fit",
            "Fit f0, the damping ratio and the contact law to measurements.",
            run=_ref("drivers.fit:fit"),
            build=_ref("io.measured:fit_dataset"),
            draw=_ref("output.figures:draw_fit"),
            summary=_ref("io.measured:fit_summary"),
            preflight=PREFLIGHT,
            exports=("model_amplitude", "model_phase"),
        ),
    )
}

STUDY_KINDS = tuple(name for name, kind in KINDS.items() if kind.case is not None)
"""What one case of a study can be."""
RERUN_KINDS = tuple(name for name, kind in KINDS.items() if kind.rerun is not None)
"""The kinds ``hertzsweep rerun`` runs again from their dataset (and the study)."""
EXPORT_KINDS = tuple(name for name, kind in KINDS.items() if kind.exports is not None)
"""The kinds ``hertzsweep export`` writes."""


def names(kinds: tuple[str, ...]) -> str:
    """``"sweep, trace and branch"``: kinds (or commands) for a message."""
    return kinds[0] if len(kinds) == 1 else f"{', '.join(kinds[:-1])} and {kinds[-1]}"


def commands_of(excitation: str) -> str:
    """The commands that run a scene of this ``excitation.kind``, for a message."""
    return names(tuple(k.command for k in KINDS.values() if k.excitation == excitation))


def kind_named(name: Any) -> Kind:
    """The kind of a ``hertzsweep_kind`` attribute.

    Raises
    ------
    HertzsweepError
        The attribute is missing or names no known kind.
    """
    if name is None:
        raise HertzsweepError("not a hertzsweep dataset (no 'hertzsweep_kind' attribute)")
    if name not in KINDS:
        known = ", ".join(KINDS)
        raise HertzsweepError(f"hertzsweep_kind: unknown kind {name!r} (known: {known})")
    return KINDS[str(name)]


__all__ = [
    "EXPORT_KINDS",
    "KINDS",
    "MEASURED",
    "RERUN_KINDS",
    "RMS_KEY",
    "SCENE",
    "SIGMA_KEY",
    "STUDY",
    "STUDY_KINDS",
    "Kind",
    "Ref",
    "commands_of",
    "kind_named",
    "names",
]
