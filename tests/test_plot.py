"""`hertzsweep plot`: every dataset kind renders to a figure of the documented size that
draws the dataset's numbers, as the paper draws them; dwells that did not settle or do
not repeat are drawn apart and named; phases are unwrapped (or wrapped on request); one
unit convention; files carry metadata; bad input ends in exit status 2 and one line."""

import os
import re
import stat

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.image import imread
from PIL import Image

from hertzsweep import __version__
from hertzsweep.cli.plot import DEFAULT_DPI
from hertzsweep.core.kinds import KINDS
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.errors import HertzsweepError
from hertzsweep.output import plot
from hertzsweep.output.dataset import attrs, global_attributes, sweep_dataset, write_atomic
from hertzsweep.output.figures import figure

from .conftest import make_scene, run_cli
from .test_fit import fit_drawn
from .test_import import measured_drawn
from .test_random_cli import random_drawn

F0 = 230.776  # [Hz] the paper rig's natural frequency (tests/test_rig.py)

# A small sigma = 1 % sweep across the jump (viscous zeta = 0.45 %): 2 x 2 x 13 dwells;
# 300 settling periods leave 8 of the 52 dwells unsettled (at the jumps and at each sweep's
# start), so the figures draw both kinds of point.
SMALL_SWEEP = dict(
    damping={"ratio": 0.0045},
    excitation={"sigma": [0.006, 0.01]},
    sweep={"start": 0.96, "stop": 1.02, "step": 0.005, "settle_periods": 300},
)
UNIT = re.compile(r"\[(1|degree|Hz|ms|%)\]$")  # the one convention: every label ends so


@pytest.fixture(scope="module")
def scene():
    return make_scene(**SMALL_SWEEP)


@pytest.fixture(scope="module")
def sweep_ds(scene):
    return sweep_dataset(run_sweep(scene), scene).to_xarray()


def _dataset(scene, kind, data, coords, extra=None):
    """A dataset of the agreed layout; every name takes its attributes from the one table
    (a name missing there is a KeyError: the layout and the table must agree)."""
    ds = xr.Dataset(
        {name: (dims, np.asarray(values), attrs(name)) for name, (dims, values) in data.items()},
        coords={name: (dims, np.asarray(v), attrs(name)) for name, (dims, v) in coords.items()},
        attrs=global_attributes(scene, f"synthetic {kind}", kind, "test"),
    )
    ds.attrs.update(extra or {})
    return ds


@pytest.fixture(scope="module")
def trace_ds(scene):
    """The agreed trace layout: one impacting period-2-flight history at w = 0.6."""
    samples, periods, w = 256, 4, 0.6
    tau = np.arange(samples) * (2 * np.pi * periods / w) / samples
    force = np.maximum(0.0, 1.0 + 4.0 * np.sin(w * tau))
    force = np.vstack([force, 0.5 + 0.5 * force])
    contact = (force > 0).astype(np.int8)
    order = np.arange(samples // 2 + 1) / periods
    spectrum = np.abs(np.fft.rfft(force, axis=1)) * 2 / samples
    data = {
        "displacement": (("sigma", "sample"), force - 1),
        "velocity": (("sigma", "sample"), np.gradient(force, axis=1)),
        "normal_force": (("sigma", "sample"), force),
        "in_contact": (("sigma", "sample"), contact),
        "spectrum": (("sigma", "harmonic_order"), spectrum),
        "amplitude": (("sigma", "harmonic"), spectrum[:, [periods, 2 * periods]]),
        "phase": (("sigma", "harmonic"), np.zeros((2, 2))),
        "force_max": ("sigma", force.max(axis=1)),
        "force_min": ("sigma", force.min(axis=1)),
        "contact_loss_fraction": ("sigma", 1 - contact.mean(axis=1)),
        "flight_time": ("sigma", [4.1e-3, 0.0]),
        "flight_start": (("sigma", "flight"), [[1.0, 2.0], [np.nan, np.nan]]),
        "flight_end": (("sigma", "flight"), [[1.5, 2.5], [np.nan, np.nan]]),
        "flight_start_time": (("sigma", "flight"), [[1e-3, 2e-3], [np.nan, np.nan]]),
        "flight_duration": (("sigma", "flight"), [[4e-4, 4e-4], [np.nan, np.nan]]),
        "frequency_ratio": ((), w),
    }
    coords = {
        "sigma": ("sigma", [0.07, 0.03]),
        "tau": ("sample", tau),
        "time": ("sample", tau / (2 * np.pi * F0)),
        "harmonic": ("harmonic", [1, 2]),
        "harmonic_order": ("harmonic_order", order),
        "spectrum_frequency": ("harmonic_order", order * w * F0),
    }
    return _dataset(scene, "trace", data, coords, {"frequency_ratio": w, "branch": "upper"})


@pytest.fixture(scope="module")
def branch_ds(scene):
    """The agreed branch layout: an S-shaped softening curve with two folds, the middle
    segment unstable, NaN padded along point for the second sigma."""
    s = np.linspace(0.0, 1.0, 41)
    w = 0.98 + 0.03 * np.cos(3 * np.pi * s) * (1 - s) - 0.02 * s
    h1 = 0.2 + 0.8 * s
    stable = np.ones(s.size, dtype=np.int8)
    stable[13:24] = 0  # between the folds at points 12 and 24
    pad = 5
    freq = np.vstack([w, np.r_[w[:-pad], [np.nan] * pad]])
    amp = np.stack([np.c_[h1, 0.15 * h1], np.c_[0.5 * h1, 0.07 * h1]])
    amp[1, -pad:] = np.nan
    stab = np.vstack([stable, np.r_[stable[:-pad], [-1] * pad]]).astype(np.int8)
    data = {
        "frequency_ratio": (("sigma", "point"), freq),
        "frequency": (("sigma", "point"), freq * F0),
        "amplitude": (("sigma", "point", "harmonic"), amp),
        "phase": (("sigma", "point", "harmonic"), 180 * amp / np.nanmax(amp)),
        "force_max": (("sigma", "point"), 1 + amp[..., 0]),
        "force_min": (("sigma", "point"), 1 - amp[..., 0]),
        "contact_loss_fraction": (("sigma", "point"), 0 * freq),
        "multiplier_real": (("sigma", "point", "multiplier"), np.zeros((2, s.size, 2))),
        "multiplier_imag": (("sigma", "point", "multiplier"), np.zeros((2, s.size, 2))),
        "stable": (("sigma", "point"), stab),
        "arclength": (("sigma", "point"), np.vstack([s, s])),
        "bifurcation_frequency_ratio": (
            ("sigma", "bifurcation"),
            [[w[12], w[24]], [w[12], np.nan]],
        ),
        "bifurcation_kind": (("sigma", "bifurcation"), np.array([["fold", "fold"], ["fold", ""]])),
        "bifurcation_amplitude": (
            ("sigma", "bifurcation"),
            [[h1[12], h1[24]], [h1[12] / 2, np.nan]],
        ),
    }
    coords = {"sigma": ("sigma", [0.006, 0.01]), "harmonic": ("harmonic", [1, 2])}
    return _dataset(scene, "branch", data, coords)


@pytest.fixture(scope="module")
def study_ds(scene):
    """The agreed study layout: down jumps against sigma for four damping exponents."""
    sigma = np.array([0.002, 0.01, 0.03, 0.07])
    n = np.array([0.0, 0.5, 1.0, 1.5])
    jump = 0.99 - 0.3 * np.sqrt(sigma)[None, :] * (2.0 - n)[:, None]
    jump[0, 0] = np.nan  # n = 0: no jump at the smallest level
    data = {
        "jump_frequency_ratio": (
            ("direction", "damping_exponent", "sigma"),
            np.stack([jump + 0.05, jump]),
        ),
        "case_failed": (("damping_exponent", "sigma"), np.zeros((4, 4), dtype=np.int8)),
    }
    coords = {
        "direction": ("direction", np.array(["up", "down"], dtype=object)),
        "damping_exponent": ("damping_exponent", n),
        "sigma": ("sigma", sigma),
    }
    return _dataset(scene, "study", data, coords, {"study_kind": "sweep"})


@pytest.fixture(scope="module")
def accuracy_ds(scene):
    """The agreed accuracy layout: a second-order ladder of steps per period."""
    steps = np.array([32, 64, 128, 256, 512, 1024])
    cost = steps * 1e5
    h1 = 3.0 / steps.astype(float) ** 2
    h1[-1] = 0.0  # the reference itself
    data = {
        "error_h1": ("setting", h1),
        "error_h2": ("setting", 2 * h1),
        "error_force": ("setting", 0.5 * h1),
        "error_jump": ("setting", np.where(steps < 128, 0.0025, 0.0)),
        "cost_steps": ("setting", cost),
        "wall_time": ("setting", cost * 2e-8),
        "pareto": ("setting", np.array([1, 1, 0, 1, 1, 1], dtype=np.int8)),
    }
    coords = {
        "setting_label": ("setting", np.array([f"N={k}" for k in steps], dtype=object)),
        "steps_per_period": ("setting", steps),
    }
    extra = {
        "observed_order": 2.01,
        "reference_label": "N=1024",
        "recommended": "N=256",
        "target": 1e-4,
    }
    return _dataset(scene, "accuracy", data, coords, extra)


def _render(ds, tmp_path, capsys, name, *options):
    """Run ``hertzsweep plot`` on the dataset; the PNG's (width, height) in pixels."""
    source = tmp_path / f"{name}.nc"
    write_atomic(ds, source)
    out = tmp_path / f"{name}.png"
    code, stdout, err = run_cli(["plot", source, "-o", out, *options], capsys)
    assert code == 0, err
    assert f"wrote {out}" in stdout
    image = imread(out)
    return image.shape[1], image.shape[0]


def _options(options):
    """The keyword arguments of :func:`figure` for command-line options."""
    kwargs = {"view": None, "harmonics": None, "sigma": None}
    for flag, value in zip(options[::2], options[1::2], strict=True):
        if flag == "--view":
            kwargs["view"] = value
        elif flag == "--harmonic":
            kwargs["harmonics"] = [*(kwargs["harmonics"] or []), int(value)]
        else:
            kwargs["sigma"] = [*(kwargs["sigma"] or []), float(value)]
    return kwargs


def _curves(ax):
    """(x, y) of every line of data with more than one point on an axes (not the
    reference lines, drawn in axes coordinates, nor single markers)."""
    return [
        (np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float))
        for line in ax.get_lines()
        if np.asarray(line.get_xdata()).size > 1 and line.get_transform() is ax.transData
    ]


def _assert_drawn(curves, x, y):
    """One of the curves is exactly (x, y) (NaN where the dataset has NaN)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    assert any(
        cx.shape == x.shape
        and np.array_equal(cx, x, equal_nan=True)
        and np.array_equal(cy, y, equal_nan=True)
        for cx, cy in curves
    ), f"no curve draws {y}"


def _series(ax, marker="o"):
    """(x, y) of the lines of data with the given marker (not the empty legend proxies)."""
    return [
        (np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float))
        for line in ax.get_lines()
        if line.get_marker() == marker
        and line.get_transform() is ax.transData
        and np.asarray(line.get_xdata()).size
    ]


def _assert_sweep_drawn(ax, ds, direction, sigma, values, phase=False):
    """One sweep's values on a panel: the converged dwells as one series of circles (NaN
    at the others), the dwells that did not settle as crosses, those settled but not
    periodic as triangles; phases unwrapped, equal to the stored ones modulo 360."""
    w = ds.frequency_ratio.values
    y = np.asarray(values, float)
    if phase:
        drawn = plot.unwrap_degrees(y)
        np.testing.assert_allclose(np.mod(drawn, 360.0), np.mod(y, 360.0), atol=1e-9)
        y = drawn
    i = int(np.flatnonzero(ds.sigma.values == sigma)[0])
    unsettled, aperiodic = plot.dwell_flags(ds, direction, i)
    _assert_drawn(_series(ax, "o"), w, np.where(unsettled | aperiodic, np.nan, y))
    for mask, (marker, _) in ((unsettled, plot.NOT_SETTLED), (aperiodic, plot.NOT_PERIODIC)):
        if mask.any():
            _assert_drawn(_series(ax, marker), w[mask], y[mask])


def _sweep_drawn(fig, ds, kwargs):
    ds = ds if kwargs["sigma"] is None else plot.select_sigma(ds, kwargs["sigma"])
    view = kwargs["view"] or "harmonics"
    if view == "forces":
        top, bottom = fig.axes[:2]
        for direction in ds.direction.values:
            for sigma in ds.sigma.values:
                one = ds.sel(direction=direction, sigma=sigma)
                _assert_sweep_drawn(top, ds, direction, sigma, one.force_max)
                _assert_sweep_drawn(top, ds, direction, sigma, one.force_min)
                _assert_sweep_drawn(bottom, ds, direction, sigma, 100 * one.contact_loss_fraction)
        return len(_series(top)) + len(_series(bottom))
    orders = kwargs["harmonics"] or list(ds.harmonic.values)
    columns = 2 if view == "harmonics" else 1
    count = 0
    for row, k in enumerate(orders):
        for column, name in enumerate(["amplitude", "phase"][:columns]):
            ax = fig.axes[columns * row + column]
            count += len(_series(ax))
            for direction in ds.direction.values:
                for sigma in ds.sigma.values:
                    values = ds[name].sel(direction=direction, sigma=sigma, harmonic=k)
                    _assert_sweep_drawn(ax, ds, direction, sigma, values, name == "phase")
    return count


def _trace_drawn(fig, ds, kwargs):
    ds = ds if kwargs["sigma"] is None else plot.select_sigma(ds, kwargs["sigma"])
    view = kwargs["view"] or "both"
    t = ds.time.values
    columns = 2 if view == "both" else 1
    count = 0
    for row in range(ds.sizes["sigma"]):
        one = ds.isel(sigma=row)
        time_axes = fig.axes[columns * row]
        curves = _curves(time_axes)
        count += len(curves)
        _assert_drawn(curves, 1e3 * (t - t[0]), one.normal_force)  # ms from the start
        if view == "both":
            (lines,) = [
                c for c in fig.axes[columns * row + 1].collections if isinstance(c, LineCollection)
            ]
            order = one.harmonic_order.values
            shown = (order > 0) & (order <= plot.SPECTRUM_ORDERS)
            segments = np.array(lines.get_segments())  # one vertical line per order
            np.testing.assert_array_equal(segments[:, 0, 0], order[shown])
            np.testing.assert_array_equal(segments[:, 1, 1], one.spectrum.values[shown])
            count += len(segments)
    return count


def _branch_drawn(fig, ds, kwargs):
    view = kwargs["view"] or "harmonics"
    columns = 2 if view == "harmonics" else 1
    count = 0
    for row, k in enumerate(ds.harmonic.values):
        drawn = _curves(fig.axes[columns * row])
        count += len(drawn)
        points = {(x, y) for cx, cy in drawn for x, y in zip(cx, cy, strict=True)}
        for i in range(ds.sizes["sigma"]):
            one = ds.isel(sigma=i)
            valid = one.stable.values >= 0
            w = one.frequency_ratio.values[valid]
            amplitude = one.amplitude.sel(harmonic=k).values[valid]
            # every point of the branch lies on the stable and unstable segments drawn
            assert set(zip(w, amplitude, strict=True)) <= points
    return count


def _study_drawn(fig, ds, kwargs):
    curves = _curves(fig.axes[0])
    for n in ds.damping_exponent.values:
        down = ds.jump_frequency_ratio.sel(direction="down", damping_exponent=n)
        _assert_drawn(curves, 100 * ds.sigma.values, down)  # sigma in %
    return len(curves)


def _accuracy_drawn(fig, ds, kwargs):
    ax = fig.axes[0]
    cost = ds.cost_steps.values
    for name, (label, _) in plot.ERROR_VARIABLES.items():
        (line,) = [line for line in ax.get_lines() if line.get_label() == f"error in {label}"]
        error = ds[name].values
        np.testing.assert_array_equal(line.get_xdata(), cost)
        np.testing.assert_array_equal(line.get_ydata(), np.where(error > 0, error, np.nan))
    return len(_curves(ax))


DRAWN = {  # kind -> the check that a figure draws the dataset's values; returns the curves
    "sweep": _sweep_drawn,
    "trace": _trace_drawn,
    "branch": _branch_drawn,
    "study": _study_drawn,
    "accuracy": _accuracy_drawn,
    "measured": measured_drawn,  # tests/test_import.py draws measured datasets
    "fit": fit_drawn,  # tests/test_fit.py draws fit datasets
    "random": random_drawn,  # tests/test_random_cli.py draws random datasets
}


def test_every_kind_has_a_check():
    assert set(DRAWN) == set(KINDS)


# Expected pixel sizes: inches x plot.DPI (200), from the builders' documented sizes;
# expected curves: one series of converged dwells per sigma and direction on each panel
# (sweep), one per sigma (trace), the stability segments (branch), one per damping law
# (study), one per error measure and the Pareto front (accuracy).
@pytest.mark.parametrize(
    "fixture, options, inches, curves",
    [
        ("sweep_ds", [], (11.0, 7.4), 16),  # 2 harmonics, amplitude and phase
        ("sweep_ds", ["--view", "amplitude", "--harmonic", "1"], (8.0, 5.0), 4),
        ("sweep_ds", ["--view", "forces", "--sigma", "0.01"], (8.0, 7.0), 6),
        ("trace_ds", [], (13.0, 6.1), 2 + 2 * 34),  # 2 sigma rows: force and 34 lines
        ("trace_ds", ["--view", "time", "--sigma", "0.07"], (10.0, 3.5), 1),
        ("branch_ds", [], (11.0, 7.4), 12),  # 2 sigma x stable, unstable, stable x 2 rows
        ("study_ds", [], (8.5, 6.0), 4),
        ("accuracy_ds", [], (9.0, 6.5), 4 + 1),  # 4 error measures and the Pareto front
    ],
)
def test_every_kind_renders(fixture, options, inches, curves, request, tmp_path, capsys):
    ds = request.getfixturevalue(fixture)
    size = tuple(round(x * plot.DPI) for x in inches)
    assert _render(ds, tmp_path, capsys, fixture, *options) == size
    # the figure the command saved draws the dataset's numbers
    kwargs = _options(options)
    fig = figure(ds, **kwargs)
    assert DRAWN[ds.attrs["hertzsweep_kind"]](fig, ds, kwargs) == curves


def test_vector_formats(sweep_ds, tmp_path, capsys):
    source = tmp_path / "s.nc"
    write_atomic(sweep_ds, source)
    for suffix, magic in ((".pdf", b"%PDF"), (".svg", b"<?xml")):
        out = tmp_path / f"s{suffix}"
        code, _, err = run_cli(["plot", source, "-o", out], capsys)
        assert code == 0, err
        assert out.read_bytes().startswith(magic)
        mask = os.umask(0)
        os.umask(mask)
        assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~mask  # as open() makes files


@pytest.mark.parametrize(
    "argv_tail, message",
    [
        (["-o", "{tmp}/f.jpg"], "unknown figure extension .jpg"),
        (["-o", "{tmp}/f"], "unknown figure extension (none)"),
        (["-o", "{tmp}/f.png", "--view", "spectrum"], "--view: sweep datasets have views"),
        (["-o", "{tmp}/f.png", "--harmonic", "3"], "--harmonic: 3 not in the dataset"),
        (["-o", "{tmp}/f.png", "--sigma", "0.02"], "--sigma: 0.02 is not in the dataset"),
    ],
)
def test_bad_options_exit_2(sweep_ds, tmp_path, capsys, argv_tail, message):
    source = tmp_path / "s.nc"
    write_atomic(sweep_ds, source)
    argv = ["plot", source] + [a.format(tmp=tmp_path) for a in argv_tail]
    code, out, err = run_cli(argv, capsys)
    assert code == 2
    assert message in err and len(err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.nc"]  # no figure, no temporary


def test_unknown_kind_exit_2(sweep_ds, tmp_path, capsys):
    for kind, message in (
        ("spectrogram", "unknown kind 'spectrogram'"),
        (None, "no 'hertzsweep_kind' attribute"),
    ):
        ds = sweep_ds.copy()
        if kind is None:
            del ds.attrs["hertzsweep_kind"]
        else:
            ds.attrs["hertzsweep_kind"] = kind
        source = tmp_path / "odd.nc"
        write_atomic(ds, source)
        code, _, err = run_cli(["plot", source, "-o", tmp_path / "odd.png"], capsys)
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "odd.png").exists()


def test_incomplete_dataset_exit_2(sweep_ds, tmp_path, capsys):
    source = tmp_path / "partial.nc"
    write_atomic(sweep_ds.drop_vars("amplitude"), source)
    code, _, err = run_cli(["plot", source, "-o", tmp_path / "f.png"], capsys)
    assert code == 2 and "not a complete sweep dataset" in err and "amplitude" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "f.png").exists()


def test_not_netcdf_exit_2(tmp_path, capsys):
    source = tmp_path / "notes.nc"
    source.write_text("not a dataset\n")
    code, _, err = run_cli(["plot", source, "-o", tmp_path / "f.png"], capsys)
    assert code == 2 and "cannot read it as netCDF" in err and len(err.strip().splitlines()) == 1


# --------------------------------------------------------------------------- drawn as the paper
def test_sweep_markers_and_hz_axis(sweep_ds):
    fig = figure(sweep_ds, harmonics=[1])
    amplitude_axes = fig.axes[0]
    lines = [line for line in amplitude_axes.get_lines() if line.get_marker() == "o"]
    # one series per sigma and direction: up filled (face = edge colour), down open
    assert len(lines) == 4
    faces = [line.get_markerfacecolor() for line in lines]
    assert sum(face == "none" for face in faces) == 2
    # the data drawn are the dataset's H1 values (the converged dwells among them)
    up = sweep_ds.amplitude.sel(direction="up", sigma=0.01, harmonic=1).values
    unsettled, _ = plot.dwell_flags(sweep_ds, "up", 1)
    up = np.where(unsettled, np.nan, up)
    assert any(np.array_equal(line.get_ydata(), up, equal_nan=True) for line in lines)
    # a second x axis in Hz: f = w f0 (eq. 15) on the top of the first row
    secondary = [child for child in amplitude_axes.child_axes]
    assert secondary and secondary[0].get_xlabel() == plot.HZ_LABEL
    fig.canvas.draw()  # a secondary axis takes its limits at drawing time
    lo, hi = amplitude_axes.get_xlim()
    # F0 above is the rig's f0 rounded to 6 digits (1e-6 relative): 1e-4 covers it
    np.testing.assert_allclose(secondary[0].get_xlim(), (lo * F0, hi * F0), rtol=1e-4)


def test_stability_segments():
    runs = plot.stability_segments(np.array([1, 1, 0, 0, 0, 1, -1, -1], dtype=np.int8))
    # each run overlaps the next by one point so the curve is unbroken; padding ends it
    assert runs == [(0, 3, True), (2, 6, False), (5, 6, True)]
    assert plot.stability_segments(np.array([-1, -1])) == []


def test_branch_stable_solid_unstable_dotted_folds(branch_ds):
    fig = figure(branch_ds, view="amplitude", harmonics=[1])
    ax = fig.axes[0]
    curves = [line for line in ax.get_lines() if line.get_xdata().size > 1]
    styles = {line.get_linestyle() for line in curves}
    assert styles == {"-", ":"}
    # stable 0-12, unstable 13-23 (11 points and the next one, to join), stable 24-40
    dotted = [line for line in curves if line.get_linestyle() == ":"]
    assert sorted(line.get_xdata().size for line in dotted) == [12, 12]
    folds = [line for line in ax.get_lines() if line.get_marker() == "D"]
    assert len(folds) == 3  # two on the first branch, one on the second (one padded)
    np.testing.assert_allclose(
        sorted(float(line.get_xdata()[0]) for line in folds),
        sorted(
            branch_ds.bifurcation_frequency_ratio.values[
                ~np.isnan(branch_ds.bifurcation_frequency_ratio.values)
            ]
        ),
    )


def test_branch_overlay_sweep(branch_ds, sweep_ds):
    plain = figure(branch_ds, view="amplitude", harmonics=[1])
    over = figure(branch_ds, view="amplitude", harmonics=[1], overlay=sweep_ds)
    # two sigma levels match, each with an up and a down sweep: four series of circles
    # more, and the unsettled dwells as crosses
    assert len(_series(over.axes[0])) - len(_series(plain.axes[0])) == 4
    assert _series(over.axes[0], "x") and not _series(plain.axes[0], "x")
    # the legend says the markers are simulated (the paper's are its measurements)
    texts = [t.get_text() for t in over.axes[0].get_legend().get_texts()]
    assert "simulated up sweep" in texts and "simulated down sweep" in texts
    assert plot.NOT_SETTLED[1] in texts
    assert not any("sweep" in t for t in legend_texts(plain.axes[0]))
    with pytest.raises(HertzsweepError, match="expected a sweep"):
        figure(branch_ds, overlay=branch_ds)


def legend_texts(ax):
    legend = ax.get_legend()
    return [t.get_text() for t in legend.get_texts()] if legend else []


def test_trace_flights_shaded_and_spectrum(trace_ds):
    fig = figure(trace_ds)
    time_axes, spectrum_axes = fig.axes[0], fig.axes[1]
    shaded = [c for c in time_axes.collections if isinstance(c, PolyCollection)]
    assert shaded  # sigma = 7 % loses contact
    force = time_axes.get_lines()[0]
    t = trace_ds.time.values
    np.testing.assert_allclose(force.get_xdata(), 1e3 * (t - t[0]))  # ms from the start
    np.testing.assert_allclose(force.get_ydata(), trace_ds.normal_force.values[0])
    assert "longest flight 4.10 ms" in time_axes.get_title(loc="left")
    # the second sigma never loses contact: no shading on its row
    assert not [c for c in fig.axes[2].collections if isinstance(c, PolyCollection)]
    assert spectrum_axes.get_xlim() == (0.0, plot.SPECTRUM_ORDERS)


def test_trace_figure_stacks_datasets(trace_ds):
    fig = plot.trace_figure([trace_ds, trace_ds.isel(sigma=[0])], view="time")
    assert len(fig.axes) == 3 and fig.get_size_inches()[1] == pytest.approx(0.9 + 3 * 2.6)


def test_study_one_curve_per_damping_law(study_ds):
    fig = figure(study_ds)
    ax = fig.axes[0]
    curves = ax.get_lines()
    assert len(curves) == 4
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "n = 0",
        "n = 0.5",
        "n = 1",
        "n = 1.5",
    ]
    # the down sweep's jumps against sigma in %, log scale (0.2 % to 7 %)
    np.testing.assert_allclose(curves[3].get_xdata(), 100 * study_ds.sigma.values)
    down = study_ds.jump_frequency_ratio.sel(direction="down", damping_exponent=1.5).values
    np.testing.assert_array_equal(curves[3].get_ydata(), down)
    # levels drawn over more than a decade: a log axis; over less: linear
    assert ax.get_xscale() == "log"
    narrow = study_ds.copy(deep=True)
    narrow["jump_frequency_ratio"][..., 0] = np.nan  # nothing drawn at 0.2 %: 1 % to 7 %
    assert figure(narrow).axes[0].get_xscale() == "linear"


def test_accuracy_log_log_pareto(accuracy_ds):
    fig = figure(accuracy_ds)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    front = [line for line in ax.get_lines() if line.get_label().startswith("Pareto")]
    assert len(front) == 1
    cost = accuracy_ds.cost_steps.values
    np.testing.assert_array_equal(front[0].get_xdata(), cost[accuracy_ds.pareto.values == 1])
    star = [line for line in ax.get_lines() if line.get_label().startswith("recommended")]
    assert star and star[0].get_xdata()[0] == cost[3]


def test_unknown_view_and_kind_in_library(sweep_ds):
    with pytest.raises(HertzsweepError, match="views harmonics, amplitude, forces"):
        figure(sweep_ds, view="time")
    odd = sweep_ds.copy()
    odd.attrs["hertzsweep_kind"] = "movie"
    with pytest.raises(HertzsweepError, match="unknown kind 'movie'"):
        figure(odd)


# --------------------------------------------------------------------------- real datasets
# The builders take the datasets the drivers and builders make (not only the synthetic
# layouts above): small real runs, each drawn and checked for what the paper shows.
def test_real_trace_flights():
    from hertzsweep.drivers.trace import run_trace
    from hertzsweep.output.dataset import trace_dataset

    # Figure 17's case (sigma 7.8 %, zeta 1 %, n = 3/2) reached from 0.95 downwards
    scene = make_scene(
        damping={"ratio": 0.01, "law": "contact", "exponent": 1.5},
        excitation={"sigma": [0.078]},
        sweep={"start": 0.58, "stop": 0.95, "step": 0.01, "settle_periods": 150},
    )
    ds = trace_dataset(run_trace(scene, 0.58, periods=2, branch="upper"), scene).to_xarray()
    fig = figure(ds)
    time_axes = fig.axes[0]
    assert [c for c in time_axes.collections if isinstance(c, PolyCollection)]
    assert f"out of contact {100 * float(ds.contact_loss_fraction[0]):.0f} %" in (
        time_axes.get_title(loc="left")
    )
    assert float(ds.contact_loss_fraction[0]) > 0.5  # the flights shaded cover most of it


def test_real_branch_folds(sweep_ds):
    from hertzsweep.drivers.continuation import run_branch
    from hertzsweep.output.dataset import branch_dataset

    scene = make_scene(**SMALL_SWEEP)
    ds = branch_dataset(run_branch(scene), scene).to_xarray()
    fig = figure(ds, view="amplitude", harmonics=[1], sigma=[0.01], overlay=sweep_ds)
    ax = fig.axes[0]
    curves = [line for line in ax.get_lines() if line.get_linestyle() in ("-", ":")]
    assert {line.get_linestyle() for line in curves} == {"-", ":"}
    folds = [line for line in ax.get_lines() if line.get_marker() == "D"]
    expected = ds.bifurcation_frequency_ratio.sel(sigma=0.01).values[
        ds.bifurcation_kind.sel(sigma=0.01).values == "fold"
    ]
    assert len(folds) == expected.size == 2  # sigma = 1 %: the two folds of the hysteresis


# --------------------------------------------------------------------------- honest figures
def test_unsettled_and_non_periodic_dwells_drawn_apart_and_named(sweep_ds):
    ds = sweep_ds.copy(deep=True)
    settled = ds.settled.values
    assert 0 < int((settled == 0).sum()) < settled.size  # the fixture has both kinds
    ds["periodic"].values[0, 0, 5] = 0  # a settled dwell that does not repeat
    assert settled[0, 0, 5] == 1
    fig = figure(ds, view="amplitude", harmonics=[1])
    ax = fig.axes[0]
    w = ds.frequency_ratio.values
    for direction in ("up", "down"):
        for sigma in ds.sigma.values:
            values = ds.amplitude.sel(direction=direction, sigma=sigma, harmonic=1)
            _assert_sweep_drawn(ax, ds, direction, sigma, values)
    (triangle,) = _series(ax, plot.NOT_PERIODIC[0])
    np.testing.assert_array_equal(triangle[0], [w[5]])
    crosses = np.concatenate([x for x, _ in _series(ax, plot.NOT_SETTLED[0])])
    assert crosses.size == int((settled == 0).sum())
    texts = legend_texts(ax)
    assert plot.NOT_SETTLED[1] in texts and plot.NOT_PERIODIC[1] in texts
    # a dataset whose dwells all converged names neither
    ds["settled"].values[:] = 1
    ds["periodic"].values[:] = 1
    texts = legend_texts(figure(ds, view="amplitude", harmonics=[1]).axes[0])
    assert plot.NOT_SETTLED[1] not in texts and plot.NOT_PERIODIC[1] not in texts


def test_forces_view_draws_flags_too(sweep_ds):
    fig = figure(sweep_ds, view="forces")
    assert _series(fig.axes[0], "x") and _series(fig.axes[1], "x")
    assert plot.NOT_SETTLED[1] in legend_texts(fig.axes[0])


def test_trace_title_says_not_settled(trace_ds):
    ds = trace_ds.copy(deep=True)
    ds["settled"] = ("sigma", np.array([0, 1], dtype=np.int8))
    ds["periodic"] = ("sigma", np.array([1, 0], dtype=np.int8))
    fig = figure(ds, view="time")
    assert plot.NOT_SETTLED[1] in fig.axes[0].get_title(loc="left")
    assert plot.NOT_PERIODIC[1] in fig.axes[1].get_title(loc="left")


def test_study_marks_jumps_read_next_to_unconverged_dwells(study_ds):
    ds = study_ds.copy(deep=True)
    w = np.round(np.arange(0.50, 1.0001, 0.0025), 10)
    jump = ds.jump_frequency_ratio.values
    jump = np.where(np.isfinite(jump), np.round(jump / 0.0025) * 0.0025, np.nan)
    ds["jump_frequency_ratio"].values = jump
    ds = ds.assign_coords(frequency_ratio=w)
    settled = np.ones((2, 4, 4, w.size), dtype=np.int8)
    j = int(np.flatnonzero(np.isclose(w, jump[1, 3, 2]))[0])  # down, n = 1.5, sigma = 3 %
    settled[1, 3, 2, j - 1] = 0  # the dwell after the jump, in down-sweep order
    ds["settled"] = (("direction", "damping_exponent", "sigma", "frequency_ratio"), settled)
    flagged = plot.unconverged_jumps(ds, plot.study_jumps(ds))
    assert flagged.values.sum() == 1 and bool(flagged.sel(damping_exponent=1.5, sigma=0.03))
    ax = figure(ds).axes[0]
    (cross,) = _series(ax, "x")
    np.testing.assert_allclose(cross[0], [3.0])
    np.testing.assert_allclose(cross[1], [jump[1, 3, 2]])
    assert plot.JUMP_FLAG in legend_texts(ax)
    assert plot.JUMP_FLAG not in legend_texts(figure(study_ds).axes[0])


def test_unwrap_degrees():
    # continuous across 360 -> 0, NaN kept (and skipped), the first value in [-180, 180)
    y = np.array([350.0, 355.0, np.nan, 2.0, 8.0, 100.0, 170.0, 250.0])
    np.testing.assert_allclose(
        plot.unwrap_degrees(y), [-10.0, -5.0, np.nan, 2.0, 8.0, 100.0, 170.0, 250.0]
    )
    np.testing.assert_allclose(plot.unwrap_degrees([10.0, 300.0, 250.0]), [10.0, -60.0, -110.0])
    np.testing.assert_allclose(plot.unwrap_degrees([200.0, 210.0]), [-160.0, -150.0])
    assert np.isnan(plot.unwrap_degrees([np.nan, np.nan])).all()
    # a jump of the response (here 180, as H2's at a jump of H1) is kept, not unwrapped;
    # the window's lower end places the first value
    np.testing.assert_allclose(
        plot.unwrap_degrees([95.0, 275.0, 355.0, 5.0], low=0.0), [95.0, 275.0, 355.0, 365.0]
    )
    np.testing.assert_allclose(plot.unwrap_degrees([300.0, 310.0], low=60.0), [300.0, 310.0])


def test_phase_window_at_the_widest_gap():
    # H1's lag, 10 to 170 degrees: the window [-90, 270) holds it and a lag of -1 alike
    assert plot.phase_window(np.array([10.0, 90.0, 170.0])) == pytest.approx(-90.0)
    # H2 from 100 to 380 (stored 20): the gap 20..100 is left out
    h2 = np.array([100.0, 150.0, 200.0, 250.0, 300.0, 355.0, 5.0, 20.0, np.nan])
    assert plot.phase_window(h2) == (pytest.approx(60.0))
    assert plot.phase_window(np.array([np.nan])) == -180.0


def test_phases_unwrapped_by_default_wrapped_on_request(sweep_ds, tmp_path, capsys):
    ds = sweep_ds.copy(deep=True)
    stored = np.mod(np.linspace(300.0, 420.0, ds.sizes["frequency_ratio"]), 360.0)
    ds["phase"].values[..., 1] = stored  # H2 crosses 360 -> 0 mid-curve
    ds["settled"].values[:] = 1
    fig = figure(ds, view="harmonics", harmonics=[2])
    (x, y), *_ = _series(fig.axes[1])
    np.testing.assert_allclose(y, np.linspace(-60.0, 60.0, stored.size), atol=1e-9)
    assert "unwrapped [degree]" in fig.axes[1].get_ylabel()
    with plot.phase_convention(plot.WRAPPED):
        wrapped = figure(ds, view="harmonics", harmonics=[2])
    (x, y), *_ = _series(wrapped.axes[1])
    np.testing.assert_array_equal(y, stored)
    assert wrapped.axes[1].get_ylim() == (-5.0, 365.0)
    assert "unwrapped" not in wrapped.axes[1].get_ylabel()
    with pytest.raises(HertzsweepError, match="phase convention"):
        with plot.phase_convention("radians"):
            pass
    source = tmp_path / "s.nc"
    write_atomic(ds, source)
    code, _, err = run_cli(["plot", source, "-o", tmp_path / "w.png", "--wrap-phase"], capsys)
    assert code == 0, err


def test_branch_phase_unwrapped_along_the_branch(branch_ds):
    ds = branch_ds.copy(deep=True)
    ds["phase"].values[0, :, 0] = np.mod(np.linspace(330.0, 390.0, ds.sizes["point"]), 360.0)
    fig = figure(ds, view="harmonics", harmonics=[1])
    drawn = np.concatenate([y for _, y in _curves(fig.axes[1])])
    assert drawn.max() < 180.0 and drawn.min() == pytest.approx(-30.0)  # no jump to 360
    with plot.phase_convention(plot.WRAPPED):
        fig = figure(ds, view="harmonics", harmonics=[1])
    drawn = np.concatenate([y for _, y in _curves(fig.axes[1])])
    assert np.nanmax(drawn) > 300.0  # as stored, broken where it wraps


FIXTURES_AND_VIEWS = (
    [("sweep_ds", view) for view in KINDS["sweep"].views]
    + [("trace_ds", v) for v in KINDS["trace"].views]
    + [("branch_ds", v) for v in KINDS["branch"].views]
    + [("study_ds", "jumps"), ("accuracy_ds", "errors")]
)


@pytest.mark.parametrize("fixture, view", FIXTURES_AND_VIEWS)
def test_one_unit_convention(fixture, view, request, sweep_ds):
    ds = request.getfixturevalue(fixture)
    overlay = sweep_ds if fixture == "branch_ds" else None
    fig = figure(ds, view=view, overlay=overlay)
    fig.canvas.draw()
    labels = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            text = axis.get_label().get_text()
            if text and axis.get_visible() and axis.get_label().get_visible():
                labels.append(text)
        for child in ax.child_axes:  # the secondary axes in Hz
            labels += [t for t in (child.get_xlabel(), child.get_ylabel()) if t]
    assert labels
    wrong = [label for label in labels if not UNIT.search(label) or "F_s$]" in label]
    assert not wrong, wrong


def test_default_dpi_is_for_print():
    assert DEFAULT_DPI == plot.DPI == 200


def test_png_metadata_and_dpi(sweep_ds, tmp_path, capsys):
    source = tmp_path / "s.nc"
    write_atomic(sweep_ds, source)
    out = tmp_path / "f.png"
    argv = ["plot", source, "-o", out, "--view", "amplitude", "--harmonic", "1", "--dpi", "150"]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    with Image.open(out) as image:
        assert image.size == (8.0 * 150, 5.0 * 150)
        text = dict(image.text)
    assert text["Software"] == f"hertzsweep {__version__}"
    assert text["Source"] == str(source.resolve())
    assert text["Title"].startswith("Simulated stepped-sine sweep")
    command = f"hertzsweep plot {source.resolve()} -o {out.resolve()} --view amplitude"
    assert f"drawn by: {command} --harmonic 1 --dpi 150" in text["Description"]
    assert f"dataset made by: {sweep_ds.attrs['history']}" in text["Description"]


def test_pdf_and_svg_metadata(sweep_ds, tmp_path, capsys):
    source = tmp_path / "s.nc"
    write_atomic(sweep_ds, source)
    for suffix, expected in (
        (".pdf", [b"/Creator (hertzsweep ", b"/Subject (" + str(source.resolve()).encode()]),
        (".svg", [b"<dc:source>" + str(source.resolve()).encode(), b"hertzsweep plot"]),
    ):
        out = tmp_path / f"m{suffix}"
        code, _, err = run_cli(["plot", source, "-o", out], capsys)
        assert code == 0, err
        data = out.read_bytes()
        for needle in expected:
            assert needle in data, (suffix, needle)


def test_fractional_orders_are_drawn_and_named_as_fractions(tmp_path, capsys):
    # A sweep reading H1/2 .. H2: a row per order, each labelled with its order as a
    # fraction ($H_{1/2}$, $H_{3/2}$; whole ones as before), --harmonic takes "1/2" or 0.5,
    # and the summary's peak and jumps go by H1 whatever order comes first
    scene = make_scene(
        excitation={"sigma": [0.01]},
        sweep={"start": 0.97, "stop": 0.99, "step": 0.01, "settle_periods": 50,
               "measure_periods": 4},
        lockin={"harmonics": [0.5, 1, 1.5, 2]},
    )  # fmt: skip
    result = run_sweep(scene)
    ds = sweep_dataset(result, scene).to_xarray()
    fig = figure(ds)
    labels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()]
    assert labels[:2] == [
        "$H_{1/2}$ amplitude of $N/F_s$ [1]",
        "$H_{1/2}$ phase lag, unwrapped [degree]",
    ]
    assert [label.split("$")[1] for label in labels[::2]] == [
        "H_{1/2}",
        "H_{1}",
        "H_{3/2}",
        "H_{2}",
    ]
    chosen = plot.select_harmonics(ds, ["1/2", 2.0])
    assert chosen.harmonic.values.tolist() == [0.5, 2.0]
    with pytest.raises(
        HertzsweepError, match=r"--harmonic: 1/3 not in the dataset \(it holds 1/2, 1, 3/2, 2\)"
    ):
        plot.select_harmonics(ds, ["1/3"])
    with pytest.raises(HertzsweepError, match="--harmonic: '0.2' is not an order > 0"):
        plot.select_harmonics(ds, ["0.2"])
    source = tmp_path / "halves.nc"
    write_atomic(ds, source)
    code, _, err = run_cli(["plot", source, "-o", tmp_path / "f.png", "--harmonic", "3/2"], capsys)
    assert code == 0, err
    from hertzsweep.output.summary import sweep_summary

    lines = sweep_summary(result, ds).splitlines()
    assert "peak H1" in lines[0]
    peak = float(lines[1].split()[2])
    assert peak == pytest.approx(
        float(ds.amplitude.sel(harmonic=1).isel(direction=0).max()), abs=1e-4
    )
