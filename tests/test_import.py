"""`hertzsweep import`: measured sweeps and jump frequencies (CSV) into a dataset of kind
``measured`` in the sweep layout; bad files end in one line naming file, line and column
(exit 2); `plot` draws the dataset and `--overlay` puts it over simulated figures."""

import numpy as np
import pytest
import xarray as xr

from hertzsweep.drivers.fit import JumpMeasurements, SweepMeasurements
from hertzsweep.io.measured import (
    measured_dataset,
    measurements_from_dataset,
    read_measurements,
)
from hertzsweep.output import plot
from hertzsweep.output.dataset import global_attributes, open_dataset, write_atomic
from hertzsweep.output.figures import figure

from .conftest import CONFIGS, make_scene, run_cli

SWEEP_CSV = """\
# a lock-in's readings: two levels, up and down, H1 and H2 (comments and blanks skipped)
direction,sigma,frequency,amplitude,phase,harmonic,reference
up,0.006,230.0,0.30,20.0,1,run 1

up,0.006,230.0,0.01,40.0,2,run 1
up,0.006,231.0,0.50,-30.0,1,run 1
down,0.006,231.0,0.60,100.0,1,"run 2, after a pause"
down,0.006,232.5,0.40,150.0,1,"run 2, after a pause"
up,0.01,230.0,0.35,,1,
"""
JUMP_CSV = """\
direction,sigma,jump_frequency
down,0.01,223.4
down,0.03,177.4
up,0.01,229.7
"""


def write(tmp_path, text, name="data.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_sweep_file_to_the_sweep_layout(tmp_path, capsys):
    out = tmp_path / "measured.nc"
    code, stdout, err = run_cli(["import", write(tmp_path, SWEEP_CSV), "-o", out], capsys)
    assert code == 0, err
    assert "6 readings" in stdout and f"wrote {out}" in stdout
    ds = open_dataset(out)
    assert ds.attrs["hertzsweep_kind"] == "measured" and ds.attrs["measured_kind"] == "sweep"
    assert ds.attrs["Conventions"] == "CF-1.11" and ds.attrs["history"]
    assert ds.amplitude.dims == ("direction", "sigma", "frequency", "harmonic")
    assert list(ds.direction.values) == ["up", "down"]
    np.testing.assert_array_equal(ds.sigma, [0.006, 0.01])
    np.testing.assert_array_equal(ds.frequency, [230.0, 231.0, 232.5])
    np.testing.assert_array_equal(ds.harmonic, [1, 2])
    assert ds.frequency.attrs["units"] == "Hz" and ds.phase.attrs["units"] == "degree"
    one = ds.sel(direction="up", sigma=0.006)
    np.testing.assert_array_equal(one.amplitude.sel(harmonic=1), [0.30, 0.50, np.nan])
    np.testing.assert_array_equal(one.amplitude.sel(harmonic=2), [0.01, np.nan, np.nan])
    assert float(one.phase.sel(harmonic=1, frequency=231.0)) == 330.0  # -30 -> [0, 360)
    assert np.isnan(ds.phase.sel(direction="up", sigma=0.01, frequency=230.0, harmonic=1))
    assert int(np.isfinite(ds.amplitude).sum()) == 6  # the rest is NaN: not measured
    assert ds.reference.sel(direction="down", sigma=0.006).item() == "run 2, after a pause"


def test_jump_file_and_the_round_trip(tmp_path, capsys):
    out = tmp_path / "jumps.nc"
    code, stdout, err = run_cli(["import", write(tmp_path, JUMP_CSV), "-o", out], capsys)
    assert code == 0, err
    ds = open_dataset(out)
    assert ds.attrs["measured_kind"] == "jumps"
    assert ds.jump_frequency.dims == ("direction", "sigma")
    assert ds.jump_frequency.attrs["units"] == "Hz"
    np.testing.assert_array_equal(
        ds.jump_frequency.sel(direction="down"), [223.4, 177.4]
    )  # sigma 0.01, 0.03
    assert np.isnan(ds.jump_frequency.sel(direction="up", sigma=0.03))
    back = measurements_from_dataset(ds, str(out))
    read = read_measurements(tmp_path / "data.csv")
    assert isinstance(back, JumpMeasurements) and back.in_hertz
    key = sorted(zip(back.direction, back.sigma, back.frequency, strict=True))
    assert key == sorted(zip(read.direction, read.sigma, read.frequency, strict=True))


def test_sweep_round_trip_through_the_dataset(tmp_path):
    read = read_measurements(write(tmp_path, SWEEP_CSV))
    back = measurements_from_dataset(measured_dataset(read), "measured.nc")
    assert isinstance(back, SweepMeasurements) and back.in_hertz

    def rows(m):
        return sorted(
            zip(m.direction, m.sigma, m.frequency, m.harmonic, m.amplitude, m.phase, strict=True),
            key=lambda r: r[:4],
        )

    for a, b in zip(rows(read), rows(back), strict=True):
        assert a[:5] == b[:5] and (a[5] == b[5] or (np.isnan(a[5]) and np.isnan(b[5])))


def test_frequency_ratios_instead_of_hertz(tmp_path):
    text = "direction,sigma,frequency_ratio,amplitude,phase\nup,0.0003,0.99,0.02,45\n"
    data = read_measurements(write(tmp_path, text))
    assert not data.in_hertz and data.harmonic.tolist() == [1]
    ds = measured_dataset(data)
    assert "frequency_ratio" in ds.amplitude.dims and "frequency" not in ds.dims


BAD_FILES = [  # text, line, column, reason: each rule breaks once
    ("direction,sigma,frequency,amplitude\nup,0.01,230,0.5\n", 1, "phase", "missing column"),
    ("direction,sigma,frequency,amplitude,phase\nup,0.01,230,abc,10\n", 2, "amplitude",
     "not a number: 'abc'"),
    ("direction,sigma,frequency,amplitude,phase\nsideways,0.01,230,0.5,10\n", 2, "direction",
     "unknown direction 'sideways'"),
    ("direction,sigma,frequency,amplitude,phase\nup,0.01,230,0.5,10\n#\nup,0.01,230,0.6,11\n",
     4, "frequency", "repeats line 2"),
    ("direction,sigma,jump_frequency\ndown,0.01,223\ndown,0.01,224\n", 3, "sigma",
     "repeats line 2"),
    ("direction,sigma,frequency,amplitude,phase,colour\nup,0.01,230,0.5,10,red\n", 1, "colour",
     "unknown column"),
    ("direction,sigma,frequency,amplitude,phase\nup,0.01,230,0.5\n", 2, "", "expected 5 cells"),
    ("direction,sigma,frequency,amplitude,phase\nup,-0.01,230,0.5,10\n", 2, "sigma",
     "must be positive"),
    ("direction,sigma,frequency,amplitude,phase,harmonic\nup,0.01,230,0.5,10,1.5\n", 2,
     "harmonic", "whole number"),
    ("direction,sigma,frequency,amplitude,phase\nup,0.01,inf,0.5,10\n", 2, "frequency",
     "finite number"),
    ("direction,sigma,frequency,amplitude,phase\n", 1, "", "no measurements"),
    ("# only a comment\n", 0, "", "no header"),
    ("direction,sigma,frequency,frequency_ratio,amplitude,phase\nup,0.01,230,1,0.5,10\n", 1,
     "frequency_ratio", "give frequency [Hz] or frequency_ratio"),
]  # fmt: skip


@pytest.mark.parametrize("text, line, column, reason", BAD_FILES)
def test_bad_files_exit_2_naming_file_line_and_column(tmp_path, capsys, text, line, column, reason):
    path = write(tmp_path, text, "bad.csv")
    out = tmp_path / "out.nc"
    code, stdout, err = run_cli(["import", path, "-o", out], capsys)
    assert code == 2 and not out.exists()
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    where = f"{path}: " + (f"line {line}: " if line else "") + (f"{column}: " if column else "")
    assert err.startswith(f"hertzsweep: error: {where}") and reason in err, err


def test_missing_file_exit_2(tmp_path, capsys):
    code, _, err = run_cli(["import", tmp_path / "none.csv", "-o", tmp_path / "o.nc"], capsys)
    assert code == 2 and "none.csv: no such file" in err and len(err.strip().splitlines()) == 1


# --------------------------------------------------------------------------- figures
def measured_drawn(fig, ds, kwargs):
    """The check of `plot` for a measured dataset (used by tests/test_plot.py): every
    measured point of every sweep, or every jump, is drawn; returns the series drawn."""
    count = 0
    if ds.attrs["measured_kind"] == "jumps":
        name = "jump_frequency" if "jump_frequency" in ds else "jump_frequency_ratio"
        lines = [line for line in fig.axes[0].get_lines() if line.get_xdata().size]
        for direction in ds.direction.values:
            y = ds[name].sel(direction=direction).values
            keep = np.isfinite(y)
            assert any(
                np.array_equal(line.get_xdata(), 100 * ds.sigma.values[keep])
                and np.array_equal(line.get_ydata(), y[keep])
                for line in lines
            )
            count += 1
        return count
    orders = kwargs.get("harmonics") or list(ds.harmonic.values)
    for row, k in enumerate(orders):
        lines = fig.axes[2 * row].get_lines()
        for direction in ds.direction.values:
            for sigma in ds.sigma.values:
                y = ds.amplitude.sel(direction=direction, sigma=sigma, harmonic=k).values
                keep = np.isfinite(y)
                if not keep.any():
                    continue
                assert any(
                    np.array_equal(line.get_xdata(), ds.frequency.values[keep])
                    and np.array_equal(line.get_ydata(), y[keep])
                    for line in lines
                )
                count += 1
    return count


def test_plot_draws_measured_sweeps_and_jumps(tmp_path, capsys):
    sweeps = measured_dataset(read_measurements(write(tmp_path, SWEEP_CSV)))
    # 4 series of H1 (up and down at 0.6 %, up at 1 %... 3 with data) and 1 of H2
    assert measured_drawn(figure(sweeps), sweeps, {}) == 3 + 1
    jumps = measured_dataset(read_measurements(write(tmp_path, JUMP_CSV, "j.csv")))
    assert measured_drawn(figure(jumps), jumps, {}) == 2
    path = tmp_path / "m.nc"
    write_atomic(sweeps, path)
    code, _, err = run_cli(["plot", path, "-o", tmp_path / "m.png"], capsys)
    assert code == 0, err
    code, _, err = run_cli(["plot", path, "-o", tmp_path / "j.png", "--view", "jumps"], capsys)
    assert code == 2 and "does not show sweeps" in err


def _simulated_sweep():
    """A synthetic sweep dataset at sigma 0.6 % and 1 % on the paper's rig (f0 = 230.776
    Hz): the overlay's frame, no integration needed."""
    scene = make_scene(excitation={"sigma": [0.006, 0.01]})
    w = np.array([0.99, 0.995, 1.0])
    shape = (2, 2, 3, 1)
    data = {
        "amplitude": (("direction", "sigma", "frequency_ratio", "harmonic"), np.ones(shape)),
        "phase": (("direction", "sigma", "frequency_ratio", "harmonic"), np.full(shape, 90.0)),
    }
    coords = {
        "direction": ["up", "down"],
        "sigma": [0.006, 0.01],
        "frequency_ratio": w,
        "harmonic": [1],
    }
    return xr.Dataset(data, coords=coords, attrs=global_attributes(scene, "s", "sweep", "t"))


def test_overlay_over_a_sweep_in_the_figures_frequency_ratio(tmp_path):
    measured = measured_dataset(read_measurements(write(tmp_path, SWEEP_CSV)))
    sweep = _simulated_sweep()
    f0 = sweep.attrs["natural_frequency"]
    fig = figure(sweep, overlay=measured)
    amplitude = fig.axes[0]
    one = measured.sel(direction="up", sigma=0.006, harmonic=1)
    keep = np.isfinite(one.amplitude.values)
    # measured Hz over the simulated f0, in the colour of the simulated sigma = 0.6 %
    (line,) = [
        line
        for line in amplitude.get_lines()
        if line.get_marker() == "s" and np.array_equal(line.get_ydata(), one.amplitude.values[keep])
    ]
    np.testing.assert_allclose(line.get_xdata(), measured.frequency.values[keep] / f0, rtol=1e-15)
    assert line.get_color() == plot.COLOURS[0]
    labels = [t.get_text() for t in amplitude.get_legend().get_texts()]
    assert "measured up sweep" in labels and "measured down sweep" in labels
    with pytest.raises(Exception, match="not in the figure"):
        figure(sweep.sel(sigma=[0.01]).assign_coords(sigma=[0.02]), overlay=measured)


def test_overlay_jumps_over_a_study(tmp_path):
    jumps = measured_dataset(read_measurements(write(tmp_path, JUMP_CSV)))
    scene = make_scene()
    study = xr.Dataset(
        {"jump_frequency_ratio": (("direction", "sigma"), [[0.95, 0.77]])},
        coords={"direction": ["down"], "sigma": [0.01, 0.03]},
        attrs=global_attributes(scene, "s", "study", "t"),
    )
    f0 = study.attrs["natural_frequency"]
    fig = figure(study, overlay=jumps)
    (stars,) = [line for line in fig.axes[0].get_lines() if line.get_marker() == "*"]
    np.testing.assert_allclose(stars.get_xdata(), [1.0, 3.0])  # sigma in %
    np.testing.assert_allclose(stars.get_ydata(), np.array([223.4, 177.4]) / f0, rtol=1e-15)


def test_the_paper_values_import(tmp_path, capsys):
    # configs/measured: every row of the importable files cites where it comes from
    for name in ("paper-down-jumps.csv", "paper-up-jumps.csv"):
        data = read_measurements(CONFIGS / "measured" / name)
        assert not data.in_hertz and all(text.startswith("Section 4.") for text in data.reference)
    down = read_measurements(CONFIGS / "measured" / "paper-down-jumps.csv")
    np.testing.assert_array_equal(down.sigma, [0.01, 0.014, 0.03, 0.07])
    np.testing.assert_array_equal(down.frequency, [0.957, 0.9, 0.76, 0.56])  # section 4.1-4.2
