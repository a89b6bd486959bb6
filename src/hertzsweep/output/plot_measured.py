"""Figures of measurements and fits, and measurements drawn over simulated figures.

- ``measured``: sweeps as the rig read them (H_k amplitude and phase against the
  frequency in Hz, or the frequency ratio), squares, up filled, down open, a colour per
  sigma; jump frequencies against sigma (down triangles pointing down, up pointing up).
- ``fit``: the measured H1 (squares) and the fitted model at the same frequencies (lines,
  solid up, dashed down), or the measured jumps and the model's jump curve, with the
  estimates and their standard errors.
- :func:`overlay_measured`: measured sweeps over a simulated sweep or branch figure (in
  the figure's frequency ratio, w = f / f0 with the dataset's ``natural_frequency``),
  measured jumps over a study figure (Figure 11 over Figure 15), or as vertical lines
  over a sweep or branch figure.

The conventions (sizes, colours, phase windows) are those of
:mod:`hertzsweep.output.plot`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..errors import HertzsweepError
from .frame import load_xarray
from .plot import (
    COLOURS,
    DPI,
    HZ_LABEL,
    MARKER_SIZE,
    W_LABEL,
    drawn_phase,
    phase_window,
    select_harmonics,
)

xr = load_xarray()  # xarray with its dask probe kept quiet

MARKER = "s"  # measured points are squares (simulated sweeps are circles)
JUMP_MARKERS = {"down": "v", "up": "^"}  # measured jump frequencies, by sweep direction
JUMP_LINES = {"down": "--", "up": ":"}  # measured jumps drawn over a sweep or branch figure
SIGMA_RTOL = 1e-9  # a measured sigma is a simulated one within this (as --sigma matches)
PARAMETER_SYMBOLS = {
    "rig.natural_frequency": ("$f_0$", "Hz"),
    "damping.ratio": (r"$\zeta$", ""),
    "damping.exponent": ("$n$", ""),
}


# --------------------------------------------------------------------------- helpers
def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _colour(i: int) -> str:
    return COLOURS[i % len(COLOURS)]


def _sigma_label(sigma: float) -> str:
    return rf"$\sigma$ = {100.0 * sigma:.3g} %"


def _is_jumps(ds: xr.Dataset) -> bool:
    return ds.attrs.get("measured_kind") == "jumps"


def _view(ds: xr.Dataset, view: str) -> str:
    """The view to draw: ``auto`` is ``jumps`` or ``harmonics`` by what was measured.

    Raises
    ------
    HertzsweepError
        A view of sweeps for jump frequencies, or the other way round.
    """
    if view == "auto":
        return "jumps" if _is_jumps(ds) else "harmonics"
    if (view == "jumps") != _is_jumps(ds):
        held = "jump frequencies" if _is_jumps(ds) else "sweeps"
        raise HertzsweepError(f"--view: {view} does not show {held} (use auto)")
    return view


def _frequency_axis(ds: xr.Dataset) -> tuple[str, str]:
    """The measured frequencies' dimension and its label."""
    if "frequency" in ds.dims:
        return "frequency", HZ_LABEL
    return "frequency_ratio", W_LABEL


def _jump_variable(ds: xr.Dataset) -> tuple[str, str]:
    if "jump_frequency" in ds:
        return "jump_frequency", "jump frequency $f$ [Hz]"
    return "jump_frequency_ratio", r"jump frequency ratio $\varpi$ [1]"


def _markers(ax, x: np.ndarray, y: np.ndarray, colour: str, direction: str, **extra) -> None:
    face = colour if direction == "up" else "none"
    keep = np.isfinite(y)
    ax.plot(
        x[keep],
        y[keep],
        ls="none",
        marker=MARKER,
        ms=MARKER_SIZE,
        color=colour,
        mfc=face,
        mew=0.8,
        **extra,
    )


def _direction_handles(directions: Sequence[str], prefix: str = "measured") -> list[Line2D]:
    return [
        Line2D(
            [],
            [],
            ls="none",
            marker=MARKER,
            ms=6,
            color="0.2",
            mfc="0.2" if d == "up" else "none",
            label=f"{prefix} {d} sweep",
        )
        for d in directions
    ]


def _sigma_handles(sigmas: np.ndarray) -> list[Line2D]:
    return [
        Line2D([], [], ls="none", marker=MARKER, ms=6, color=_colour(i), label=_sigma_label(s))
        for i, s in enumerate(sigmas)
    ]


def _source(ds: xr.Dataset) -> str:
    name = str(ds.attrs.get("measured_file", ""))
    return name.rsplit("/", 1)[-1] if name else ""


# --------------------------------------------------------------------------- measured
def measured_figure(
    ds: xr.Dataset, view: str = "auto", harmonics: Sequence[float | str] | None = None
) -> Figure:
    """Measured sweeps (H_k amplitude and phase against frequency) or jump frequencies
    (against sigma), as they were read."""
    view = _view(ds, view)
    if view == "jumps":
        fig = _figure(8.5, 6.0)
        ax = fig.subplots()
        _measured_jumps(ax, ds)
        ax.legend(fontsize="small", loc="best")
        fig.suptitle(f"Measured jump frequencies  ({_source(ds)})", fontsize="medium")
        return fig
    ds = select_harmonics(ds, harmonics)
    orders = [float(k) for k in ds.harmonic.values]
    with_phase = view == "harmonics"
    size = (11.0, 1.0 + 3.2 * len(orders)) if with_phase else (8.0, 1.4 + 3.6 * len(orders))
    fig = _figure(*size)
    axes = fig.subplots(len(orders), 2 if with_phase else 1, squeeze=False, sharex=True)
    axis, label = _frequency_axis(ds)
    x = ds[axis].values
    for row, k in enumerate(orders):
        phases = ds.phase.sel(harmonic=k)
        window = phase_window(phases.values)
        for i in range(ds.sizes["sigma"]):
            for direction in ds.direction.values:
                one = ds.sel(direction=direction, harmonic=k).isel(sigma=i)
                _markers(axes[row, 0], x, one.amplitude.values, _colour(i), direction)
                if with_phase:
                    y = drawn_phase(one.phase.values, window)
                    _markers(axes[row, 1], x, y, _colour(i), direction)
        axes[row, 0].set_ylabel(f"$H_{{{k}}}$ amplitude of $N/F_s$ [1]")
        if with_phase:
            axes[row, 1].set_ylabel(f"$H_{{{k}}}$ phase lag [degree]")
    for ax in axes.ravel():
        ax.grid(True, lw=0.3)
    for ax in axes[-1]:
        ax.set_xlabel(label)
    handles = _sigma_handles(ds.sigma.values) + _direction_handles(list(ds.direction.values))
    axes[0, 0].legend(handles=handles, fontsize="small", loc="best")
    fig.suptitle(f"Measured stepped-sine sweeps  ({_source(ds)})", fontsize="medium")
    return fig


def _measured_jumps(ax, ds: xr.Dataset, f0: float | None = None, colour: str = "k") -> None:
    """The measured jumps against sigma [%]; with ``f0``, in frequency ratios."""
    name, label = _jump_variable(ds)
    for direction in ds.direction.values:
        y = ds[name].sel(direction=direction).values
        if f0 is not None and name == "jump_frequency":
            y = y / f0
        keep = np.isfinite(y)
        ax.plot(
            100.0 * ds.sigma.values[keep],
            y[keep],
            ls="none",
            marker=JUMP_MARKERS[str(direction)],
            ms=8,
            color=colour,
            mfc="none" if direction == "down" else colour,
            label=f"measured {direction}ward jump",
        )
    ax.set_xlabel(r"input level $\sigma = F/F_s$ [%]")
    ax.set_ylabel(label if f0 is None else r"jump frequency ratio $\varpi$ [1]")
    ax.grid(True, lw=0.3)


# --------------------------------------------------------------------------- fit
def fit_figure(ds: xr.Dataset, view: str = "auto") -> Figure:
    """The measurements and the fitted model, with the estimates in a box."""
    view = _view(ds, view)
    if view == "jumps":
        fig = _figure(8.5, 6.0)
        ax = fig.subplots()
        _fit_jumps(ax, ds)
        axes = [ax]
    else:
        with_phase = view == "harmonics"
        fig = _figure(11.0, 4.6) if with_phase else _figure(8.0, 5.0)
        axes = list(fig.subplots(1, 2 if with_phase else 1, squeeze=False)[0])
        _fit_sweeps(axes, ds)
    axes[0].text(
        0.02,
        0.02,
        _estimates_text(ds),
        transform=axes[0].transAxes,
        fontsize="small",
        va="bottom",
        bbox={"boxstyle": "round", "facecolor": "white", "alpha": 0.85, "edgecolor": "0.6"},
    )
    what = "jump frequencies" if view == "jumps" else "H1 readings"
    fig.suptitle(
        f"Model fitted to measured {what}  ({_source(ds)}; {ds.attrs.get('fit_method', '')})",
        fontsize="medium",
    )
    return fig


def _estimates_text(ds: xr.Dataset) -> str:
    lines = []
    for key, x, s in zip(
        ds.parameter.values, ds.estimate.values, ds.standard_error.values, strict=True
    ):
        symbol, unit = PARAMETER_SYMBOLS.get(str(key), (str(key), ""))
        lines.append(f"{symbol} = {x:.5g} $\\pm$ {s:.2g} {unit}".rstrip())
    lines.append(f"residual RMS {float(ds.attrs.get('residual_rms', np.nan)):.3g}")
    return "\n".join(lines)


def _fit_sweeps(axes, ds: xr.Dataset) -> None:
    axis, label = _frequency_axis(ds)
    x = ds[axis].values
    window = phase_window(ds.phase.values)
    for i in range(ds.sizes["sigma"]):
        colour = _colour(i)
        for direction in ds.direction.values:
            one = ds.sel(direction=direction).isel(sigma=i)
            measured = np.isfinite(one.amplitude.values)
            panels = [(axes[0], one.amplitude.values, one.model_amplitude.values)]
            if len(axes) > 1:
                panels.append(
                    (
                        axes[1],
                        drawn_phase(one.phase.values, window),
                        drawn_phase(np.where(measured, one.model_phase.values, np.nan), window),
                    )
                )
            for ax, data, model in panels:
                _markers(ax, x, data, colour, str(direction))
                ax.plot(
                    x[measured],
                    model[measured],
                    color=colour,
                    lw=1.4,
                    ls="-" if direction == "up" else "--",
                )
    axes[0].set_ylabel("$H_1$ amplitude of $N/F_s$ [1]")
    if len(axes) > 1:
        axes[1].set_ylabel("$H_1$ phase lag [degree]")
    for ax in axes:
        ax.set_xlabel(label)
        ax.grid(True, lw=0.3)
    handles = _sigma_handles(ds.sigma.values) + _direction_handles(list(ds.direction.values))
    handles += [
        Line2D([], [], color="0.2", lw=1.4, ls="-" if d == "up" else "--", label=f"model, {d}")
        for d in ds.direction.values
    ]
    axes[0].legend(handles=handles, fontsize="small", loc="upper left")


def _fit_jumps(ax, ds: xr.Dataset) -> None:
    name, _ = _jump_variable(ds)
    f0 = float(ds.attrs["natural_frequency"]) if name == "jump_frequency" else None
    _measured_jumps(ax, ds, f0)
    for d, direction in enumerate(ds.direction.values):
        curve = ds.curve_jump_frequency_ratio.isel(direction=d).values
        ax.plot(
            100.0 * ds.curve_sigma.values,
            curve,
            color=_colour(d),
            lw=1.6,
            ls=JUMP_LINES[str(direction)],
            label=f"model {direction}ward jump",
        )
        model = ds[f"model_{name}"].isel(direction=d).values
        ratio = model / f0 if f0 is not None else model
        ax.plot(100.0 * ds.sigma.values, ratio, ls="none", marker="x", ms=6, color=_colour(d))
    ax.legend(fontsize="small", loc="upper right")


# --------------------------------------------------------------------------- overlays
def overlay_measured(
    fig: Figure,
    ds: xr.Dataset,
    measured: xr.Dataset,
    view: str,
    harmonics: Sequence[float | str] | None = None,
) -> None:
    """Draw a ``measured`` dataset over the figure of ``ds`` (a sweep, branch or study),
    in its frequency ratio (measured Hz over the dataset's ``natural_frequency``).

    Raises
    ------
    HertzsweepError
        Another kind of figure or view; sweeps over a study; no measured level in the
        figure.
    """
    kind = ds.attrs.get("hertzsweep_kind")
    if kind == "study":
        if not _is_jumps(measured):
            raise HertzsweepError("--overlay: a study figure takes measured jump frequencies")
        _overlay_study(fig.axes[0], ds, measured)
        return
    if kind not in ("sweep", "branch") or view not in ("harmonics", "amplitude"):
        raise HertzsweepError(
            "--overlay: measurements go over a sweep or branch figure (view harmonics or "
            "amplitude) or a study figure"
        )
    drawn = select_harmonics(ds, harmonics)
    orders = [float(k) for k in drawn.harmonic.values]
    columns = 2 if view == "harmonics" else 1
    axes = np.array(fig.axes[: len(orders) * columns]).reshape(len(orders), columns)
    colours = _matching_colours(ds.sigma.values, measured.sigma.values)
    f0 = float(ds.attrs.get("natural_frequency", np.nan))
    if _is_jumps(measured):
        _jump_lines(axes, measured, colours, f0)
    else:
        _overlay_sweeps(axes, drawn, measured, orders, colours, f0)
    legend = axes[0, 0].get_legend()
    handles = list(legend.legend_handles) if legend is not None else []
    if _is_jumps(measured):
        handles += [
            Line2D([], [], color="0.2", ls=JUMP_LINES[str(d)], label=f"measured {d}ward jump")
            for d in measured.direction.values
        ]
    else:
        handles += _direction_handles(list(measured.direction.values))
    axes[0, 0].legend(handles=handles, fontsize="small", loc="best")


def _matching_colours(figure_sigma: np.ndarray, measured_sigma: np.ndarray) -> dict[int, str]:
    """Colour of each measured level (index) that the figure draws: the figure's own."""
    colours = {}
    for j, s in enumerate(measured_sigma):
        match = np.flatnonzero(np.isclose(figure_sigma, s, rtol=SIGMA_RTOL, atol=0.0))
        if match.size:
            colours[j] = _colour(int(match[0]))
    if not colours:
        held = ", ".join(f"{s:g}" for s in figure_sigma)
        given = ", ".join(f"{s:g}" for s in measured_sigma)
        raise HertzsweepError(f"--overlay: measured sigma {given} not in the figure ({held})")
    return colours


def _ratios(measured: xr.Dataset, values: np.ndarray, in_hertz: bool, f0: float) -> np.ndarray:
    if not in_hertz:
        return values
    if not np.isfinite(f0) or f0 <= 0:
        raise HertzsweepError("--overlay: the figure's dataset has no natural_frequency")
    return values / f0


def _overlay_sweeps(axes, ds, measured, orders, colours, f0) -> None:
    axis, _ = _frequency_axis(measured)
    w = _ratios(measured, measured[axis].values, axis == "frequency", f0)
    for row, k in enumerate(orders):
        if k not in measured.harmonic.values:
            continue
        window = phase_window(ds.phase.sel(harmonic=k).values)
        for j, colour in colours.items():
            for direction in measured.direction.values:
                one = measured.sel(direction=direction, harmonic=k).isel(sigma=j)
                _markers(axes[row, 0], w, one.amplitude.values, colour, str(direction), mec="k")
                if axes.shape[1] > 1:
                    y = drawn_phase(one.phase.values, window)
                    _markers(axes[row, 1], w, y, colour, str(direction), mec="k")


def _jump_lines(axes, measured, colours, f0) -> None:
    name, _ = _jump_variable(measured)
    for j, colour in colours.items():
        for direction in measured.direction.values:
            value = float(measured[name].sel(direction=direction).isel(sigma=j))
            if not np.isfinite(value):
                continue
            w = float(_ratios(measured, np.array(value), name == "jump_frequency", f0))
            for ax in axes.ravel():
                ax.axvline(w, color=colour, lw=1.0, ls=JUMP_LINES[str(direction)])


def _overlay_study(ax, ds: xr.Dataset, measured: xr.Dataset) -> None:
    """Measured jumps (of the study's drawn direction, down if it has it) over the jump
    frequency against sigma (Figure 11 over Figure 15)."""
    if "sigma" not in ds.dims:
        raise HertzsweepError("--overlay: measured jumps go over a study with a sigma dimension")
    directions = [str(d) for d in ds.direction.values] if "direction" in ds.coords else ["down"]
    direction = "down" if "down" in directions else directions[0]
    if direction not in measured.direction.values:
        raise HertzsweepError(f"--overlay: no measured {direction}ward jumps to draw")
    one = measured.sel(direction=[direction])
    name, _ = _jump_variable(one)
    f0 = float(ds.attrs.get("natural_frequency", np.nan))
    y = _ratios(one, one[name].values[0], name == "jump_frequency", f0)
    keep = np.isfinite(y)
    ax.plot(
        100.0 * one.sigma.values[keep],
        y[keep],
        ls="none",
        marker="*",
        ms=11,
        color="k",
        label=f"measured {direction}ward jump",
    )
    ax.legend(fontsize="small", loc="best")


__all__ = ["fit_figure", "measured_figure", "overlay_measured"]
