"""``hertzsweep rerun IN.nc -o OUT.nc [--set k=v]``: the command that made a dataset,
run again from the dataset alone, gives the same data variables bit for bit (every kind);
``--set`` changes what it says; a dataset without its configuration is refused.

The datasets are those of ``tests/test_cf.py`` (one run of each command per session).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from hertzsweep.output.dataset import open_dataset, write_atomic

from .conftest import run_cli
from .test_cf import KINDS, kind_files

MEASURED = {"accuracy": {"wall_time", "pareto"}}  # measures of the machine, not the model


@pytest.fixture(scope="module")
def files():
    return kind_files()


def assert_identical_data(a, b, skip=()):
    """Every variable (data and coordinates): same names, dims, dtype and values, bit for
    bit (NaN where NaN)."""
    assert set(a.variables) == set(b.variables)
    for name in a.variables:
        if name in skip:
            continue
        x, y = a[name], b[name]
        assert x.dims == y.dims and x.dtype == y.dtype, name
        assert np.array_equal(x.values, y.values, equal_nan=x.dtype.kind == "f"), name


@pytest.mark.parametrize("kind", KINDS)
def test_rerun_is_bit_identical(kind, files, tmp_path, capsys):
    source = files[kind]
    out = tmp_path / f"again-{kind}.nc"
    code, stdout, err = run_cli(["rerun", source, "-o", out, "-q", "--workers", "1"], capsys)
    assert code == 0, err
    assert f"wrote {out}" in stdout
    original, again = open_dataset(source), open_dataset(out)
    assert again.attrs["hertzsweep_kind"] == kind
    skip = MEASURED.get(kind, set())
    assert_identical_data(original, again, skip)
    for name in skip:  # measured again, so present
        assert name in again
    if "wall_time" in skip:
        assert np.all(again["wall_time"].values > 0)
    for name in ("config_json", "command_json"):  # what it ran is what it records
        assert json.loads(again.attrs[name]) == json.loads(original.attrs[name])


def test_rerun_with_set_changes_the_scene(files, tmp_path, capsys):
    out = tmp_path / "stiffer.nc"
    argv = ["rerun", files["trace"], "-o", out, "-q", "--set", "damping.ratio=0.02"]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    original, changed = open_dataset(files["trace"]), open_dataset(out)
    assert json.loads(changed.attrs["config_json"])["damping"]["ratio"] == 0.02
    assert changed.attrs["damping_ratio"] == 0.02
    # the command's own arguments are kept: the same frequency, periods and samples
    assert changed.attrs["command_json"] == original.attrs["command_json"]
    np.testing.assert_array_equal(changed.tau.values, original.tau.values)
    assert not np.array_equal(changed.amplitude.values, original.amplitude.values)


def test_rerun_of_a_study_with_set(files, tmp_path, capsys):
    out = tmp_path / "study.nc"
    argv = ["rerun", files["study"], "-o", out, "-q", "--workers", "1",
            "--set", "sweep.step=0.05"]  # fmt: skip
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    ds = open_dataset(out)
    np.testing.assert_allclose(ds.frequency_ratio.values, [0.9, 0.95, 1.0])
    assert list(ds.damping_law.values) == ["viscous", "contact"]
    assert json.loads(ds.attrs["config_json"])["scene"]["sweep"]["step"] == 0.05


@pytest.mark.parametrize(
    "argv_tail, message",
    [
        (["--set", "damping.ratio=-1"], "--set: damping.ratio: must be >= 0"),
        (["--set", "damping.colour=1"], "damping.colour: unknown key"),
    ],
)
def test_rerun_bad_set_exit_2(files, tmp_path, capsys, argv_tail, message):
    out = tmp_path / "x.nc"
    code, _, err = run_cli(["rerun", files["sweep"], "-o", out, *argv_tail], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_rerun_refuses_a_dataset_without_its_configuration(files, tmp_path, capsys):
    ds = open_dataset(files["sweep"])
    del ds.attrs["config_json"]
    old = tmp_path / "old.nc"
    write_atomic(ds, old)
    code, _, err = run_cli(["rerun", old, "-o", tmp_path / "x.nc"], capsys)
    assert code == 2 and "no config_json attribute" in err
    ds.attrs["config_json"] = "{not json"
    write_atomic(ds, old)
    code, _, err = run_cli(["rerun", old, "-o", tmp_path / "x.nc"], capsys)
    assert code == 2 and "config_json is not valid JSON" in err
    assert not (tmp_path / "x.nc").exists()


def test_rerun_refuses_a_kind_it_cannot_run(files, tmp_path, capsys):
    from hertzsweep.api.rerun import RUNNERS
    from hertzsweep.core.kinds import KINDS as REGISTRY

    others = [name for name in REGISTRY if name not in RUNNERS and name != "study"]
    if not others:
        pytest.skip("every registered kind is made by a command rerun knows")
    ds = open_dataset(files["sweep"])
    ds.attrs["hertzsweep_kind"] = others[0]
    odd = tmp_path / "odd.nc"
    write_atomic(ds, odd)
    code, _, err = run_cli(["rerun", odd, "-o", tmp_path / "x.nc"], capsys)
    assert code == 2 and f"cannot rerun a {others[0]} dataset" in err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "x.nc").exists()
