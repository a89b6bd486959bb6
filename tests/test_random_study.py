"""Studies of random scenes (issue 32): ``kind = "random"`` runs each case with the random
driver on a local pool, and the study's dataset holds, bit for bit, what ``hertzsweep
random`` gives on each case's scene, also with ``split_rms`` (every level its own case:
a realisation's stream depends only on the seed and its number)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hertzsweep.drivers.random import STATISTICS
from hertzsweep.drivers.study import expand
from hertzsweep.drivers.study import load_study as load_study_file
from hertzsweep.output.dataset import open_dataset
from hertzsweep.output.kinds import STUDY_KINDS
from hertzsweep.output.study import part_path, parts_folder, read_part, study_dataset

from .conftest import PAPER_RIG, run_cli

LEVELS = [0.001, 0.2]  # the linear regime, and frequent loss of contact
RATIOS = [0.0045, 0.02]  # damping ratios: each case's histogram spans its own range
SCENE = {  # small: 2 levels x 4 realisations x 80 periods of 32 steps, 5 segments measured
    "damping": {"ratio": RATIOS[0], "law": "viscous"},
    "excitation": {"kind": "random", "rms": LEVELS, "band": [0.2, 3.0], "seed": 7},
    "solver": {"steps_per_period": 32},
    "random": {
        "realisations": 4,
        "duration_periods": 80,
        "transient_periods": 16,
        "segment_periods": 16,
        "force_bins": 40,
    },
}
VARIABLES = [*STATISTICS, *(f"{name}_stderr" for name in STATISTICS)]


def toml_value(value):
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return repr(value)


def toml(tables, head=()):
    """TOML text of ``head`` lines then ``{table: {key: value}}``."""
    lines = list(head)
    for name, table in tables.items():
        lines.append(f"[{name}]")
        lines += [f'"{k}" = {toml_value(v)}' for k, v in table.items()]
    return "\n".join(lines) + "\n"


@pytest.fixture
def scene_file(tmp_path):
    """The random scene on the paper's rig."""
    path = tmp_path / "scene.toml"
    path.write_text(toml({"rig": PAPER_RIG, **SCENE}))
    return path


def write_study(path, grid, kind="random", **keys):
    """A study of ``scene.toml`` beside it."""
    head = [f'kind = "{kind}"', 'scene = "scene.toml"']
    head += [f"{k} = {str(v).lower()}" for k, v in keys.items()]
    path.write_text(toml({"grid": grid}, head))
    return path


def random_run(tmp_path, capsys, scene_file, name, *overrides):
    """The dataset of ``hertzsweep random`` on the scene with ``--set`` overrides."""
    out = tmp_path / f"{name}.nc"
    argv = ["random", scene_file, "-o", out, "-q"]
    for override in overrides:
        argv += ["--set", override]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    return open_dataset(out)


def same(a, b):
    """Bit for bit (NaN where NaN)."""
    return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)


def test_random_study_equals_the_random_command_case_by_case(tmp_path, capsys, scene_file):
    path = write_study(tmp_path / "study.toml", {"damping.ratio": RATIOS})
    study = load_study_file(path, STUDY_KINDS)
    cases = expand(study)
    assert [c.scene.excitation.rms for c in cases] == [tuple(LEVELS)] * 2  # levels folded
    out = tmp_path / "study.nc"
    code, stdout, err = run_cli(["study", path, "-o", out, "--workers", "2", "-q"], capsys)
    assert code == 0, err
    assert "2 cases: 2 computed, 0 resumed, 0 failed" in stdout
    ds = open_dataset(out)
    assert ds.attrs["hertzsweep_kind"] == "study" and ds.attrs["study_kind"] == "random"
    assert ds.attrs["study_split_rms"] == 0
    assert ds.psd.dims == ("damping_ratio", "rms", "frequency_ratio")
    assert ds.force_mean.dims == ("damping_ratio", "rms")
    assert ds.force_pdf.dims == ("damping_ratio", "rms", "force_bin")
    # the histogram spans 1 + 10 linear RMS, which depend on the damping: the bins are
    # each case's, numbered along force_bin
    assert ds.force_bin_centre.dims == ("damping_ratio", "force_bin")
    assert "force_bin" not in ds.coords
    assert not same(ds.force_bin_centre[0], ds.force_bin_centre[1])
    assert np.all(ds.case_failed == 0)
    assert json.loads(ds.attrs["config_json"])["split_rms"] is False
    for i, ratio in enumerate(RATIOS):
        single = random_run(tmp_path, capsys, scene_file, f"z{i}", f"damping.ratio={ratio}")
        case = ds.sel(damping_ratio=ratio)
        for name in VARIABLES:
            assert same(case[name], single[name]), name
        assert same(case.force_bin_centre, single.force_bin)
        assert same(case.rms, single.rms) and same(case.frequency_ratio, single.frequency_ratio)
        assert case.case_id.item() == cases[i].hash
    assert ds.contact_loss_fraction.sel(rms=LEVELS[1]).min() > 0.01  # the loud level loses
    assert ds.contact_loss_fraction.sel(rms=LEVELS[0]).max() == 0  # contact, the quiet not


def test_split_rms_gives_every_level_of_one_run(tmp_path, capsys, scene_file):
    path = write_study(tmp_path / "study.toml", {"excitation.rms": LEVELS}, split_rms=True)
    study = load_study_file(path, STUDY_KINDS)
    cases = expand(study)
    assert [c.scene.excitation.rms for c in cases] == [(LEVELS[0],), (LEVELS[1],)]
    out = tmp_path / "split.nc"
    code, stdout, err = run_cli(["study", path, "-o", out, "--workers", "2", "-q"], capsys)
    assert code == 0, err
    assert "2 cases: 2 computed" in stdout
    ds = open_dataset(out)
    assert ds.attrs["study_split_rms"] == 1
    assert ds.psd.dims == ("rms", "frequency_ratio") and ds.rms.values.tolist() == LEVELS
    whole = random_run(tmp_path, capsys, scene_file, "whole")
    for name in VARIABLES:  # every spectrum and statistic is that of one run of both levels
        if not name.startswith("force_pdf"):
            assert same(ds[name], whole[name]), name
    # the histogram spans a run's largest level: a split case's spans its own level, and is
    # that of a run of that level alone
    assert ds.force_bin_centre.dims == ("rms", "force_bin")
    assert same(ds.force_pdf.sel(rms=LEVELS[1]), whole.force_pdf.sel(rms=LEVELS[1]))
    for i, level in enumerate(LEVELS):
        alone = random_run(tmp_path, capsys, scene_file, f"r{i}", f"excitation.rms=[{level}]")
        for name in ("force_pdf", "force_pdf_stderr"):
            assert same(ds[name].sel(rms=level), alone[name].sel(rms=level)), name
        assert same(ds.force_bin_centre.sel(rms=level), alone.force_bin)
    # a failed case: fill values along its level, its bins' centres too
    parts = {c.index: read_part(part_path(parts_folder(out), c), c.hash) for c in cases}
    parts[cases[0].index] = None
    failed = study_dataset(study, cases, parts)
    assert failed.case_failed.values.tolist() == [1, 0]
    assert np.all(np.isnan(failed.psd.sel(rms=LEVELS[0])))
    assert np.all(np.isnan(failed.force_bin_centre.sel(rms=LEVELS[0])))
    assert same(failed.psd.sel(rms=LEVELS[1]), whole.psd.sel(rms=LEVELS[1]))


@pytest.mark.parametrize(
    "kind, grid, keys, key",
    [
        ("random", {"excitation.sigma": [0.01, 0.02]}, {}, "grid.excitation.sigma"),
        ("random", {"damping.ratio": RATIOS}, {"split_sigma": True}, "split_sigma"),
        ("sweep", {"damping.ratio": RATIOS}, {"split_rms": True}, "split_rms"),
        ("sweep", {"damping.ratio": RATIOS}, {}, "kind"),  # a sweep of a random scene
    ],
)
def test_a_study_keeps_to_its_kind_s_levels(tmp_path, capsys, scene_file, kind, grid, keys, key):
    path = write_study(tmp_path / "study.toml", grid, kind=kind, **keys)
    code, _, err = run_cli(["study", path, "-o", tmp_path / "out.nc"], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and key in lines[0], err
