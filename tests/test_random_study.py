"""Studies of random scenes (issue 32): ``kind = "random"`` runs each case with the random
driver on a local pool, and the study's dataset holds, bit for bit, what ``hertzsweep
random`` gives on each case's scene, also with ``split_rms`` (every level its own case:
a realisation's stream depends only on the seed and its number) and with
``split_realisations`` (every case as groups of its realisations, merged)."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from hertzsweep.api.runs import counted_cases
from hertzsweep.core.config import scene_from_dict
from hertzsweep.core.kinds import STUDY_KINDS
from hertzsweep.drivers.random import STATISTICS, merge, run_random
from hertzsweep.drivers.study import expand, realisation_groups, whole_cases
from hertzsweep.drivers.study import load_study as load_study_file
from hertzsweep.jobs import realisations as split_parts
from hertzsweep.jobs.study import (
    part_path,
    parts_folder,
    read_part,
    resumable,
    study_dataset,
)
from hertzsweep.output.dataset import open_dataset

from .conftest import PAPER_RIG, run_cli
from .test_study import interrupted, snapshot, start

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
    head = [line.replace(" = one_and_a_half", " = 1.5") for line in head]
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
        ("random", {"damping.ratio": RATIOS}, {"split_realisations": 0}, "split_realisations"),
        ("random", {}, {"split_realisations": "one_and_a_half"}, "split_realisations"),
        ("random", {}, {"split_realisations": True}, "split_realisations"),
        ("random", {}, {"split_realisations": 5}, "split_realisations"),  # of 4 realisations
        # the fewest realisations of any case
        ("random", {"random.realisations": [8, 2]}, {"split_realisations": 3}, "split_"),
        ("sweep", {"damping.ratio": RATIOS}, {"split_realisations": 2}, "split_realisations"),
        ("random", {"random.first_realisation": [-1]}, {}, "random.first_realisation"),
        ("random", {"random.first_realisation": [0.5]}, {}, "random.first_realisation"),
    ],
)
def test_a_study_keeps_to_its_kind_s_levels(tmp_path, capsys, scene_file, kind, grid, keys, key):
    path = write_study(tmp_path / "study.toml", grid, kind=kind, **keys)
    code, _, err = run_cli(["study", path, "-o", tmp_path / "out.nc"], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and key in lines[0], err


# --------------------------------------------------------------------------- split_realisations
SPLIT = 3  # groups of the 7 realisations below: 3, 2, 2


def split_scene(**random):
    """The scene with 7 realisations and a trace, ``[random]`` keys replaced."""
    raw = {"rig": dict(PAPER_RIG), **copy.deepcopy(SCENE)}
    raw["random"].update({"realisations": 7, "trace_periods": 4, **random})
    return raw


@pytest.fixture
def split_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(toml(split_scene()))
    return path


def assert_same_study(a, b):
    """Every variable and coordinate bit for bit, their attributes and the global ones but
    those that record the study file and its split."""
    assert list(a.variables) == list(b.variables)
    for name in a.variables:
        assert a[name].dims == b[name].dims, name
        assert (
            same(a[name], b[name])
            if a[name].dtype.kind == "f"
            else (np.array_equal(a[name].values, b[name].values))
        ), name
        assert a[name].attrs.keys() == b[name].attrs.keys(), name
    recording = {"history", "study_file", "config_json", "study_split_realisations"}
    kept = [k for k in b.attrs if k not in recording]
    assert [k for k in a.attrs if k not in recording] == kept
    for key in kept:
        assert str(a.attrs[key]) == str(b.attrs[key]), key


def test_realisation_groups_are_contiguous_and_even():
    assert realisation_groups(16, 3) == [(0, 6), (6, 5), (11, 5)]
    assert realisation_groups(7, 3) == [(0, 3), (3, 2), (5, 2)]
    assert realisation_groups(4, 4) == [(0, 1), (1, 1), (2, 1), (3, 1)]
    assert realisation_groups(5, 1) == [(0, 5)]


def test_sub_cases_start_at_the_case_s_own_first_realisation(tmp_path, scene_file):
    # a case of realisations 3..6 (first_realisation 3, 4 realisations) in 3 groups runs
    # 3..4, 5 and 6: the groups count from the case's first, not from 0
    path = tmp_path / "split.toml"
    head = ['kind = "random"', 'scene = "scene.toml"', "split_realisations = 3"]
    path.write_text(toml({"random": {"first_realisation": 3}, "grid": {}}, head))
    cases = expand(load_study_file(path, STUDY_KINDS))
    runs = [(c.scene.random.first_realisation, c.scene.random.realisations) for c in cases]
    assert runs == [(3, 2), (5, 1), (6, 1)]
    assert [c.label for c in cases] == [
        "base, realisations 3-4",
        "base, realisation 5",
        "base, realisation 6",
    ]


@pytest.mark.parametrize("workers", [1, 2])
def test_split_realisations_gives_the_unsplit_study_bit_for_bit(
    tmp_path, capsys, split_file, workers
):
    grid = {"damping.ratio": RATIOS}
    whole_path = write_study(tmp_path / "whole.toml", grid)
    split_path = write_study(tmp_path / "split.toml", grid, split_realisations=SPLIT)
    study = load_study_file(split_path, STUDY_KINDS)
    cases = expand(study)
    assert len(cases) == 2 * SPLIT and len(whole_cases(cases)) == 2
    # what the progress bar and an interruption count
    assert (counted_cases(cases), counted_cases(whole_cases(cases))) == ("6 sub-cases", "2 cases")
    runs = [(c.scene.random.first_realisation, c.scene.random.realisations) for c in cases]
    assert runs == [(0, 3), (3, 2), (5, 2)] * 2
    assert len({c.hash for c in cases}) == len(cases)  # each its own case
    assert [c.hash for c in whole_cases(cases)] == [
        c.hash for c in expand(load_study_file(whole_path, STUDY_KINDS))
    ]
    outputs = {}
    for name, path in (("whole", whole_path), ("split", split_path)):
        out = tmp_path / f"{name}.nc"
        argv = ["study", path, "-o", out, "--workers", str(workers), "-q"]
        code, stdout, err = run_cli(argv, capsys)
        assert code == 0, err
        outputs[name] = open_dataset(out)
    assert "2 cases as 6 sub-cases: 6 computed, 0 resumed, 0 failed" in stdout
    whole, split = outputs["whole"], outputs["split"]
    assert_same_study(split, whole)
    assert not any(name.startswith("realisation") for name in split.variables)
    assert "realisation" not in split.dims
    assert "trace_force" in split and split.attrs["integration_steps"] > 0
    assert split.attrs["study_split_realisations"] == SPLIT
    assert "study_split_realisations" not in whole.attrs
    assert json.loads(split.attrs["config_json"])["split_realisations"] == SPLIT
    assert "split_realisations" not in json.loads(whole.attrs["config_json"])
    # each case's hash is the unsplit case's
    assert split.case_id.values.tolist() == whole.case_id.values.tolist()
    # a re-run with the parts there resumes every sub-case, and gives the same again
    assert resumable(cases, tmp_path / "split.nc") == cases
    argv = ["study", split_path, "-o", tmp_path / "split.nc", "--resume", "-q"]
    argv += ["--workers", str(workers)]
    code, stdout, err = run_cli(argv, capsys)
    assert code == 0, err
    assert "2 cases as 6 sub-cases: 0 computed, 6 resumed, 0 failed" in stdout
    assert_same_study(open_dataset(tmp_path / "split.nc"), whole)


@pytest.mark.slow
def test_an_interrupted_split_study_resumes_to_the_unsplit_dataset(tmp_path, capsys):
    # 2 cases as 6 sub-cases of about 0.3 s each on one worker (2 or 3 realisations x 2
    # levels x 12016 periods of 128 steps): SIGTERM lands after the first part. The parts
    # kept are not touched by the resume, which computes the rest; the dataset is the
    # unsplit study's, bit for bit.
    raw = split_scene(duration_periods=12000, trace_periods=0)
    raw["solver"] = {"steps_per_period": 128}
    (tmp_path / "scene.toml").write_text(toml(raw))
    grid = {"damping.ratio": RATIOS}
    split = write_study(tmp_path / "split.toml", grid, split_realisations=SPLIT)
    out = tmp_path / "split.nc"
    folder = parts_folder(out)
    _, err = interrupted(split, out)
    before = snapshot(folder)
    assert 1 <= len(before) < 6 and not out.exists()
    assert f"interrupted by SIGTERM: {len(before)} of 6 sub-cases finished" in err
    resumed = start(split, out, "--workers", "1", "--resume")
    stdout, err = resumed.communicate(timeout=120)
    assert resumed.returncode == 0, err
    counts = f"{6 - len(before)} computed, {len(before)} resumed, 0 failed"
    assert f"2 cases as 6 sub-cases: {counts}" in stdout
    after = snapshot(folder)
    assert len(after) == 6 and all(after[name] == before[name] for name in before)
    whole = write_study(tmp_path / "whole.toml", grid)
    code, _, err = run_cli(["study", whole, "-o", tmp_path / "whole.nc", "-q"], capsys)
    assert code == 0, err
    assert_same_study(open_dataset(out), open_dataset(tmp_path / "whole.nc"))


@pytest.mark.slow
def test_a_split_study_on_dask_is_the_unsplit_study(tmp_path, capsys, split_file):
    # the sub-cases on a Dask cluster of two worker processes: the same engine code as the
    # local pool, the dataset the unsplit study's bit for bit
    distributed = pytest.importorskip("distributed")
    grid = {"damping.ratio": RATIOS}
    whole = write_study(tmp_path / "whole.toml", grid)
    split = write_study(tmp_path / "split.toml", grid, split_realisations=SPLIT)
    code, _, err = run_cli(["study", whole, "-o", tmp_path / "whole.nc", "-q"], capsys)
    assert code == 0, err
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        argv = ["study", split, "-o", tmp_path / "dask.nc", "-q"]
        code, stdout, err = run_cli([*argv, "--scheduler", cluster.scheduler_address], capsys)
    assert code == 0, err
    assert "2 cases as 6 sub-cases: 6 computed" in stdout and "on Dask cluster" in stdout
    assert_same_study(open_dataset(tmp_path / "dask.nc"), open_dataset(tmp_path / "whole.nc"))


def test_a_sub_case_part_holds_its_realisations(tmp_path, capsys, split_file):
    path = write_study(tmp_path / "split.toml", {}, split_realisations=SPLIT)
    out = tmp_path / "split.nc"
    code, _, err = run_cli(["study", path, "-o", out, "--workers", "2", "-q"], capsys)
    assert code == 0, err
    cases = expand(load_study_file(path, STUDY_KINDS))
    unsplit = run_random(scene_from_dict(split_scene(), source="whole"))
    levels = len(LEVELS)
    for case in cases:
        part = read_part(part_path(parts_folder(out), case), case.hash)
        first, count = case.scene.random.first_realisation, case.scene.random.realisations
        assert part.attrs["realisation_first"] == first
        assert part.sizes["realisation"] == count
        sums = split_parts.group_sums(part)
        mine = np.arange(7).reshape(1, 7)[:, first : first + count]
        columns = (np.arange(levels)[:, None] * 7 + mine).ravel()  # level outer
        assert same(sums.tally.sums, unsplit.sums.tally.sums[:, columns])
        assert same(sums.tally.histogram, unsplit.sums.tally.histogram[:, columns])
        for name in ("nn", "ff", "fn"):
            assert same(getattr(sums.welch, name), getattr(unsplit.sums.welch, name)[columns])
        # the group's own statistics: those of its realisations in the unsplit run (but
        # the FRF's lag, placed about the lag pooled over the run's realisations)
        alone = merge(case.scene, [sums])
        for name, values in alone.per_realisation.items():
            if name != "frf_phase":
                assert same(values, unsplit.per_realisation[name][:, first : first + count]), name


def test_first_realisation_runs_those_realisations_of_a_larger_run():
    five = run_random(scene_from_dict(split_scene(realisations=5), source="five"))
    three = run_random(
        scene_from_dict(split_scene(realisations=3, first_realisation=2), source="three")
    )
    assert three.realisations == 3
    for name, values in three.per_realisation.items():
        if name != "frf_phase":  # about the lag pooled over the run's own realisations
            assert same(values, five.per_realisation[name][:, 2:5]), name
    turns = (three.per_realisation["frf_phase"] - five.per_realisation["frf_phase"][:, 2:5]) / 360
    finite = np.isfinite(turns)
    assert finite.any() and np.allclose(turns[finite], np.round(turns[finite]), atol=1e-9)
    assert not same(three.trace_force, five.trace_force)  # realisation 2's, not 0's


@pytest.mark.parametrize(
    "changes",
    [
        {},
        {"model": {"kind": "ball"}, "solver": {"steps_per_period": 128}},
        {"solver": {"method": "rk4", "steps_per_period": 32}},
    ],
    ids=["single", "ball", "rk4"],
)
def test_merge_of_groups_is_the_run_of_every_realisation(changes):
    raw = split_scene()
    for table, values in changes.items():
        raw.setdefault(table, {}).update(values)
    whole = run_random(scene_from_dict(copy.deepcopy(raw), source="whole"))
    groups = []
    for first, count in realisation_groups(7, SPLIT):
        group = copy.deepcopy(raw)
        group["random"].update(first_realisation=first, realisations=count)
        groups.append(run_random(scene_from_dict(group, source="group")).sums)
    merged = merge(scene_from_dict(copy.deepcopy(raw), source="whole"), groups)
    assert merged.mean.keys() == whole.mean.keys()
    for name in whole.mean:
        assert same(merged.mean[name], whole.mean[name]), name
        assert same(merged.stderr[name], whole.stderr[name]), name
        assert same(merged.per_realisation[name], whole.per_realisation[name]), name
    for name in ("trace_force", "trace_forcing", "trace_tau", "force_bin", "frequency_ratio"):
        assert same(getattr(merged, name), getattr(whole, name)), name
    assert (merged.steps, merged.segments, merged.measured_periods, merged.complete) == (
        whole.steps,
        whole.segments,
        whole.measured_periods,
        whole.complete,
    )
    assert ("ball_flight_fraction" in whole.mean) == ("model" in changes)
