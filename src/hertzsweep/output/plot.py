"""Paper-style figures from hertzsweep datasets (the views of Figures 3-17 of the paper).

Builders: a dataset in, a :class:`matplotlib.figure.Figure` out, drawn on an Agg canvas
(no screen, no pyplot state); :func:`write_figure` saves one atomically. The builder of a
dataset is that of its ``hertzsweep_kind`` (:func:`hertzsweep.output.figures.figure`):

- ``sweep``: amplitude and phase of each harmonic against the frequency ratio, up sweeps
  filled markers, down sweeps open ones, one colour per sigma (Figures 3, 4, 5, 9, 10);
  view ``forces``: extremes of N/F_s and the contact-loss share (Figure 6). Dwells that
  did not settle (``settled = 0``) are crosses, settled ones that do not repeat every
  period (``periodic = 0``) triangles, or squares where they repeat after n > 1 periods
  (``response_period``), each named in the legend; the jumps onto and off the period-2
  response (``subharmonic_onset/end_frequency_ratio``) vertical lines.
- ``branch``: the periodic-orbit branches, stable solid, unstable dotted, folds and other
  bifurcations marked, optionally over a simulated sweep (Figures 13, 14; the paper's
  markers there are its measurements, ours a simulation, and the legend says so).
- ``trace``: N/F_s against time in ms with the flights shaded, and the amplitude
  spectrum against the harmonic order (Figures 7, 8, 12, 16, 17).
- ``study``: the jump frequency against sigma, one curve per damping law (Figure 15).
- ``accuracy``: error against cost, log-log, the Pareto front highlighted.
- ``random``: the PSD of N/F_s for every level beside the linear model's, its probability
  density beside the Gaussian's, and the loss of contact and the PSD's peak against the
  level (the paper's Part 2, random excitation).

Conventions: every axis label ends with its unit in brackets, that of the dataset's
``units`` (``[1]`` for a quantity in units of the static load F_s or a ratio,
``[degree]``, ``[Hz]``; ``[ms]`` and ``[%]`` for scaled ones). Phases are unwrapped along
each curve (continuous across 360 -> 0, anchored in [-180, 180) at the lowest frequency or
the branch's first point); :func:`phase_convention` ``("wrapped")`` draws them as stored,
in [0, 360). Figures have a fixed size in inches; files are written at :data:`DPI` (or
the ``dpi`` asked for), with metadata naming the dataset, the command and the version
(:func:`write_figure`). A second axis in Hz uses the dataset's ``natural_frequency``.
"""

from __future__ import annotations

import contextvars
import itertools
import os
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import FuncFormatter, LogLocator, MultipleLocator, NullFormatter

from .. import __version__
from ..core.lockin import first_harmonic_index, order_label, parse_order
from ..errors import HertzsweepError
from .dataset import atomic_path
from .frame import load_xarray

xr = load_xarray()  # xarray with its dask probe kept quiet

DPI = 200  # dots per inch of the raster formats: print quality (journals ask 150-300)
FORMATS = ("png", "pdf", "svg")  # figure files, by extension
COLOURS = (  # matplotlib's tab10, one per sigma (or per curve)
    "#1f77b4",
    "#d62728",
    "#2ca02c",
    "#ff7f0e",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)
MARKER_SIZE = 4.0  # [pt] sweep markers: dense grids (100+ points) stay readable
FLAG_MARKER_SIZE = 6.0  # [pt] unsettled / non-periodic dwells: a little larger, to stand out
SPECTRUM_ORDERS = 8.5  # highest harmonic order shown in a spectrum: the paper's Figure 8
# shows the first few; beyond 8 the lines of these responses are below 1e-3 of H1

W_LABEL = r"frequency ratio $\varpi = f/f_0$ [1]"
HZ_LABEL = "frequency $f$ [Hz]"
FORCE_LABEL = r"normal force $N/F_s$ [1]"
WRAPPED, UNWRAPPED = "wrapped", "unwrapped"  # phase conventions (:func:`phase_convention`)
NOT_SETTLED = ("x", "not settled (still a transient)")  # marker and legend of settled = 0
NOT_PERIODIC = ("^", "not periodic (period doubling, subharmonic or chaos)")  # periodic = 0
# response_period n > 1 (the square of a period doubling, as FOLD_MARKERS); with it, the
# triangles of NOT_PERIODIC are the dwells that repeat within no 8 periods (n = 0)
MULTI_PERIOD = ("s", "repeats every n > 1 periods (period doubling, subharmonic)")
SUBHARMONIC_JUMPS = {  # dataset variable -> (line style, legend) of the vertical marks
    "subharmonic_onset_frequency_ratio": ("--", "jump onto the period-2 response"),
    "subharmonic_end_frequency_ratio": (":", "jump off the period-2 response"),
}
FOLD_MARKERS = {  # bifurcation kind -> (marker, label)
    "fold": ("D", "fold (saddle-node)"),
    "period-doubling": ("s", "period doubling"),
    "neimark-sacker": ("^", "Neimark-Sacker"),
}


# --------------------------------------------------------------------------- files
def figure_format(path: str | os.PathLike) -> str:
    """The format named by a figure file's extension (one of :data:`FORMATS`).

    Raises
    ------
    HertzsweepError
        Another extension, or none.
    """
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in FORMATS:
        named = f".{suffix}" if suffix else "(none)"
        allowed = ", ".join(f".{f}" for f in FORMATS)
        raise HertzsweepError(
            f"-o: {str(path)!r}: unknown figure extension {named} (use {allowed})"
        )
    return suffix


def write_figure(
    fig: Figure,
    path: str | os.PathLike,
    dpi: float = DPI,
    datasets: Sequence[str | os.PathLike] = (),
    command: str = "",
    made_by: str = "",
) -> Path:
    """Save a figure in the format of its extension, atomically: complete or absent.

    Parameters
    ----------
    fig : Figure
    path : path
        ``FIG.png``, ``FIG.pdf`` or ``FIG.svg``.
    dpi : float
        Dots per inch of a PNG (and of the images inside a PDF or SVG).
    datasets : sequence of path
        The dataset(s) drawn, named in the file's metadata (absolute paths).
    command : str
        The command that drew it, for the metadata.
    made_by : str
        How the dataset was made (its ``history``), for the metadata.
    """
    path = Path(path)
    fmt = figure_format(path)
    metadata = figure_metadata(fmt, fig, datasets, command, made_by)
    with atomic_path(path, suffix=f".{fmt}") as tmp:
        fig.savefig(tmp, format=fmt, dpi=dpi, metadata=metadata)
    return path


def figure_metadata(
    fmt: str,
    fig: Figure,
    datasets: Sequence[str | os.PathLike] = (),
    command: str = "",
    made_by: str = "",
) -> dict[str, str]:
    """The metadata of a figure file in the keys its format has: the title, the
    dataset(s) drawn, the command that drew them and how they were made, and the version
    of hertzsweep (PNG text chunks; the PDF info dictionary; SVG Dublin Core)."""
    title = fig.get_suptitle() or "hertzsweep figure"
    software = f"hertzsweep {__version__}"
    source = "; ".join(os.path.abspath(d) for d in datasets)
    description = "; ".join(
        text
        for text in (
            f"drawn by: {command}" if command else "",
            f"dataset made by: {made_by}" if made_by else "",
        )
        if text
    )
    if fmt == "png":
        out = {"Title": title, "Software": software, "Source": source}
        out["Description"] = description
    elif fmt == "pdf":
        out = {"Title": title, "Creator": software, "Subject": source, "Keywords": description}
    else:  # svg: Dublin Core
        out = {"Title": title, "Creator": software, "Source": source}
        out["Description"] = description
    return {key: value for key, value in out.items() if value}


# --------------------------------------------------------------------------- phases
_PHASE = contextvars.ContextVar("hertzsweep_phase_convention", default=UNWRAPPED)


@contextmanager
def phase_convention(convention: str) -> Iterator[None]:
    """Draw phases :data:`UNWRAPPED` (the default: continuous along each curve) or
    :data:`WRAPPED` (as stored, in [0, 360)) inside the block."""
    if convention not in (WRAPPED, UNWRAPPED):
        raise HertzsweepError(f"phase convention: expected {WRAPPED} or {UNWRAPPED}")
    token = _PHASE.set(convention)
    try:
        yield
    finally:
        _PHASE.reset(token)


WRAP_STEP = 270.0  # [degree] a step between neighbours beyond this is a wrap of 360; a
# smaller one is kept: a jump of the response moves H2's phase by up to about 180 degrees


def unwrap_degrees(y: np.ndarray, low: float = -180.0) -> np.ndarray:
    """A phase curve [degree] made continuous where it wraps: a step of more than
    :data:`WRAP_STEP` between finite neighbours is taken as a wrap of 360 (a jump of the
    response, smaller, is kept as it is); the curve is then moved by a multiple of 360 so
    that its first finite value lies in ``[low, low + 360)``. NaN stays NaN (and does not
    break the continuity)."""
    y = np.array(y, dtype=float)
    finite = np.flatnonzero(np.isfinite(y))
    if finite.size:
        values = np.unwrap(y[finite], discont=WRAP_STEP, period=360.0)
        values -= 360.0 * np.floor((values[0] - low) / 360.0)
        y[finite] = values
    return y


def phase_window(values: np.ndarray) -> float:
    """The lower end, in [-180, 180), of the 360-degree window the curves of one panel
    start in: the middle of the widest gap between the panel's phases (taken modulo
    360), so that curves of different levels and directions are drawn alike and none is
    cut where the data leave room (H1's lag, 0 to 180: the window [-90, 270))."""
    phases = np.sort(np.mod(np.asarray(values, dtype=float)[np.isfinite(values)], 360.0))
    if phases.size == 0:
        return -180.0
    gaps = np.diff(np.r_[phases, phases[0] + 360.0])
    widest = int(np.argmax(gaps))
    middle = phases[widest] + 0.5 * gaps[widest]
    return float(np.mod(middle + 180.0, 360.0) - 180.0)


def drawn_phase(y: np.ndarray, low: float = -180.0) -> np.ndarray:
    """A phase curve as the current :func:`phase_convention` draws it (``low``: the
    panel's :func:`phase_window`)."""
    return np.asarray(y, dtype=float) if _PHASE.get() == WRAPPED else unwrap_degrees(y, low)


# --------------------------------------------------------------------------- selection
def select_sigma(ds: xr.Dataset, sigma: Sequence[float]) -> xr.Dataset:
    """The dataset at the given input levels (each must match one within 1e-9 relative)."""
    if "sigma" not in ds.dims:
        raise HertzsweepError("--sigma: this dataset has no sigma dimension")
    held = ds.sigma.values
    index = []
    for value in sigma:
        match = np.flatnonzero(np.isclose(held, value, rtol=1e-9, atol=0.0))
        if match.size == 0:
            raise HertzsweepError(
                f"--sigma: {value:g} is not in the dataset (it holds {_list(held)})"
            )
        index.append(int(match[0]))
    return ds.isel(sigma=index)


def select_harmonics(ds: xr.Dataset, harmonics: Sequence[float | str] | None) -> xr.Dataset:
    """The dataset restricted to the given harmonic orders (all when None): numbers, or
    texts such as ``"2"``, ``"1/2"`` (:func:`~hertzsweep.core.lockin.parse_order`)."""
    if harmonics is None:
        return ds
    held = [float(k) for k in ds.harmonic.values]
    wanted = []
    for k in harmonics:
        try:
            wanted.append(parse_order(k))
        except ValueError as exc:
            raise HertzsweepError(f"--harmonic: {exc}") from None
    missing = [k for k in wanted if not np.isclose(held, k, rtol=1e-9, atol=0.0).any()]
    if missing:
        raise HertzsweepError(
            f"--harmonic: {_orders(missing)} not in the dataset (it holds {_orders(held)})"
        )
    index = [int(np.flatnonzero(np.isclose(held, k, rtol=1e-9, atol=0.0))[0]) for k in wanted]
    return ds.isel(harmonic=index)


# --------------------------------------------------------------------------- helpers
def _list(values) -> str:
    return ", ".join(f"{v:g}" for v in np.asarray(values, dtype=float))


def _orders(values) -> str:
    """Orders as text: ``1/2, 1, 3/2``."""
    return ", ".join(order_label(k) for k in np.asarray(values, dtype=float))


def panel_size(with_phase: bool, rows: int) -> tuple[float, float]:
    """Figure size [in] of a sweep or branch figure: one row per harmonic, amplitude
    (and phase) side by side."""
    return (11.0, 1.0 + 3.2 * rows) if with_phase else (8.0, 1.4 + 3.6 * rows)


def _new_figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _f0(ds: xr.Dataset) -> float:
    """f0 [Hz], the rig's natural frequency, from the global attributes (NaN if absent)."""
    return float(ds.attrs.get("natural_frequency", np.nan))


def _hz_axis(ax, f0: float, where: str = "top") -> None:
    """A second frequency axis in Hz, ``f = w f0`` (eq. 15)."""
    if not np.isfinite(f0) or f0 <= 0:
        return
    functions = (lambda w: w * f0, lambda f: f / f0)
    if where == "right":
        ax.secondary_yaxis("right", functions=functions).set_ylabel(HZ_LABEL)
    else:
        ax.secondary_xaxis("top", functions=functions).set_xlabel(HZ_LABEL)


def _sigma_label(sigma: float) -> str:
    return rf"$\sigma$ = {100.0 * sigma:.3g} %"


def _colour(i: int) -> str:
    return COLOURS[i % len(COLOURS)]


def _amplitude_label(k: float) -> str:
    return f"$H_{{{order_label(k)}}}$ amplitude of $N/F_s$ [1]"


def _phase_label(k: float) -> str:
    unwrapped = ", unwrapped" if _PHASE.get() == UNWRAPPED else ""
    return f"$H_{{{order_label(k)}}}$ phase lag{unwrapped} [degree]"


def _phase_axis(ax) -> None:
    """Ticks every 90 degrees; the wrapped convention's fixed range [0, 360]."""
    if _PHASE.get() == WRAPPED:
        ax.set_ylim(-5.0, 365.0)
        ax.set_yticks([0, 90, 180, 270, 360])
    else:
        ax.yaxis.set_major_locator(MultipleLocator(90.0))


def _title(ds: xr.Dataset, text: str) -> str:
    """A figure title with the damping of the dataset, e.g. ``(zeta = 1 %, contact damping
    n = 1.5)``; a value the dataset does not hold as an attribute (a study's grid
    dimension) is left out."""
    parts = []
    if "damping_ratio" in ds.attrs:
        parts.append(rf"$\zeta$ = {100.0 * float(ds.attrs['damping_ratio']):.3g} %")
    law = str(ds.attrs.get("damping_law", ""))
    if law == "contact":
        exponent = ds.attrs.get("damping_exponent")
        parts.append("contact damping" + ("" if exponent is None else f" n = {float(exponent):g}"))
    elif law:
        parts.append(law)
    return f"{text}  ({', '.join(parts)})" if parts else text


def _direction_handles(directions: Sequence[str], simulated: bool = False) -> list[Line2D]:
    """Legend entries of the sweep directions: up filled, down open (``simulated``: said
    so, where the figure also shows other curves)."""
    prefix = "simulated " if simulated else ""
    return [
        Line2D(
            [],
            [],
            ls="none",
            marker="o",
            ms=6,
            color="0.2",
            mfc="0.2" if direction == "up" else "none",
            label=f"{prefix}{direction} sweep",
        )
        for direction in directions
    ]


def _flag_handles(flags: set[str]) -> list[Line2D]:
    """Legend entries of the dwells drawn apart (:func:`_sweep_markers`), those drawn."""
    return [
        Line2D([], [], ls="none", marker=marker, ms=7, color="0.2", mfc="none", label=label)
        for marker, label in (NOT_SETTLED, NOT_PERIODIC, MULTI_PERIOD)
        if label in flags
    ] + [
        Line2D([], [], color="0.2", lw=1.0, ls=style, label=label)
        for style, label in SUBHARMONIC_JUMPS.values()
        if label in flags
    ]


def _sweep_legend(
    ax, sigmas: np.ndarray, directions: Sequence[str], flags: set[str] = frozenset()
) -> None:
    handles = [
        Line2D([], [], ls="none", marker="o", ms=6, color=_colour(i), label=_sigma_label(s))
        for i, s in enumerate(sigmas)
    ]
    handles += _direction_handles(directions) + _flag_handles(flags)
    ax.legend(handles=handles, fontsize="small", loc="best")


def _label_harmonic_axes(axes, orders, with_phase: bool, f0: float) -> None:
    """Labels, grid and the Hz axis of a harmonics figure (a row per order, amplitude and
    optionally phase), shared by the sweep and branch figures."""
    for row, k in enumerate(orders):
        axes[row, 0].set_ylabel(_amplitude_label(k))
        if with_phase:
            axes[row, 1].set_ylabel(_phase_label(k))
            _phase_axis(axes[row, 1])
    for ax in axes.ravel():
        ax.grid(True, lw=0.3)
    for ax in axes[-1]:
        ax.set_xlabel(W_LABEL)
    for ax in axes[0]:
        _hz_axis(ax, f0)


def dwell_flags(ds: xr.Dataset, direction: str, i: int) -> tuple[np.ndarray, np.ndarray]:
    """``(not_settled, not_periodic)`` masks of one sweep's dwells (all False where the
    dataset has no such flag); a settled dwell that is not periodic is only the second."""
    one = ds.sel(direction=direction).isel(sigma=i)
    size = ds.sizes["frequency_ratio"]
    unsettled = one.settled.values == 0 if "settled" in one else np.zeros(size, bool)
    aperiodic = one.periodic.values == 0 if "periodic" in one else np.zeros(size, bool)
    return unsettled, aperiodic & ~unsettled


def multi_period_flags(ds: xr.Dataset, direction: str, i: int) -> np.ndarray:
    """Mask of one sweep's dwells that repeat after n > 1 periods (``response_period``;
    all False where the dataset has none), among those :func:`dwell_flags` finds settled
    but not periodic."""
    one = ds.sel(direction=direction).isel(sigma=i)
    if "response_period" not in one:
        return np.zeros(ds.sizes["frequency_ratio"], bool)
    return dwell_flags(ds, direction, i)[1] & (one.response_period.values > 1)


def _subharmonic_jumps(axes, ds: xr.Dataset, colour_of=None) -> set[str]:
    """Vertical marks at each sweep's jumps onto and off the period-2 response
    (:data:`SUBHARMONIC_JUMPS`) on every panel, in the colour of its sigma; returns the
    legend labels of those drawn (none where no sweep has one)."""
    drawn: set[str] = set()
    for name, (style, label) in SUBHARMONIC_JUMPS.items():
        if name not in ds:
            continue
        values = ds[name].transpose("direction", "sigma").values
        for i in range(ds.sizes["sigma"]):
            for w in values[:, i][np.isfinite(values[:, i])]:
                for ax in axes:
                    ax.axvline(w, color=(colour_of or _colour)(i), lw=1.0, ls=style, alpha=0.7)
                drawn.add(label)
    return drawn


def _sweep_markers(
    ax,
    ds: xr.Dataset,
    values: xr.DataArray,
    phase: bool = False,
    colour_of=None,
    alpha: float = 1.0,
    window: float | None = None,
) -> set[str]:
    """``values`` (direction, sigma, frequency_ratio) as markers: one colour per sigma,
    up filled and down open; dwells that did not settle as crosses, settled ones that do
    not repeat every period as triangles (:data:`NOT_SETTLED`, :data:`NOT_PERIODIC`).
    ``phase``: drawn in the current :func:`phase_convention`, starting in the
    :func:`phase_window` of ``values`` (or ``window``). Returns the legend labels of the
    flags drawn."""
    w = ds.frequency_ratio.values
    flags: set[str] = set()
    low = window if window is not None else phase_window(values.values) if phase else 0.0
    for i in range(ds.sizes["sigma"]):
        colour = (colour_of or _colour)(i)
        for direction in ds.direction.values:
            y = values.sel(direction=direction).isel(sigma=i).values
            y = drawn_phase(y, low) if phase else np.asarray(y, dtype=float)
            unsettled, aperiodic = dwell_flags(ds, direction, i)
            multiple = multi_period_flags(ds, direction, i)
            face = colour if direction == "up" else "none"
            style = dict(ls="none", color=colour, mew=0.8, alpha=alpha)
            converged = np.where(unsettled | aperiodic, np.nan, y)
            ax.plot(w, converged, marker="o", ms=MARKER_SIZE, mfc=face, **style)
            for mask, (marker, label) in (
                (unsettled, NOT_SETTLED),
                (aperiodic & ~multiple, NOT_PERIODIC),
                (multiple, MULTI_PERIOD),
            ):
                if np.any(mask & np.isfinite(y)):
                    ax.plot(w[mask], y[mask], marker=marker, ms=FLAG_MARKER_SIZE, mfc=face, **style)
                    flags.add(label)
    return flags


# --------------------------------------------------------------------------- sweep
def sweep_figure(
    ds: xr.Dataset, view: str = "harmonics", harmonics: Sequence[float | str] | None = None
) -> Figure:
    """Simulated stepped-sine sweeps as the rig shows them (Figures 3-6, 9, 10).

    ``harmonics``: one row per harmonic, amplitude and phase side by side; ``amplitude``:
    amplitudes only; ``forces``: N_max and N_min, and the contact-loss share (Figure 6).
    Up sweeps are filled markers, down sweeps open ones, one colour per sigma; dwells that
    did not settle or do not repeat every period are drawn apart (:func:`_sweep_markers`).
    """
    if view == "forces":
        return _sweep_forces(ds)
    ds = select_harmonics(ds, harmonics)
    orders = [float(k) for k in ds.harmonic.values]
    with_phase = view == "harmonics"
    fig = _new_figure(*panel_size(with_phase, len(orders)))
    axes = fig.subplots(len(orders), 2 if with_phase else 1, squeeze=False, sharex=True)
    f0 = _f0(ds)
    flags: set[str] = set()
    for row, k in enumerate(orders):
        flags |= _sweep_markers(axes[row, 0], ds, ds.amplitude.sel(harmonic=k))
        if with_phase:
            phase = defined_phase(ds.phase.sel(harmonic=k), ds.amplitude.sel(harmonic=k))
            flags |= _sweep_markers(axes[row, 1], ds, phase, phase=True)
    flags |= _subharmonic_jumps(axes.ravel(), ds)
    _label_harmonic_axes(axes, orders, with_phase, f0)
    _sweep_legend(axes[0, 0], ds.sigma.values, list(ds.direction.values), flags)
    text = "Simulated stepped-sine sweep, harmonics of $N/F_s$"
    fig.suptitle(_title(ds, text), fontsize="medium")
    return fig


PHASE_FLOOR = 1e-9  # an amplitude below this share of its order's largest has no phase


def phase_floor(amplitude: xr.DataArray) -> float:
    """The amplitude below which an order's phase is not drawn: :data:`PHASE_FLOOR` of
    its largest."""
    finite = np.abs(amplitude.values[np.isfinite(amplitude.values)])
    return PHASE_FLOOR * float(finite.max()) if finite.size else 0.0


def defined_phase(
    phase: xr.DataArray, amplitude: xr.DataArray, floor: float | None = None
) -> xr.DataArray:
    """The phases whose amplitude is above ``floor`` (default :func:`phase_floor` of
    ``amplitude``): a half order read on a period-1 response is round-off (1e-12 of its
    size on the period-2 response), and so is its phase, left undrawn (NaN)."""
    floor = phase_floor(amplitude) if floor is None else floor
    return phase.where(np.abs(amplitude) > floor)


def _sweep_forces(ds: xr.Dataset) -> Figure:
    fig = _new_figure(8.0, 7.0)
    top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=[2.0, 1.0])
    flags = _sweep_markers(top, ds, ds.force_max)
    flags |= _sweep_markers(top, ds, ds.force_min)
    top.axhline(1.0, color="0.4", lw=0.8, ls="--")
    top.axhline(0.0, color="0.4", lw=0.8)
    top.set_ylabel(r"$N_{max}/F_s$ (above 1), $N_{min}/F_s$ (below 1) [1]")
    flags |= _sweep_markers(bottom, ds, 100.0 * ds.contact_loss_fraction)
    flags |= _subharmonic_jumps((top, bottom), ds)
    bottom.set_ylabel("time out of contact, share of the period [%]")
    bottom.set_ylim(-3.0, 100.0)
    bottom.set_xlabel(W_LABEL)
    for ax in (top, bottom):
        ax.grid(True, lw=0.3)
    _hz_axis(top, _f0(ds))
    _sweep_legend(top, ds.sigma.values, list(ds.direction.values), flags)
    text = "Simulated stepped-sine sweep, extremes of the normal force"
    fig.suptitle(_title(ds, text), fontsize="medium")
    return fig


# --------------------------------------------------------------------------- branch
def stability_segments(stable: np.ndarray) -> list[tuple[int, int, bool]]:
    """Runs ``(start, stop, stable)`` of equal stability along a branch; each run is
    extended by one point into the next so the drawn curve has no gaps. Points with
    ``stable < 0`` (padding) end the branch."""
    stable = np.asarray(stable)
    valid = int(np.argmax(stable < 0)) if np.any(stable < 0) else stable.size
    runs: list[tuple[int, int, bool]] = []
    start = 0
    for i in range(1, valid + 1):
        if i == valid or stable[i] != stable[start]:
            runs.append((start, min(i + 1, valid), bool(stable[start] == 1)))
            start = i
    return runs


def break_wraps(x: np.ndarray, y: np.ndarray, phase: bool) -> tuple[np.ndarray, np.ndarray]:
    """A phase curve with a gap (NaN) where it wraps between 360 and 0 degrees, so no
    vertical line is drawn there; other curves unchanged."""
    if not phase or y.size < 2:
        return x, y
    wraps = np.flatnonzero(np.abs(np.diff(y)) > 180.0) + 1
    return np.insert(x.astype(float), wraps, np.nan), np.insert(y.astype(float), wraps, np.nan)


def branch_figure(
    ds: xr.Dataset,
    view: str = "harmonics",
    harmonics: Sequence[float | str] | None = None,
    overlay: xr.Dataset | None = None,
) -> Figure:
    """Periodic-orbit branches (Figures 13, 14): stable solid, unstable dotted, the folds
    (and period doublings, Neimark-Sacker points) marked; an optional simulated sweep
    ``overlay`` as markers, up filled and down open, labelled as simulated (the paper's
    markers in these figures are measurements). Phases are unwrapped along each branch
    in arclength order, branches and sweep alike starting in the panel's
    :func:`phase_window` (:func:`phase_convention`)."""
    ds = select_harmonics(ds, harmonics)
    orders = [float(k) for k in ds.harmonic.values]
    with_phase = view == "harmonics"
    fig = _new_figure(*panel_size(with_phase, len(orders)))
    axes = fig.subplots(len(orders), 2 if with_phase else 1, squeeze=False, sharex=True)
    sigmas = ds.sigma.values
    floors = {k: phase_floor(ds.amplitude.sel(harmonic=k)) for k in orders}
    windows = {k: phase_window(_panel_phases(ds, overlay, k, floors[k])) for k in orders}
    kinds_seen: set[str] = set()
    doubled = False
    for i in range(sigmas.size):
        for one in _branches(ds.isel(sigma=i)):
            multiple = int(one.period_multiple) if "period_multiple" in one else 1
            doubled |= multiple > 1
            width = 1.0 if multiple == 1 else 0.7  # period-doubled branches drawn thinner
            w = one.frequency_ratio.values
            runs = stability_segments(one.stable.values)
            wrapped = _PHASE.get() == WRAPPED
            for row, k in enumerate(orders):
                panels = [(axes[row, 0], one.amplitude.sel(harmonic=k).values, False)]
                if with_phase:
                    defined = defined_phase(
                        one.phase.sel(harmonic=k), one.amplitude.sel(harmonic=k), floors[k]
                    )
                    phase = drawn_phase(defined.values, windows[k])
                    panels.append((axes[row, 1], phase, wrapped))
                for ax, y, breaks in panels:
                    for start, stop, stable in runs:
                        ax.plot(
                            *break_wraps(w[start:stop], y[start:stop], breaks),
                            color=_colour(i),
                            ls="-" if stable else ":",
                            lw=(2.0 if stable else 1.4) * width,
                        )
                    kinds_seen |= _mark_bifurcations(ax, one, y, _colour(i))
    flags: set[str] = set()
    if overlay is not None:
        flags = _overlay_sweep(axes, overlay, sigmas, orders, windows if with_phase else None)
    _label_harmonic_axes(axes, orders, with_phase, _f0(ds))
    handles = [
        Line2D([], [], color=_colour(i), lw=2, label=_sigma_label(s)) for i, s in enumerate(sigmas)
    ]
    handles += [
        Line2D([], [], color="0.2", lw=2, label="stable"),
        Line2D([], [], color="0.2", lw=1.4, ls=":", label="unstable"),
    ]
    if doubled:
        handles.append(Line2D([], [], color="0.2", lw=1.4, label="period-doubled (thin)"))
    handles += [
        Line2D(
            [],
            [],
            ls="none",
            marker=FOLD_MARKERS[kind][0],
            color="k",
            mfc="w",
            label=FOLD_MARKERS[kind][1],
        )
        for kind in FOLD_MARKERS
        if kind in kinds_seen
    ]
    if overlay is not None:
        directions = [str(d) for d in overlay.direction.values]
        handles += _direction_handles(directions, simulated=True) + _flag_handles(flags)
    axes[0, 0].legend(handles=handles, fontsize="small", loc="best")
    fig.suptitle(_title(ds, "Periodic orbits (shooting, continuation)"), fontsize="medium")
    return fig


def _branches(one: xr.Dataset) -> list[xr.Dataset]:
    """The branches of one sigma of a branch dataset: itself, or with a ``branch``
    dimension (period-doubled branches followed) each branch that has points."""
    if "branch" not in one.dims:
        return [one]
    return [
        one.isel(branch=b)
        for b in range(one.sizes["branch"])
        if int(one.period_multiple.values[b]) > 0
    ]


def _mark_bifurcations(ax, one: xr.Dataset, y: np.ndarray, colour: str) -> set[str]:
    """Mark the located bifurcations on a panel: at the nearest branch point's value of
    the panel's quantity (the H1 amplitude panel gets the exact located value)."""
    if "bifurcation_frequency_ratio" not in one:
        return set()
    seen = set()
    w = one.frequency_ratio.values
    h1 = one.amplitude.isel(harmonic=first_harmonic_index(one.harmonic.values)).values
    for wf, kind, af in zip(
        one.bifurcation_frequency_ratio.values,
        one.bifurcation_kind.values,
        one.bifurcation_amplitude.values,
        strict=True,
    ):
        kind = str(kind)
        if kind not in FOLD_MARKERS or not np.isfinite(wf):
            continue
        distance = np.abs(w - wf) + np.abs(h1 - af) / max(np.nanmax(np.abs(h1)), 1e-300)
        if not np.any(np.isfinite(distance)):
            continue
        j = int(np.nanargmin(distance))
        value = af if np.array_equal(y, h1, equal_nan=True) else y[j]
        ax.plot(
            [wf],
            [value],
            ls="none",
            marker=FOLD_MARKERS[kind][0],
            ms=7,
            mfc="white",
            mec=colour,
            mew=1.6,
            zorder=5,
        )
        seen.add(kind)
    return seen


def _panel_phases(
    ds: xr.Dataset, overlay: xr.Dataset | None, k: float, floor: float = 0.0
) -> np.ndarray:
    """Every phase of harmonic k a branch panel draws: the branch's (where defined,
    :func:`defined_phase`) and the overlay's."""
    phase = defined_phase(ds.phase.sel(harmonic=k), ds.amplitude.sel(harmonic=k), floor)
    values = [np.ravel(phase.values)]
    if overlay is not None and "phase" in overlay and k in overlay.harmonic.values:
        values.append(np.ravel(overlay.phase.sel(harmonic=k).values))
    return np.concatenate(values)


def _overlay_sweep(
    axes, sweep: xr.Dataset, sigmas, orders, windows: dict[int, float] | None
) -> set[str]:
    """A simulated sweep's markers over a branch, in the colour of the branch of the same
    sigma (:func:`_sweep_markers`), phases (``windows``: per harmonic, None without a
    phase column) in the branch's window; returns the flags drawn."""
    if sweep.attrs.get("hertzsweep_kind") != "sweep":
        raise HertzsweepError("--overlay: expected a sweep dataset")
    held = [j for j, s in enumerate(sweep.sigma.values) if np.isclose(sigmas, s, rtol=1e-9).any()]
    sweep = sweep.isel(sigma=held)
    colours = [
        _colour(int(np.flatnonzero(np.isclose(sigmas, s, rtol=1e-9))[0]))
        for s in sweep.sigma.values
    ]
    flags: set[str] = set()
    for row, k in enumerate(orders):
        if k not in sweep.harmonic.values:
            continue
        one = sweep.sel(harmonic=k)
        flags |= _sweep_markers(
            axes[row, 0], one, one.amplitude, colour_of=colours.__getitem__, alpha=0.8
        )
        if windows is not None:
            flags |= _sweep_markers(
                axes[row, 1],
                one,
                one.phase,
                phase=True,
                colour_of=colours.__getitem__,
                alpha=0.8,
                window=windows[k],
            )
    return flags


# --------------------------------------------------------------------------- trace
def _scalar(ds: xr.Dataset, name: str, default=np.nan):
    if name in ds.variables and ds[name].ndim == 0:
        return ds[name].item()
    value = ds.attrs.get(name, default)
    if isinstance(value, np.ndarray) and value.size == 1:
        return value.item()
    return value


def trace_figure(data: xr.Dataset | Sequence[xr.Dataset], view: str = "both") -> Figure:
    """Time histories and spectra (Figures 7, 8, 12, 16, 17): one row per sigma of each
    dataset given (several datasets stack, as Figure 12 stacks three frequencies).

    ``time``: N/F_s against time in ms from the start of the record, flights (out of
    contact) shaded; ``spectrum``: amplitude of N/F_s against the harmonic order k w;
    ``both``: the two side by side.
    """
    datasets = [data] if isinstance(data, xr.Dataset) else list(data)
    rows = [(ds, i) for ds in datasets for i in range(ds.sizes["sigma"])]
    if not rows:
        raise HertzsweepError("no trace to draw (empty sigma dimension)")
    columns = {"both": 2, "time": 1, "spectrum": 1}[view]
    width = {"both": 13.0, "time": 10.0, "spectrum": 7.0}[view]
    fig = _new_figure(width, 0.9 + 2.6 * len(rows))
    axes = fig.subplots(
        len(rows),
        columns,
        squeeze=False,
        width_ratios=[2.6, 1.0] if view == "both" else None,
    )
    for r, (ds, i) in enumerate(rows):
        one = ds.isel(sigma=i)
        title = _trace_title(ds, one)
        c = 0
        if view in ("both", "time"):
            _time_panel(axes[r, 0], one)
            axes[r, 0].set_title(title, fontsize="medium", loc="left")
            c = 1
        if view in ("both", "spectrum"):
            _spectrum_panel(axes[r, c], one)
            if view == "spectrum":
                axes[r, c].set_title(title, fontsize="medium", loc="left")
    fig.suptitle(_title(datasets[0], "Steady-state normal force"), fontsize="medium")
    return fig


def _trace_title(ds: xr.Dataset, one: xr.Dataset) -> str:
    w = float(_scalar(ds, "frequency_ratio"))
    f0 = _f0(ds)
    branch = _scalar(ds, "branch", "")
    text = rf"{_sigma_label(float(one.sigma))}, $\varpi$ = {w:.4g} ({w * f0:.1f} Hz)"
    if branch:
        text += f", {branch} branch"
    if "contact_loss_fraction" in one:
        text += f": out of contact {100.0 * float(one.contact_loss_fraction):.0f} %"
    if "flight_time" in one and float(one.flight_time) > 0:
        text += f", longest flight {1e3 * float(one.flight_time):.2f} ms"
    if "settled" in one and int(one.settled) == 0:
        text += f" [{NOT_SETTLED[1]}]"
    elif "periodic" in one and int(one.periodic) == 0:
        text += f" [{NOT_PERIODIC[1]}]"
    return text


def _time_panel(ax, one: xr.Dataset) -> None:
    t_ms = 1e3 * (one.time.values - one.time.values[0])
    force = one.normal_force.values
    flying = one.in_contact.values == 0
    if np.any(flying):
        ax.fill_between(
            t_ms,
            0.0,
            1.0,
            where=flying,
            step="mid",
            color="0.85",
            lw=0,
            transform=ax.get_xaxis_transform(),
            label="out of contact",
        )
    ax.plot(t_ms, force, color="k", lw=1.0)
    ax.axhline(1.0, color="0.4", lw=0.8, ls="--")
    ax.axhline(0.0, color="0.4", lw=0.6)
    ax.set_xlim(t_ms[0], t_ms[-1])
    ax.set_xlabel("time $t$ [ms]")
    ax.set_ylabel(FORCE_LABEL)
    ax.grid(True, lw=0.3)
    if np.any(flying):
        ax.legend(fontsize="small", loc="upper right")


def _spectrum_panel(ax, one: xr.Dataset) -> None:
    order = one.harmonic_order.values
    amplitude = one.spectrum.values
    shown = (order > 0) & (order <= SPECTRUM_ORDERS)
    ax.vlines(order[shown], 0.0, amplitude[shown], color="k", lw=1.6)
    ax.set_xlim(0.0, SPECTRUM_ORDERS)
    ax.set_ylim(bottom=0.0)
    ax.set_xticks(np.arange(0, int(SPECTRUM_ORDERS) + 1))
    ax.set_xlabel(r"harmonic order $k$ (multiples of $\varpi$) [1]")
    ax.set_ylabel(r"amplitude of $N/F_s$ [1]")
    ax.grid(True, lw=0.3)


# --------------------------------------------------------------------------- study
AXIS_SYMBOLS = {  # grid dimension -> symbol in labels
    "damping_exponent": "n",
    "damping_ratio": r"$\zeta$",
    "damping_law": "law",
    "sigma": r"$\sigma$",
    "steps_per_period": "N",
}


def study_jumps(ds: xr.Dataset) -> xr.DataArray:
    """The downward jump frequency ratio of a study (the up one when only up sweeps ran):
    ``jump_frequency_ratio`` at direction ``down``."""
    return _study_variable(ds, "jump_frequency_ratio", "down")


SUBHARMONIC_VIEW = "subharmonic"  # a study's view of where its sweeps met the subharmonic


def study_subharmonic(ds: xr.Dataset) -> xr.DataArray:
    """Where a study's sweeps jumped onto the period-2 response:
    ``subharmonic_onset_frequency_ratio`` at direction ``up`` (the down one when only
    down sweeps ran)."""
    return _study_variable(ds, "subharmonic_onset_frequency_ratio", "up")


def _study_variable(ds: xr.Dataset, name: str, direction: str) -> xr.DataArray:
    """``ds[name]`` at ``direction`` (the study's first direction when it has not that
    one); a HertzsweepError when the study has no such variable."""
    if name not in ds:
        raise HertzsweepError(f"study dataset has no {name!r} to draw")
    values = ds[name]
    if "direction" in values.dims:
        directions = [str(d) for d in ds.direction.values]
        index = directions.index(direction) if direction in directions else 0
        values = values.isel(direction=index)
    return values


def study_figure(ds: xr.Dataset, view: str = "jumps") -> Figure:
    """The jump frequency against sigma, one curve per damping law (Figure 15); every
    other grid dimension also gets its own curve. The ``subharmonic`` view draws the
    subharmonic onset instead (:func:`study_subharmonic`), beside the edge of the
    small-amplitude (Mathieu) estimate's instability band
    (:func:`hertzsweep.core.subharmonic.mathieu_tongue`)."""
    subharmonic = view == SUBHARMONIC_VIEW
    jump = study_subharmonic(ds) if subharmonic else study_jumps(ds)
    direction = str(jump.direction.values) if "direction" in jump.coords else "down"
    x_dim = "sigma" if "sigma" in jump.dims else jump.dims[0]
    others = [d for d in jump.dims if d != x_dim]
    fig = _new_figure(8.5, 6.0)
    ax = fig.subplots()
    x = jump[x_dim].values.astype(float)
    scale = 100.0 if x_dim == "sigma" else 1.0
    markers = itertools.cycle("osD^vP*X")
    doubtful = xr.zeros_like(jump, dtype=bool) if subharmonic else unconverged_jumps(ds, jump)
    flagged = False
    for i, index in enumerate(itertools.product(*(range(jump.sizes[d]) for d in others))):
        where = dict(zip(others, index, strict=True))
        curve = jump.isel(where)
        label = ", ".join(
            f"{AXIS_SYMBOLS.get(d, d)} = {_format_value(curve[d].values)}" for d in others
        )
        ax.plot(
            scale * x,
            curve.values,
            marker=next(markers),
            ms=5,
            lw=1.4,
            color=_colour(i),
            label=label or None,
        )
        mask = doubtful.isel(where).transpose(x_dim).values
        if np.any(mask):
            style = dict(ls="none", marker="x", ms=9, mew=1.4, color="k", zorder=5)
            ax.plot(scale * x[mask], curve.values[mask], **style)
            flagged = True
    if flagged:
        ax.plot([], [], ls="none", marker="x", ms=9, mew=1.4, color="k", label=JUMP_FLAG)
    estimate = subharmonic and x_dim == "sigma" and _mathieu_edge(ax, ds, x, direction)
    drawn = x[np.any(np.isfinite(jump.transpose(x_dim, ...).values.reshape(x.size, -1)), axis=1)]
    if drawn.size > 1 and drawn.min() > 0 and drawn.max() / drawn.min() > 10:
        ax.set_xscale("log")  # levels spread over decades (0.2 % to 8 %)
        ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0, 7.0)))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(
        r"input level $\sigma = F/F_s$ [%]" if x_dim == "sigma" else _grid_label(ds, x_dim)
    )
    quantity = "subharmonic onset" if subharmonic else f"{direction}ward jump"
    ax.set_ylabel(rf"{quantity} frequency ratio $\varpi$ [1]")
    ax.grid(True, which="both", lw=0.3)
    _hz_axis(ax, _f0(ds), where="right")
    if others or flagged or estimate:
        ax.legend(fontsize="small", loc="best")
    failed = ds.case_failed.broadcast_like(jump) == 1 if "case_failed" in ds else False
    if np.any(np.isnan(jump.values) & ~np.asarray(failed)):
        ax.text(  # top right: the curves fall from the upper left, the legend goes below
            0.99,
            0.99,
            "a missing point: no jump within the swept range"
            if not subharmonic
            else "a missing point: no period-2 response met",
            transform=ax.transAxes,
            fontsize="x-small",
            color="0.3",
            ha="right",
            va="top",
        )
    text = f"{direction.capitalize()}ward jump frequency against input level"
    if subharmonic:
        text = f"Subharmonic onset ({direction} sweeps) against input level"
    step = ds.attrs.get("sweep_step")
    if isinstance(step, int | float | np.number):  # a jump is known to one grid step
        text += rf", frequency step $\Delta\varpi$ = {float(step):g}"
    fig.suptitle(_title(ds, text), fontsize="medium")
    return fig


JUMP_FLAG = "read between dwells not settled or not periodic"  # legend of a doubtful jump


def unconverged_jumps(ds: xr.Dataset, jump: xr.DataArray) -> xr.DataArray:
    """Where a jump (:func:`study_jumps`) was read between two dwells of which one did
    not settle or does not repeat every period: the dwell at the jump frequency and the
    next one in sweep order. All False when the dataset has no such flags."""
    flagged = xr.zeros_like(jump, dtype=bool)
    if "settled" not in ds and "periodic" not in ds:
        return flagged
    bad = xr.zeros_like(ds.jump_frequency_ratio, dtype=bool)
    bad = bad.expand_dims(frequency_ratio=ds.frequency_ratio.values).copy()
    for name in ("settled", "periodic"):
        if name in ds:
            bad = bad | (ds[name] == 0)
    if "direction" in jump.coords and "direction" in bad.dims:
        bad = bad.sel(direction=jump.direction.values)
    direction = str(jump.direction.values) if "direction" in jump.coords else "down"
    step = -1 if direction == "down" else 1
    w = ds.frequency_ratio.values
    bad = bad.transpose(*jump.dims, "frequency_ratio").values
    values = jump.values
    out = np.zeros(values.shape, dtype=bool)
    for index in np.ndindex(values.shape):
        match = np.flatnonzero(np.isclose(w, values[index], rtol=0.0, atol=1e-9))
        if match.size:
            j = int(match[0])
            pair = [j, j + step] if 0 <= j + step < w.size else [j]
            out[index] = bool(np.any(bad[index][pair]))
    flagged.values = out
    return flagged


def _mathieu_edge(ax, ds: xr.Dataset, sigma: np.ndarray, direction: str) -> bool:
    """Draw the small-amplitude estimate's edge of the period-1 instability band met by a
    sweep in ``direction`` (the lower edge going up, the upper going down) against sigma,
    for the scene's damping ratio when the study keeps one; False where it drew nothing."""
    from ..core.subharmonic import mathieu_tongue

    zeta = ds.attrs.get("damping_ratio")
    if not isinstance(zeta, int | float | np.number) or sigma.size == 0:
        return False
    levels = np.linspace(float(np.nanmin(sigma)), float(np.nanmax(sigma)), 200)
    bands = [mathieu_tongue(float(s), float(zeta)) for s in levels]
    edge = np.array([np.nan if b is None else b[0 if direction == "up" else 1] for b in bands])
    if not np.any(np.isfinite(edge)):
        return False
    label = rf"small-amplitude estimate ($\zeta$ = {float(zeta):g})"
    ax.plot(100.0 * levels, edge, ls="--", lw=1.2, color="0.35", label=label)
    return True


def _grid_label(ds: xr.Dataset, dim: str) -> str:
    """An axis label of a grid coordinate: its long name and units."""
    attributes = ds[dim].attrs
    name = attributes.get("long_name", dim)
    units = attributes.get("units")
    return f"{name} [{units}]" if units else name


def _format_value(value) -> str:
    value = np.asarray(value).item()
    return f"{value:g}" if isinstance(value, int | float) else str(value)


# --------------------------------------------------------------------------- accuracy
ERROR_VARIABLES = {  # variable -> (label, marker)
    "error_h1": ("$H_1$", "o"),
    "error_h2": ("$H_2$", "s"),
    "error_force": ("force extremes", "^"),
    "error_jump": ("jump frequencies", "D"),
}


def accuracy_figure(ds: xr.Dataset) -> Figure:
    """Error against cost (wall time of each setting's sweep), log-log, one marker per
    error measure (integration steps in files written before ``wall_time`` was the cost).

    The Pareto front (the settings no other beats in both cost and H1 error, the
    dataset's ``pareto`` flag) is the line through their H1 errors; the reference (zero
    error, off a log axis) is a vertical line at its cost; the target and the
    recommended setting are drawn when the dataset has them.
    """
    fig = _new_figure(9.0, 6.5)
    ax = fig.subplots()
    timed = "method" in ds  # the ladder spans methods: its cost is wall time
    cost = (ds.wall_time if timed else ds.cost_steps).values.astype(float)
    names = [n for n in ERROR_VARIABLES if n in ds]
    if "error_h1" not in names:
        raise HertzsweepError("accuracy dataset has no 'error_h1' to draw")
    for i, name in enumerate(names):
        error = ds[name].values.astype(float)
        label, marker = ERROR_VARIABLES[name]
        ax.plot(
            cost,
            np.where(error > 0, error, np.nan),
            ls="none",
            marker=marker,
            ms=6,
            color=_colour(i),
            mfc="none",
            label=f"error in {label}",
        )
    h1 = ds.error_h1.values.astype(float)
    h1 = np.where(h1 > 0, h1, np.nan)  # log axes: the reference's zero left out
    labels = [str(v) for v in ds.setting_label.values] if "setting_label" in ds else []
    if "pareto" in ds:
        _pareto_front(ax, cost, h1, ds.pareto.values == 1, labels)
    _accuracy_marks(ax, ds, cost, h1, labels)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall time [s]" if timed else "cost: integration steps [1]")
    ax.set_ylabel("error against the reference [1]")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize="small", loc="best")
    order = float(ds.attrs.get("observed_order", np.nan))
    text = "Accuracy against cost"
    if np.isfinite(order):
        text += f", observed order {order:.2f}"
    fig.suptitle(text, fontsize="medium")
    return fig


def _pareto_front(
    ax, cost: np.ndarray, h1: np.ndarray, on_front: np.ndarray, labels: list[str]
) -> None:
    """The Pareto front through the H1 errors, cheapest first, each point labelled."""
    front = np.flatnonzero(on_front)
    front = front[np.argsort(cost[front])]
    ax.plot(
        cost[front],
        h1[front],
        color="k",
        lw=2.0,
        marker="o",
        ms=7,
        label=r"Pareto front (error in $H_1$)",
    )
    for j in front:
        if labels and np.isfinite(h1[j]):
            ax.annotate(
                labels[j],
                (cost[j], h1[j]),
                fontsize="x-small",
                xytext=(4, 4),
                textcoords="offset points",
            )


def _accuracy_marks(
    ax, ds: xr.Dataset, cost: np.ndarray, h1: np.ndarray, labels: list[str]
) -> None:
    """The reference's cost, the target and the recommended setting, where the dataset
    names them."""
    reference = str(ds.attrs.get("reference_label", ""))
    if reference in labels:
        ax.axvline(
            cost[labels.index(reference)],
            color="0.3",
            ls=":",
            lw=1.2,
            label=f"reference: {reference}",
        )
    target = float(ds.attrs.get("target", np.nan))
    if np.isfinite(target):
        ax.axhline(target, color="0.3", ls="--", lw=1.0, label=f"target {target:g}")
    recommended = str(ds.attrs.get("recommended", ""))
    if recommended in labels:
        j = labels.index(recommended)
        ax.plot(
            [cost[j]],
            [h1[j]],
            ls="none",
            marker="*",
            ms=16,
            color="#ff7f0e",
            mec="k",
            label=f"recommended: {recommended}",
        )


# --------------------------------------------------------------------------- random
CONTACT_OPENS = 1.5  # q at which the compression d = 1 + 2q/3 reaches 0 (eq. 8)
LINEAR_FORCE_ZERO = 1.0  # q at which the linearised force 1 + q reaches 0
PDF_SIGMAS = 5.0  # a PDF panel spans the mean +- this many RMS of N/F_s
PDF_DECADES = 5.0  # and this many decades of density below its highest value
LOSS_FLOOR = 1e-6  # the lowest share of time out of contact drawn, without a measured one
WELCH_GRID = 8  # points of the linear model's quadrature per resolution or peak width
WELCH_CHUNK = 1 << 22  # its kernel's values formed at once (32 MiB)
RMS_LABEL = r"input level: RMS of $f = F/F_s$ [%]"


def random_figure(ds: xr.Dataset, view: str = "psd") -> Figure:
    """Random excitation (Part 2 of the paper: the rig under band-limited Gaussian
    noise), one view of a ``random`` dataset.

    ``psd``: the PSD of N/F_s per unit frequency ratio against w, log scale, one colour
    per level with its standard error as a band, and the linear model's ``|H|^2 S_f``
    for the lowest level (:func:`linear_model_psd`: as it is, and as the Welch estimate
    sees it); ``pdf``: the probability density of N/F_s, a panel per level, log scale,
    beside the Gaussian of the same mean and RMS; ``loss``: the share of time out of
    contact, with the Gaussian exceedances of the linear response
    (:func:`gaussian_exceedance`), and the PSD's peak frequency ratio, both against rms
    with their standard errors as error bars.

    Parameters
    ----------
    ds : xarray.Dataset
        A dataset of kind ``random`` (:func:`hertzsweep.output.dataset.random_dataset`).
    view : {"psd", "pdf", "loss"}

    Returns
    -------
    Figure
        9 x 6 in (``psd``), 4.2 in a column of up to three panels by 0.8 + 3.2 in a row
        (``pdf``), 12 x 5.5 in (``loss``).

    Raises
    ------
    HertzsweepError
        An unknown view, or a dataset without levels.
    """
    draw = {"psd": _random_psd, "pdf": _random_pdf, "loss": _random_loss}
    if view not in draw:
        raise HertzsweepError(f"random figure: unknown view {view!r} (psd, pdf or loss)")
    if ds.sizes.get("rms", 0) == 0:
        raise HertzsweepError("no random run to draw (empty rms dimension)")
    return draw[view](ds)


def _rms_label(rms: float) -> str:
    return f"rms {100.0 * rms:.3g} %"


def _random_band(ds: xr.Dataset) -> tuple[float, float]:
    low, high = np.asarray(ds.attrs["excitation_band"], dtype=float)
    return float(low), float(high)


def linear_model_psd(
    w: np.ndarray,
    rms: float,
    band: tuple[float, float],
    zeta: float,
    segment_periods: int | None = None,
) -> np.ndarray:
    """The linear model's one-sided PSD of N/F_s per unit w: ``|H(w)|^2 S_f`` with
    ``S_f = rms^2 / (w_high - w_low)`` on the band and 0 outside it
    (:func:`hertzsweep.core.excitation.transmissibility`).

    With ``segment_periods``, the mean of its Welch estimate instead: that PSD seen
    through the periodic Hann window of a segment of ``T = 2 pi segment_periods`` in tau,
    ``integral S(v) |W(w - v)|^2 dv / (2 pi integral w(t)^2 dt)``, which smooths a
    resonance narrower than a few ``1 / segment_periods`` (the peak of width ``2 zeta``).
    Integrated by the trapezoid rule on a grid :data:`WELCH_GRID` points a peak width or a
    resolution, whichever is finer.

    Parameters
    ----------
    w : float or array
        Frequency ratios (the Welch bins ``k / segment_periods`` for the smoothed PSD).
    rms : float
        The level: RMS of f = F/F_s.
    band : (float, float)
        ``(w_low, w_high)``.
    zeta : float
        ``damping.ratio``.
    segment_periods : int, optional
        The Welch segment in periods; None: the PSD itself.

    Returns
    -------
    numpy.ndarray
        float[w.size], per unit w; its sum over the bins ``k / segment_periods`` times
        ``1 / segment_periods`` is the variance ``rms^2 V`` (Parseval, to 1e-8).
    """
    from ..core.excitation import transmissibility

    low, high = band
    w = np.atleast_1d(np.asarray(w, dtype=float))
    flat = rms * rms / (high - low)

    def psd(v: np.ndarray) -> np.ndarray:
        inside = (v >= low) & (v < high)
        return np.where(inside, np.abs(transmissibility(v, zeta)) ** 2 * flat, 0.0)

    if segment_periods is None:
        return psd(w)
    resolution = 1.0 / segment_periods
    step = min(max(zeta, 1e-4), resolution) / WELCH_GRID
    v = np.linspace(low, high, int(np.ceil((high - low) / step)) + 1)
    density = psd(v)
    density[-1] = density[-2]  # the band's upper end (the lines stop below it)
    weight = np.full(v.size, v[1] - v[0])  # the trapezoid rule's weights
    weight[[0, -1]] *= 0.5
    length = 2.0 * np.pi * segment_periods
    # |W|^2 of the Hann window: T^2 (sinc(u) / 2 + (sinc(u - pi) + sinc(u + pi)) / 4)^2
    # at u = (w - v) T / 2, over 2 pi its energy 3 T / 8
    scale = length * length / (2.0 * np.pi * 3.0 * length / 8.0)
    out = np.empty(w.shape)
    rows = max(1, WELCH_CHUNK // v.size)
    for first in range(0, w.size, rows):
        u = (w[first : first + rows, None] - v[None, :]) * (length / 2.0)
        hann = 0.5 * np.sinc(u / np.pi) + 0.25 * (
            np.sinc(u / np.pi - 1.0) + np.sinc(u / np.pi + 1.0)
        )
        out[first : first + rows] = scale * (hann * hann) @ (density * weight)
    return out


def gaussian_exceedance(
    rms: np.ndarray, band: tuple[float, float], zeta: float, threshold: float = CONTACT_OPENS
) -> np.ndarray:
    """The share of time a Gaussian response of the linear model spends below ``q =
    -threshold``: ``erfc(threshold / (sqrt 2 sigma)) / 2`` with ``sigma = rms sqrt(V)``,
    V the linear variance of N/F_s under the unit process
    (:func:`hertzsweep.core.excitation.linear_response_variance`; that of q is smaller by
    a share of about ``4 zeta^2``).

    Parameters
    ----------
    rms : float or array
        Levels: RMS of f = F/F_s.
    band : (float, float)
        ``(w_low, w_high)``.
    zeta : float
        ``damping.ratio``.
    threshold : float
        :data:`CONTACT_OPENS` (3/2): the linear estimate of the loss of contact ``d = 1 +
        2q/3 <= 0``; :data:`LINEAR_FORCE_ZERO` (1): the linearised force ``1 + q`` below 0.

    Returns
    -------
    numpy.ndarray
        The shares, as ``rms``.
    """
    from scipy.special import erfc

    from ..core.excitation import linear_response_variance

    sigma = np.asarray(rms, dtype=float) * np.sqrt(linear_response_variance(band, zeta))
    with np.errstate(divide="ignore"):
        return 0.5 * erfc(threshold / (np.sqrt(2.0) * sigma))


def _random_psd(ds: xr.Dataset) -> Figure:
    fig = _new_figure(9.0, 6.0)
    ax = fig.subplots()
    w = ds.frequency_ratio.values
    low, high = _random_band(ds)
    shown = w <= min(1.2 * high, w[-1])
    w = w[shown]
    rms = ds.rms.values
    for i, level in enumerate(rms):
        psd = ds.psd.isel(rms=i).values[shown]
        error = ds.psd_stderr.isel(rms=i).values[shown]
        colour = _colour(i)
        ax.fill_between(w, psd - error, psd + error, color=colour, alpha=0.25, lw=0)
        ax.plot(w, psd, color=colour, lw=1.4, label=_rms_label(level))
    lowest = int(np.argmin(rms))
    zeta = float(ds.attrs["damping_ratio"])
    segment = int(ds.attrs["random_segment_periods"])
    fine = np.union1d(np.linspace(low, high, 4001)[:-1], [1.0])
    fine = fine[(fine >= low) & (fine < high)]
    exact = linear_model_psd(fine, float(rms[lowest]), (low, high), zeta)
    ax.plot(fine, exact, color="0.45", lw=0.8, ls=":", label=r"linear model $|H|^2 S_f$")
    welch = linear_model_psd(w, float(rms[lowest]), (low, high), zeta, segment)
    ax.plot(w, welch, color="k", lw=0.9, ls="--", label="linear model, as Welch sees it")
    inside = welch[(w >= low) & (w < high)]
    floor = 0.1 * float(np.min(inside if inside.size else exact))
    ax.set_yscale("log")
    ax.set_ylim(floor, 3.0 * max(float(np.nanmax(ds.psd.values)), float(exact.max())))
    ax.set_xlim(0.0, float(w[-1]))
    ax.axvspan(low, high, color="0.93", lw=0, zorder=0)
    ax.set_xlabel(W_LABEL)
    ax.set_ylabel(r"PSD of $N/F_s$ per unit $\varpi$ [1]")
    ax.grid(True, which="major", lw=0.3)
    _hz_axis(ax, _f0(ds))
    ax.legend(fontsize="small", loc="upper right")
    text = (
        rf"Random excitation on $\varpi$ = {low:g} .. {high:g} (shaded): PSD of $N/F_s$, "
        f"Welch resolution 1/{segment}"
    )
    fig.suptitle(_title(ds, text), fontsize="medium")
    return fig


def _random_pdf(ds: xr.Dataset) -> Figure:
    levels = ds.sizes["rms"]
    columns = min(levels, 3)
    rows = -(-levels // columns)
    fig = _new_figure(4.2 * columns, 0.8 + 3.2 * rows)
    axes = fig.subplots(rows, columns, squeeze=False).ravel()
    for ax in axes[levels:]:
        ax.remove()
    x = ds.force_bin.values
    width = float(x[1] - x[0]) if x.size > 1 else 1.0
    for i, ax in enumerate(axes[:levels]):
        one = ds.isel(rms=i)
        _pdf_panel(ax, one, x, width, _colour(i))
        ax.set_xlabel(FORCE_LABEL)
        if i % columns == 0:
            ax.set_ylabel(r"probability density of $N/F_s$ [1]")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize="small")
    text = "Random excitation: probability density of $N/F_s$ and the Gaussian of its moments"
    fig.suptitle(_title(ds, text), fontsize="medium")
    return fig


def _pdf_panel(ax, one: xr.Dataset, x: np.ndarray, width: float, colour: str) -> None:
    """One level's histogram (its standard error a band) and the Gaussian of the same
    mean and RMS, over the mean +- :data:`PDF_SIGMAS` RMS (at least two bins)."""
    pdf = one.force_pdf.values
    error = one.force_pdf_stderr.values
    mean, sigma = float(one.force_mean), float(one.force_rms)
    half = max(PDF_SIGMAS * sigma, 2.0 * width)
    span = np.linspace(mean - half, mean + half, 801)
    gauss = np.exp(-0.5 * ((span - mean) / sigma) ** 2) / (sigma * np.sqrt(2.0 * np.pi))
    ax.fill_between(x, pdf - error, pdf + error, step="mid", color=colour, alpha=0.25, lw=0)
    ax.step(x, pdf, where="mid", color=colour, lw=1.0, label="simulated (histogram)")
    ax.plot(span, gauss, color="k", lw=1.0, ls="--", label="Gaussian, same mean and RMS")
    ax.axvline(0.0, color="0.4", lw=0.6)
    top = 2.0 * max(float(np.nanmax(pdf)), float(gauss.max()))
    ax.set_yscale("log")
    ax.set_ylim(top * 10.0**-PDF_DECADES, top)
    ax.set_xlim(mean - half, mean + half)
    ax.grid(True, lw=0.3)
    title = (
        f"{_rms_label(float(one.rms))}: skewness {float(one.force_skewness):+.2f}, "
        f"kurtosis {float(one.force_kurtosis):.2f}"
    )
    loss = float(one.contact_loss_fraction)
    if loss > 0:
        title += f"\nout of contact {100.0 * loss:.3g} % (in the first bin)"
    if width > 0.5 * sigma:
        title += f"\nbins of {width:.2g}: wider than RMS / 2"
    ax.set_title(title, fontsize="small", loc="left")


def _level_axis(ax) -> None:
    """A log axis of input levels in %, its ticks at 1, 2, 3, 5 and 7 of each decade
    written plainly (levels spread from 0.1 % to 30 %)."""
    ax.set_xscale("log")
    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 3.0, 5.0, 7.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def _random_loss(ds: xr.Dataset) -> Figure:
    fig = _new_figure(12.0, 5.5)
    left, right = fig.subplots(1, 2)
    rms = ds.rms.values
    percent = 100.0 * rms
    loss = ds.contact_loss_fraction.values
    lost = loss > 0
    left.errorbar(
        percent[lost],
        loss[lost],
        yerr=ds.contact_loss_fraction_stderr.values[lost],
        ls="none",
        marker="o",
        ms=6,
        capsize=3,
        color=_colour(0),
        label="simulated (d <= 0)",
    )
    low, high = _random_band(ds)
    zeta = float(ds.attrs["damping_ratio"])
    line = np.geomspace(rms.min(), rms.max(), 200)
    for threshold, style, text in (
        (CONTACT_OPENS, "-", r"Gaussian linear response: $P(q < -3/2)$"),
        (LINEAR_FORCE_ZERO, ":", r"Gaussian linear response: $P(1 + q < 0)$"),
    ):
        chance = gaussian_exceedance(line, (low, high), zeta, threshold)
        left.plot(100.0 * line, chance, color="k", lw=1.0, ls=style, label=text)
    floor = 0.1 * float(loss[lost].min()) if lost.any() else LOSS_FLOOR
    _level_axis(left)
    left.set_ylim(min(floor, LOSS_FLOOR), 1.0)  # before the log scale: the limits hold
    left.set_yscale("log")  # when nothing is positive (no loss, a Gaussian tail of 0)
    left.set_xlabel(RMS_LABEL)
    left.set_ylabel("share of time out of contact [1]")
    left.grid(True, lw=0.3)
    left.legend(fontsize="small", loc="lower right")
    if not lost.all():
        left.set_title(
            f"{int((~lost).sum())} level(s) never out of contact: not drawn (0)",
            fontsize="small",
            loc="left",
        )
    segment = int(ds.attrs["random_segment_periods"])
    right.errorbar(
        percent,
        ds.peak_frequency_ratio.values,
        yerr=ds.peak_frequency_ratio_stderr.values,
        ls="-",
        marker="o",
        ms=6,
        capsize=3,
        color=_colour(1),
        label=f"peak of the PSD (Welch resolution 1/{segment})",
    )
    right.axhline(1.0, color="0.4", lw=0.8, ls="--", label="linear resonance")
    _level_axis(right)
    right.set_xlabel(RMS_LABEL)
    right.set_ylabel(r"frequency ratio $\varpi$ of the PSD's peak [1]")
    right.grid(True, which="both", lw=0.3)
    right.legend(fontsize="small", loc="lower left")
    _hz_axis(right, _f0(ds), where="right")
    text = "Random excitation: loss of contact and the softening of the peak against the level"
    fig.suptitle(_title(ds, text), fontsize="medium")
    return fig


__all__ = [
    "DPI",
    "FORMATS",
    "accuracy_figure",
    "branch_figure",
    "figure_format",
    "gaussian_exceedance",
    "linear_model_psd",
    "random_figure",
    "select_harmonics",
    "select_sigma",
    "stability_segments",
    "study_figure",
    "study_subharmonic",
    "study_jumps",
    "sweep_figure",
    "trace_figure",
    "write_figure",
]
