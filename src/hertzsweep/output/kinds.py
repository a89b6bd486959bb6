"""The one registry of dataset kinds: :data:`KINDS`.

Every dataset carries its kind in the ``hertzsweep_kind`` attribute. For each kind the
registry holds what makes, draws and prints it:

- ``run``: its driver (imported when first called, so a command imports only the
  kernels, scipy or matplotlib it uses);
- ``build``: its dataset builder (:mod:`hertzsweep.output.dataset`);
- ``draw`` and ``views``: its figure (:mod:`hertzsweep.output.plot`) and the views it
  has, the first the default;
- ``summary``: what a command prints about it (:mod:`hertzsweep.output.summary`);
- ``case_driver``: for the kinds a study can run, the driver of one case.

The commands, the study, the figures and ``make paper`` all look kinds up here.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..errors import HertzsweepError
from . import summary
from .dataset import (
    accuracy_dataset,
    branch_dataset,
    random_dataset,
    sweep_dataset,
    trace_dataset,
)
from .frame import Frame

if TYPE_CHECKING:  # matplotlib and xarray only where a figure is drawn or a study combined
    import xarray as xr
    from matplotlib.figure import Figure

    from ..drivers.study import Case, Engine, Runner, Study, StudyRun

SCENE = "scene"  # a kind that runs on a scene file
STUDY = "study"  # a kind that runs on a study file
MEASURED = "measured"  # a kind made from measurements (a CSV file or a measured dataset)
MEASURED_VIEWS = ("auto", "harmonics", "amplitude", "jumps")  # auto: by what was measured


@dataclass(frozen=True)
class Kind:
    """One kind of dataset.

    Attributes
    ----------
    name : str
        The ``hertzsweep_kind`` attribute of its datasets.
    source : str
        What it runs on: :data:`SCENE`, :data:`STUDY` (a study file) or :data:`MEASURED`
        (measurements: ``import`` reads them, ``fit`` fits a scene to them).
    views : tuple of str
        The views of its figure; the first is the default.
    run : callable
        Its driver, with the driver's parameters: ``run(scene, ...) -> result`` for a
        scene kind; the study kind's, ``run(study, cases, output, engine, ...)``, runs the
        cases into their parts with the driver of the study's kind
        (:func:`hertzsweep.output.study.run_parts`).
    build : callable
        ``build(result, scene, history=None) -> Dataset``; the study kind's combines the
        parts (:func:`hertzsweep.output.study.combine`).
    draw : callable
        ``draw(ds, view, harmonics, overlay) -> Figure``, the view already checked.
    summary : callable
        ``summary(result, ds) -> str``: what a command prints.
    case_driver : callable, optional
        For the kinds a study can run: returns the driver of one case,
        ``scene -> result`` (a module-level function: it is sent to the workers).
    at_frequency : bool
        The driver records at one frequency ratio: ``run(scene, frequency_ratio, ...)``.
    """

    name: str
    source: str
    views: tuple[str, ...]
    run: Callable[..., Any]
    build: Callable[..., Frame | xr.Dataset]
    draw: Callable[..., Figure]
    summary: Callable[[Any, Frame | xr.Dataset], str]
    case_driver: Callable[[], Runner] | None = None
    at_frequency: bool = False


# --------------------------------------------------------------------------- drivers
def _run_sweep(*args: Any, **kwargs: Any) -> Any:
    """:func:`hertzsweep.drivers.sweep.run_sweep`, each dwell read for the ball's own
    mode (the sweep dataset's ``ball_mode_error``)."""
    from ..drivers.sweep import run_sweep

    return run_sweep(*args, ball_mode=True, **kwargs)


def _run_trace(*args: Any, **kwargs: Any) -> Any:
    """:func:`hertzsweep.drivers.trace.run_trace`."""
    from ..drivers.trace import run_trace

    return run_trace(*args, **kwargs)


def _run_branch(*args: Any, **kwargs: Any) -> Any:
    """:func:`hertzsweep.drivers.continuation.run_branch`."""
    from ..drivers.continuation import run_branch

    return run_branch(*args, **kwargs)


def _run_random(*args: Any, **kwargs: Any) -> Any:
    """:func:`hertzsweep.drivers.random.run_random`."""
    from ..drivers.random import run_random

    return run_random(*args, **kwargs)


def _run_accuracy(*args: Any, **kwargs: Any) -> Any:
    """:func:`hertzsweep.drivers.accuracy.measure_accuracy`."""
    from ..drivers.accuracy import measure_accuracy

    return measure_accuracy(*args, **kwargs)


def _run_study(
    study: Study, cases: Sequence[Case], output: str | os.PathLike, engine: Engine, **options: Any
) -> StudyRun:
    """The study's cases into their parts (:func:`hertzsweep.output.study.run_parts`), by
    the case driver and the dataset builder of the study's kind."""
    from .study import run_parts

    case_kind = KINDS[study.kind]
    runner, build = case_kind.case_driver(), case_kind.build
    return run_parts(study, cases, output, engine, runner, build, **options)


def _combine(*args: Any, **kwargs: Any) -> xr.Dataset:
    """:func:`hertzsweep.output.study.combine`."""
    from .study import combine

    return combine(*args, **kwargs)


def _sweep_case() -> Runner:
    """A study's sweep case: every trajectory of the case in one compiled loop."""
    from ..drivers.sweep import run_sweep

    return run_sweep


def _branch_case() -> Runner:
    """A study's branch case: the continuation of every sigma of the case."""
    from ..drivers.continuation import run_branch

    return run_branch


def _random_case() -> Runner:
    """A study's random case: every level and realisation of the case in lockstep."""
    from ..drivers.random import run_random

    return run_random


# --------------------------------------------------------------------------- figures
def _draw_sweep(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import sweep_figure

    return sweep_figure(ds, view, harmonics)


def _draw_trace(
    ds: xr.Dataset | Sequence[xr.Dataset], view: str, harmonics: Any, overlay: Any
) -> Figure:
    """Also several trace datasets stacked (:func:`hertzsweep.output.plot.trace_figure`)."""
    from .plot import trace_figure

    return trace_figure(ds, view)


def _draw_branch(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import branch_figure

    return branch_figure(ds, view, harmonics, overlay)


def _draw_random(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import random_figure

    return random_figure(ds, view)


def _draw_study(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import study_figure

    return study_figure(ds, view)


def _draw_accuracy(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import accuracy_figure

    return accuracy_figure(ds)


# --------------------------------------------------------------------------- measurements
def _run_import(*args: Any, **kwargs: Any) -> Any:
    """:func:`hertzsweep.output.formats.read_any`: a measurement file of any kind."""
    from .formats import read_any

    return read_any(*args, **kwargs)


def _run_fit(*args: Any, **kwargs: Any) -> Any:
    """:func:`hertzsweep.drivers.fit.fit`."""
    from ..drivers.fit import fit

    return fit(*args, **kwargs)


def _build_measured(*args: Any, **kwargs: Any) -> xr.Dataset:
    from .measured import measured_dataset

    return measured_dataset(*args, **kwargs)


def _build_fit(*args: Any, **kwargs: Any) -> xr.Dataset:
    from .measured import fit_dataset

    return fit_dataset(*args, **kwargs)


def _summary_measured(result: Any, ds: xr.Dataset) -> str:
    from .measured import measured_summary

    return measured_summary(result, ds)


def _summary_fit(result: Any, ds: xr.Dataset) -> str:
    from .measured import fit_summary

    return fit_summary(result, ds)


def _draw_measured(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot_measured import measured_figure

    return measured_figure(ds, view, harmonics)


def _draw_fit(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot_measured import fit_figure

    return fit_figure(ds, view)


# --------------------------------------------------------------------------- the registry
KINDS: dict[str, Kind] = {  # name, source, views, run, build, draw, summary[, extras]
    kind.name: kind
    for kind in (
        Kind("sweep", SCENE, ("harmonics", "amplitude", "forces"), _run_sweep, sweep_dataset,
             _draw_sweep, summary.sweep_summary, case_driver=_sweep_case),
        Kind("trace", SCENE, ("both", "time", "spectrum"), _run_trace, trace_dataset,
             _draw_trace, summary.trace_summary, at_frequency=True),
        Kind("branch", SCENE, ("harmonics", "amplitude"), _run_branch, branch_dataset,
             _draw_branch, summary.branch_summary, case_driver=_branch_case),
        Kind("random", SCENE, ("psd", "pdf", "loss"), _run_random, random_dataset,
             _draw_random, summary.random_summary, case_driver=_random_case),
        Kind("study", STUDY, ("jumps", "subharmonic"), _run_study, _combine, _draw_study,
             summary.study_summary),
        Kind("accuracy", SCENE, ("errors",), _run_accuracy, accuracy_dataset,
             _draw_accuracy, summary.accuracy_summary),
        Kind("measured", MEASURED, MEASURED_VIEWS, _run_import, _build_measured,
             _draw_measured, _summary_measured),
        Kind("fit", MEASURED, MEASURED_VIEWS, _run_fit, _build_fit, _draw_fit, _summary_fit),
    )
}  # fmt: skip
STUDY_KINDS = tuple(name for name, kind in KINDS.items() if kind.case_driver is not None)


# --------------------------------------------------------------------------- lookups
def kind_of(ds: xr.Dataset) -> Kind:
    """The kind of a dataset, by its ``hertzsweep_kind``.

    Raises
    ------
    HertzsweepError
        The attribute is missing or names no known kind.
    """
    name = ds.attrs.get("hertzsweep_kind")
    if name is None:
        raise HertzsweepError("not a hertzsweep dataset (no 'hertzsweep_kind' attribute)")
    if name not in KINDS:
        known = ", ".join(KINDS)
        raise HertzsweepError(f"hertzsweep_kind: unknown kind {name!r} (known: {known})")
    return KINDS[str(name)]


def check_view(kind: Kind, view: str | None) -> str:
    """The view to draw: ``view`` if the kind has it, else its default (None).

    Raises
    ------
    HertzsweepError
        The kind has no such view.
    """
    if view is None:
        return kind.views[0]
    if view not in kind.views:
        views = ", ".join(kind.views)
        raise HertzsweepError(f"--view: {kind.name} datasets have views {views}; got {view!r}")
    return view


def figure(
    ds: xr.Dataset,
    view: str | None = None,
    harmonics: Sequence[float | str] | None = None,
    sigma: Sequence[float] | None = None,
    overlay: xr.Dataset | None = None,
) -> Figure:
    """The paper-style figure of any hertzsweep dataset, drawn as its kind draws it.

    Parameters
    ----------
    ds : xarray.Dataset
        A dataset written by hertzsweep (any kind of :data:`KINDS`).
    view : str, optional
        One of the kind's views; default the first.
    harmonics : sequence of orders, optional
        The harmonic orders to draw (sweep and branch), numbers or texts (``"1/2"``);
        default all.
    sigma : sequence of float, optional
        The input levels to draw (datasets with a ``sigma`` dimension); default all.
    overlay : xarray.Dataset, optional
        A sweep dataset drawn as markers over a branch (Figures 13, 14), or a measured
        dataset over a sweep, branch or study figure
        (:func:`hertzsweep.output.plot_measured.overlay_measured`).

    Raises
    ------
    HertzsweepError
        Unknown kind or view, or a harmonic or sigma the dataset does not hold.
    """
    kind = kind_of(ds)
    view = check_view(kind, view)
    if sigma is not None:
        from .plot import select_sigma

        ds = select_sigma(ds, sigma)
    if overlay is not None and overlay.attrs.get("hertzsweep_kind") == MEASURED:
        from .plot_measured import overlay_measured

        fig = kind.draw(ds, view, harmonics, None)
        overlay_measured(fig, ds, overlay, view, harmonics)
        return fig
    return kind.draw(ds, view, harmonics, overlay)


__all__ = [
    "KINDS",
    "MEASURED",
    "SCENE",
    "STUDY",
    "STUDY_KINDS",
    "Kind",
    "check_view",
    "figure",
    "kind_of",
]
