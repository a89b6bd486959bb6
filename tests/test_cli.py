"""The sweep command end to end: run it, reopen the netCDF, check names, units, numbers."""

import errno
import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hertzsweep.output.dataset import open_dataset

from .conftest import CONFIGS, run_cli


@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "sweep.nc"
    import subprocess
    import sys

    cmd = [
        sys.executable,
        "-m",
        "hertzsweep",
        "sweep",
        str(CONFIGS / "default.toml"),
        "-o",
        str(out),
        "--set",
        "sweep.start=0.5",
        "--set",
        "sweep.stop=0.6",
        "--set",
        "sweep.step=0.05",
        "--set",
        "excitation.sigma=[1e-4, 0.01]",
        "--quiet",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "wrote" in done.stdout and "peak H1" in done.stdout
    return out


def test_dataset_names_units_numbers(sweep_file):
    ds = open_dataset(sweep_file)
    assert ds.attrs["Conventions"] == "CF-1.11"
    assert "hertzsweep sweep" in ds.attrs["history"]
    assert ds.attrs["damping_ratio"] == 0.0045 and ds.attrs["steps_per_period"] == 256
    assert ds.attrs["natural_frequency"] == pytest.approx(230.78, abs=0.01)
    assert list(ds.direction.values) == ["up", "down"]
    assert list(ds.harmonic.values) == [1, 2]
    np.testing.assert_allclose(ds.frequency_ratio, [0.5, 0.55, 0.6])
    np.testing.assert_allclose(ds.frequency, ds.frequency_ratio * ds.attrs["natural_frequency"])
    for name, units in [
        ("amplitude", "1"),
        ("phase", "degree"),
        ("force_max", "1"),
        ("flight_time", "s"),
        ("frequency", "Hz"),
        ("contact_loss_fraction", "1"),
        ("jump_frequency_ratio", "1"),
    ]:
        assert ds[name].attrs["units"] == units and ds[name].attrs["long_name"]
    assert ds.amplitude.dims == ("direction", "sigma", "frequency_ratio", "harmonic")
    # far below resonance the response is quasi-linear: |T| = 1/(1 - w^2) within the
    # Hertz nonlinearity (sigma = 1e-4) and damping (2 zeta w = 0.5 %)
    h1 = ds.amplitude.sel(direction="up", sigma=1e-4, harmonic=1).values / 1e-4
    np.testing.assert_allclose(h1, 1 / (1 - ds.frequency_ratio.values**2), rtol=1e-3)
    assert np.all(ds.phase.sel(harmonic=1, sigma=1e-4) < 1.0)  # nearly in phase
    assert np.all(ds.settled == 1) and np.all(ds.periodic == 1)
    assert np.all(np.isnan(ds.jump_frequency_ratio))
    assert np.all(ds.flight_time == 0)


def test_output_is_atomic(tmp_path, capsys, monkeypatch):
    # The disk fills up half way through writing the netCDF: the command ends with one
    # line and exit 2, the temporary it was writing is removed, and the file already at
    # the output's name (an earlier run's) is untouched.
    out = tmp_path / "x.nc"
    out.write_bytes(b"an earlier run's dataset")
    before = out.stat()
    from hertzsweep.output import dataset as dataset_module

    original = dataset_module.write_netcdf
    written = []

    def fail_half_way(ds, path):
        original(ds, path)
        written.append(Path(path))
        size = Path(path).stat().st_size
        with open(path, "r+b") as handle:
            handle.truncate(size // 2)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(dataset_module, "write_netcdf", fail_half_way)
    code, stdout, err = run_cli(
        [
            "sweep",
            CONFIGS / "default.toml",
            "-o",
            out,
            "-q",
            "--set",
            "sweep.stop=0.9",
            "--set",
            "excitation.sigma=0.01",
        ],
        capsys,
    )
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert f"{out}: No space left on device" in err and "wrote" not in stdout
    # the write went to a temporary beside the output, which is gone
    assert len(written) == 1 and written[0].parent == tmp_path and written[0] != out
    assert sorted(tmp_path.iterdir()) == [out]
    after = out.stat()
    assert out.read_bytes() == b"an earlier run's dataset"
    assert (after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("settle", "wait"),
    [
        # lockstep (fixed settling): the sixteen sweeps advance together, 1501 dwells of
        # 3020 periods (~4e10 trajectory-steps, minutes): at 3 s some dwells are done
        ("3000", 3.0),
        # one sweep at a time ("auto"): 301 dwells, about 0.8 s per sweep, 16 sweeps:
        # at 3.5 s (1 s of it start-up) some but not all have finished
        ("auto", 3.5),
    ],
)
def test_sigterm_keeps_finished_work(tmp_path, settle, wait):
    # A long sweep (8 sigma x 2 directions x 1501 or 301 dwells) stopped by SIGTERM, then
    # SIGTERM again while it writes what it finished: no output file, the finished dwells
    # in OUT.partial.nc with the sweeps that ran to their end flagged, exit 143.
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "long.nc"
    cmd = [
        sys.executable,
        "-m",
        "hertzsweep",
        "sweep",
        str(CONFIGS / "default.toml"),
        "-o",
        str(out),
        "-q",
        "--set",
        "excitation.sigma=[0.001, 0.002, 0.003, 0.004, 0.005, 0.006, 0.007, 0.008]",
        "--set",
        f"sweep.step={0.0005 if settle == 'auto' else 0.0001}",
        "--set",
        f"sweep.settle_periods={settle if settle == 'auto' else int(settle)}",
    ]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    partial = tmp_path / "long.partial.nc"
    time.sleep(wait)
    asked = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    time.sleep(0.05)  # a second SIGTERM, during the partial write: ignored, nothing lost
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    # the bound: exit within 1 s of the signal, partial file written (measured
    # 0.1-0.2 s: the compiled loop stops within a period, xarray is already loaded)
    assert time.monotonic() - asked < 1.0
    assert proc.returncode == 128 + signal.SIGTERM
    assert "interrupted" in err.splitlines()[-1]
    assert not out.exists()
    ds = open_dataset(partial)
    finished = ds.finished.values.astype(bool)
    h1 = ds.amplitude.values[..., 0]  # (direction, sigma, frequency_ratio)
    done = np.isfinite(h1)
    assert ds.attrs["complete"] == 0 and 0 < done.sum() < done.size
    assert np.all(done[finished])  # a finished sweep has every dwell
    # each sweep keeps the dwells it finished, in its own order (up: from the lowest
    # frequency, down: from the highest); those not reached are NaN
    for d, direction in enumerate(ds.direction.values):
        for s in range(ds.sigma.size):
            row = done[d, s] if direction == "up" else done[d, s, ::-1]
            count = int(row.sum())
            assert np.all(row[:count]) and not np.any(row[count:])
    if settle == "auto":
        assert 0 < finished.sum() < finished.size
    else:  # lockstep: every sweep has done the same number of dwells, none finished
        assert not finished.any() and len(set(done.sum(axis=2).ravel())) == 1
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_output_file_mode_follows_umask(sweep_file):
    import os

    mask = os.umask(0)
    os.umask(mask)
    assert sweep_file.stat().st_mode & 0o777 == 0o666 & ~mask


def test_unwritable_output_is_one_line(tmp_path, capsys):
    # /proc refuses new files: the error names the output asked for, not a temporary
    code, _, err = run_cli(
        [
            "sweep",
            CONFIGS / "default.toml",
            "-o",
            "/proc/x.nc",
            "-q",
            "--set",
            "sweep.stop=0.9",
            "--set",
            "excitation.sigma=0.01",
        ],
        capsys,
    )
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert "/proc/x.nc" in err and ".tmp" not in err


def test_context_keeps_the_error_and_its_exit_status(tmp_path, capsys):
    # A layer adds where an error happened without re-making it: same object, type and
    # fields, the message prefixed; it still pickles (a study's workers send errors back)
    import pickle

    from hertzsweep.errors import ConfigError, StabilityError

    error = ConfigError("scene.toml", "damping.ratio", "must be >= 0")
    assert error.with_context("study s.toml") is error
    assert str(error) == "study s.toml: scene.toml: damping.ratio: must be >= 0"
    assert (error.source, error.key, error.reason) == (
        "scene.toml",
        "damping.ratio",
        "must be >= 0",
    )
    again = pickle.loads(pickle.dumps(error))
    assert type(again) is ConfigError and str(again) == str(error) and again.key == error.key
    assert str(StabilityError("h too large").with_context("s.toml: up sweep")) == (
        "s.toml: up sweep: h too large"
    )
    # `plot` names its input before the library's message, exit 2, one line
    from hertzsweep.output.dataset import write_atomic

    source = write_atomic(xr.Dataset(attrs={"hertzsweep_kind": "movie"}), tmp_path / "m.nc")
    code, _, err = run_cli(["plot", source, "-o", tmp_path / "f.png"], capsys)
    assert code == 2 and err.count("\n") == 1
    assert f"error: {source}: hertzsweep_kind: unknown kind 'movie'" in err


def test_bare_hertzsweep_prints_the_usage_and_the_commands(capsys):
    # as git does: the usage and the command list on their own lines, no "error:" mash
    code, out, err = run_cli([], capsys)
    assert code == 2 and out == ""
    assert err.startswith("Usage: hertzsweep [OPTIONS] COMMAND [ARGS]...\n")
    assert "error" not in err
    assert "\n  sweep     Stepped-sine sweeps" in err and err.count("\n") > 20


@pytest.mark.parametrize(
    ("typed", "hint"),
    [
        ("swep", "; did you mean sweep?"),
        ("brach", "; did you mean branch, trace or bench?"),
        ("xyzzy", ""),
    ],
)
def test_an_unknown_command_suggests_the_nearest(typed, hint, capsys):
    code, out, err = run_cli([typed], capsys)
    assert code == 2 and out == ""
    assert err == (
        f"hertzsweep: error: no command {typed!r}{hint} (hertzsweep --help lists them)\n"
    )
