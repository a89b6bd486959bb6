"""``hertzsweep random`` and ``hs.random``: the command writes the API's dataset, ``validate``
reads a random scene, the other commands refuse it (and ``random`` a sine scene), ``rerun``
makes the same data, an interrupted run keeps its finished segments; ``plot`` draws the
three views of a random dataset (the PSD, the PDF, the loss of contact)."""

from __future__ import annotations

import contextlib
import dataclasses
import io
import math
import signal

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

import hertzsweep as hs
from hertzsweep.core.excitation import linear_response_variance
from hertzsweep.core.kinds import KINDS
from hertzsweep.output import plot
from hertzsweep.output.dataset import open_dataset
from hertzsweep.output.figures import figure

from .conftest import CONFIGS, PAPER_RIG, run_cli
from .test_api import same
from .test_rerun import assert_identical_data
from .tomlwriter import toml_document

LEVELS = [0.02, 0.15]  # linear, then frequent loss of contact
BAND, ZETA = (0.2, 3.0), 0.0045
SCENE = {  # a random scene of a second: 2 levels x 3 realisations x 72 periods of 32 steps
    "rig": dict(PAPER_RIG),
    "damping": {"ratio": 0.0045, "law": "viscous"},
    "excitation": {"kind": "random", "rms": LEVELS, "band": [0.2, 3.0], "seed": 7},
    "random": {
        "realisations": 3,
        "duration_periods": 64,
        "transient_periods": 8,
        "segment_periods": 16,
        "force_bins": 50,
    },
    "solver": {"steps_per_period": 32},
}


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "random.toml"
    path.write_text(toml_document(SCENE))
    return path


@pytest.fixture(scope="module")
def written(scene_file, tmp_path_factory):
    """The command's file and what it printed."""
    out = tmp_path_factory.mktemp("run") / "random.nc"
    code, printed = _run(["random", scene_file, "-o", out, "-q"])
    assert code == 0, printed
    return out, printed


def _run(argv):
    """``hertzsweep ARGV`` in-process, outside a test's capsys (a module's fixture):
    (status, stdout and stderr)."""
    from hertzsweep.cli import main

    stdout = io.StringIO()
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stdout):
            main([str(a) for a in argv])
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    return code, stdout.getvalue()


@pytest.fixture(scope="module")
def ds(written):
    return open_dataset(written[0])


# --------------------------------------------------------------------------- the command
def test_the_command_writes_the_apis_dataset(written, scene_file):
    out, printed = written
    assert printed.splitlines()[-1] == f"wrote {out}"
    assert printed.splitlines()[0].startswith("rms 0.02: N rms ")  # a line per level
    same(hs.random(hs.load_scene(scene_file)), out)


def test_validate_prints_its_line(scene_file, capsys):
    code, out, err = run_cli(["validate", scene_file], capsys)
    assert (code, err) == (0, ""), err
    (line,) = out.splitlines()
    assert line.startswith(
        f"{scene_file}: ok: random: 2 rms x 3 realisation(s) (6 trajectories of 8 + 64 "
        "periods); band 0.2 .. 3; steps_per_period 32 is "
    ), line
    assert f"{6 * 72 * 32:.3g} integration steps" in line


def _refused(code, err, *words):
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("hertzsweep: error: "), err
    assert "Traceback" not in err
    for word in words:
        assert word in err, (word, err)


def test_sweep_refuses_a_random_scene(scene_file, tmp_path, capsys):
    out = tmp_path / "sweep.nc"
    code, _, err = run_cli(["sweep", scene_file, "-o", out, "-q"], capsys)
    _refused(code, err, str(scene_file), "excitation.kind", "a random scene runs with random")
    assert not out.exists()


def test_random_refuses_a_sine_scene(tmp_path, capsys):
    out = tmp_path / "random.nc"
    code, _, err = run_cli(["random", CONFIGS / "smoke.toml", "-o", out, "-q"], capsys)
    _refused(code, err, "smoke.toml", "excitation.kind", "sine")
    assert list(tmp_path.iterdir()) == []


def test_rerun_gives_the_same_data(written, ds, tmp_path, capsys):
    again = tmp_path / "again.nc"
    code, stdout, err = run_cli(["rerun", written[0], "-o", again, "-q"], capsys)
    assert code == 0, err
    assert f"wrote {again}" in stdout
    rerun = open_dataset(again)
    assert rerun.attrs["hertzsweep_kind"] == "random"
    assert_identical_data(ds, rerun)


@pytest.fixture
def interrupted_random(monkeypatch):
    """The random driver runs, then reports an interrupt with its whole result as the
    partial one (as SIGINT after the last segment would)."""
    from hertzsweep.errors import Interrupted

    real = KINDS["random"]

    def run_then_interrupt(scene, progress=None):
        raise Interrupted(real.run(scene, progress), signal.SIGINT)

    monkeypatch.setitem(KINDS, "random", dataclasses.replace(real, run=run_then_interrupt))


def test_an_interrupted_run_keeps_its_segments(
    scene_file, ds, tmp_path, capsys, interrupted_random
):
    out = tmp_path / "x.nc"
    code, _, err = run_cli(["random", scene_file, "-o", out, "-q"], capsys)
    assert code == 130 and err.splitlines()[-1] == "hertzsweep: error: interrupted", err
    assert "kept 4 finished segment(s) of every realisation" in err  # 64 / 16 periods
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.partial.nc"]
    partial = open_dataset(tmp_path / "x.partial.nc")
    assert partial.attrs["complete"] == 0
    assert_identical_data(ds, partial)  # the whole run finished before the interrupt


# --------------------------------------------------------------------------- the figures
def _labels(ax) -> list[str]:
    return ax.get_legend_handles_labels()[1]


def test_the_psd_view(ds):
    fig = figure(ds)  # the default view
    assert isinstance(fig, Figure)
    (ax,) = fig.axes
    lines = ax.get_lines()
    assert len(lines) == len(LEVELS) + 2  # every level, the linear model as is and as Welch
    assert _labels(ax) == [
        "rms 2 %",
        "rms 15 %",
        r"linear model $|H|^2 S_f$",
        "linear model, as Welch sees it",
    ]
    assert ax.get_yscale() == "log"
    w = ds.frequency_ratio.values
    for line, level in zip(lines, LEVELS, strict=False):
        shown = len(line.get_xdata())
        np.testing.assert_array_equal(line.get_xdata(), w[:shown])
        np.testing.assert_array_equal(line.get_ydata(), ds.psd.sel(rms=level).values[:shown])
    assert w[shown - 1] <= 1.2 * 3.0 < w[shown]  # up to 1.2 w_high
    # the linear model of the lowest level at the bins, as the Welch estimate sees it
    welch = plot.linear_model_psd(w[:shown], LEVELS[0], BAND, ZETA, segment_periods=16)
    np.testing.assert_array_equal(lines[-1].get_ydata(), welch)


@pytest.mark.parametrize("segment", [16, 64])
def test_the_linear_model_through_the_window_keeps_the_variance(segment):
    # Parseval: the smoothed PSD summed over the bins k / segment times the resolution
    # 1 / segment is the variance rms^2 V (the leakage beyond 6 w_high is below 1e-8)
    w = np.arange(1, 18 * segment) / segment
    welch = plot.linear_model_psd(w, 0.1, BAND, ZETA, segment_periods=segment)
    variance = 0.01 * linear_response_variance(BAND, ZETA)
    assert np.sum(welch) / segment == pytest.approx(variance, rel=1e-6)
    # away from the resonance and the band's ends, the window changes little: 1.5 % at a
    # resolution of 1/16, 0.11 % at 1/64 between w = 0.3 and 0.6
    exact = plot.linear_model_psd(w, 0.1, BAND, ZETA)
    flat = (w > 0.3) & (w < 0.6)
    np.testing.assert_allclose(welch[flat], exact[flat], rtol=0.016 if segment == 16 else 0.0012)


def test_the_pdf_view(ds):
    fig = figure(ds, view="pdf")
    assert len(fig.axes) == len(LEVELS)  # a panel a level
    for ax, level in zip(fig.axes, LEVELS, strict=True):
        histogram, gaussian, zero = ax.get_lines()
        np.testing.assert_array_equal(histogram.get_ydata(), ds.force_pdf.sel(rms=level).values)
        x, y = gaussian.get_xdata(), gaussian.get_ydata()
        mean, rms = (float(ds[name].sel(rms=level)) for name in ("force_mean", "force_rms"))
        assert x[np.argmax(y)] == pytest.approx(mean, abs=x[1] - x[0])
        area = np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x))
        assert area == pytest.approx(1.0, abs=1e-5)  # +-5 RMS: all but 6e-7
        assert list(zero.get_xdata()) == [0.0, 0.0]
        assert ax.get_yscale() == "log"
        assert f"rms {100 * level:g} %" in ax.get_title(loc="left")
    assert "out of contact" in fig.axes[1].get_title(loc="left")  # the loss at rms 0.15


def test_the_loss_view(ds):
    fig = figure(ds, view="loss")
    left, right = fig.axes[:2]
    assert _labels(left) == [
        r"Gaussian linear response: $P(q < -3/2)$",
        r"Gaussian linear response: $P(1 + q < 0)$",
        "simulated (d <= 0)",
    ]
    assert _labels(right) == ["linear resonance", "peak of the PSD (Welch resolution 1/16)"]
    loss = ds.contact_loss_fraction.values
    assert loss[0] == 0 < loss[1]  # the linear level is not drawn on the log axis
    (bars,) = left.containers  # the error bars of the simulated loss
    simulated = bars.lines[0]
    np.testing.assert_array_equal(simulated.get_xdata(), [15.0])
    np.testing.assert_array_equal(simulated.get_ydata(), loss[1:])
    # the Gaussian exceedance: erfc(3/2 / (sqrt 2 sigma)) / 2, sigma the linear RMS
    (gaussian,) = [line for line in left.get_lines() if "3/2" in line.get_label()]
    level = gaussian.get_xdata()[-1] / 100.0
    sigma = level * math.sqrt(linear_response_variance(BAND, ZETA))
    expected = 0.5 * math.erfc(1.5 / (math.sqrt(2.0) * sigma))
    assert gaussian.get_ydata()[-1] == pytest.approx(expected, rel=1e-12)
    (peak,) = right.containers
    np.testing.assert_array_equal(peak.lines[0].get_xdata(), 100.0 * ds.rms.values)
    np.testing.assert_array_equal(peak.lines[0].get_ydata(), ds.peak_frequency_ratio.values)
    assert left.get_xscale() == right.get_xscale() == "log" == left.get_yscale()


def test_plot_writes_the_loss_view(written, tmp_path, capsys):
    png = tmp_path / "loss.png"
    code, stdout, err = run_cli(["plot", written[0], "-o", png, "--view", "loss"], capsys)
    assert code == 0, err
    assert stdout.strip() == f"wrote {png}"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert Image.open(png).size == (round(12.0 * plot.DPI), round(5.5 * plot.DPI))


def test_an_unknown_view_is_one_line(written, tmp_path, capsys):
    argv = ["plot", written[0], "-o", tmp_path / "x.png", "--view", "jumps"]
    code, _, err = run_cli(argv, capsys)
    _refused(code, err, "--view", "psd, pdf, loss")


def random_drawn(fig, ds, kwargs):
    """The check of `plot` for a random dataset (used by tests/test_plot.py): the PSD of
    every level is drawn as stored; returns the levels' curves."""
    lines = fig.axes[0].get_lines()
    for line, level in zip(lines, ds.rms.values, strict=False):
        shown = len(line.get_xdata())
        np.testing.assert_array_equal(line.get_ydata(), ds.psd.sel(rms=level).values[:shown])
    return ds.rms.size
