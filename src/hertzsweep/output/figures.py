"""The figure of any dataset, drawn as its kind draws it (:func:`figure`).

Each kind's ``draw`` (:data:`hertzsweep.core.kinds.KINDS`) names one of the ``draw_*``
functions here: the figure functions of :mod:`hertzsweep.output.plot` and
:mod:`hertzsweep.output.plot_measured` behind one signature, ``draw(ds, view, harmonics,
overlay)``, imported when first drawn (matplotlib only where a figure is made).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from ..core.kinds import KINDS, MEASURED, Kind, kind_named
from ..errors import HertzsweepError

if TYPE_CHECKING:  # matplotlib and xarray only where a figure is drawn
    import xarray as xr
    from matplotlib.figure import Figure


# --------------------------------------------------------------------------- figures
def draw_sweep(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import sweep_figure

    return sweep_figure(ds, view, harmonics)


def draw_trace(
    ds: xr.Dataset | Sequence[xr.Dataset], view: str, harmonics: Any, overlay: Any
) -> Figure:
    """Also several trace datasets stacked (:func:`hertzsweep.output.plot.trace_figure`)."""
    from .plot import trace_figure

    return trace_figure(ds, view)


def draw_branch(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import branch_figure

    return branch_figure(ds, view, harmonics, overlay)


def draw_random(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import random_figure

    return random_figure(ds, view)


def draw_study(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import study_figure

    return study_figure(ds, view)


def draw_accuracy(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot import accuracy_figure

    return accuracy_figure(ds)


def draw_measured(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot_measured import measured_figure

    return measured_figure(ds, view, harmonics)


def draw_fit(ds: xr.Dataset, view: str, harmonics: Any, overlay: Any) -> Figure:
    from .plot_measured import fit_figure

    return fit_figure(ds, view)


# --------------------------------------------------------------------------- lookups
def kind_of(ds: xr.Dataset) -> Kind:
    """The kind of a dataset, by its ``hertzsweep_kind``
    (:func:`hertzsweep.core.kinds.kind_named`)."""
    return kind_named(ds.attrs.get("hertzsweep_kind"))


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
    "check_view",
    "draw_accuracy",
    "draw_branch",
    "draw_fit",
    "draw_measured",
    "draw_random",
    "draw_study",
    "draw_sweep",
    "draw_trace",
    "figure",
    "kind_of",
]
