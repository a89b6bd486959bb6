"""Studies: grid expansion and naming, the combined dataset, failed cases, engines,
interruption and resume."""

import hashlib
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from hertzsweep.core.kinds import STUDY_KINDS
from hertzsweep.drivers.study import Engine, canonical_json, case_hash, expand, run_case, run_study
from hertzsweep.drivers.study import load_study as load_study_file
from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.jobs.study import parts_folder, read_part
from hertzsweep.output.dataset import open_dataset

from .conftest import CONFIGS, PAPER_RIG, run_cli

VARIABLES = (
    "amplitude",
    "phase",
    "force_max",
    "force_min",
    "contact_loss_fraction",
    "flight_time",
    "settled",
    "periodic",
    "jump_frequency_ratio",
)


def load_study(path):
    """A study file with the kinds the registry can run as cases (as the command reads it)."""
    return load_study_file(path, STUDY_KINDS)


def toml_value(value):
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return repr(value)


def write_study(path, grid, split_sigma=False, **tables):
    """A study file with an inline scene on the paper's rig: few frequencies, few periods."""
    scene = {
        "damping": {"ratio": 0.01, "law": "contact", "exponent": 1.5},
        "excitation": {"sigma": [0.01]},
        "sweep": {
            "start": 0.7,
            "stop": 1.0,
            "step": 0.1,
            "settle_periods": 40,
            "measure_periods": 4,
        },
        "solver": {"steps_per_period": 64},
    }
    for name, table in tables.items():
        scene.setdefault(name, {}).update(table)
    lines = ['kind = "sweep"', f"split_sigma = {str(split_sigma).lower()}", "[rig]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in PAPER_RIG.items()]
    for name, table in scene.items():
        lines.append(f"[{name}]")
        lines += [f"{k} = {toml_value(v)}" for k, v in table.items()]
    lines.append("[grid]")
    lines += [f'"{k}" = {toml_value(v)}' for k, v in grid.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


GRID = {
    "damping.exponent": [0, 1.5],
    "damping.ratio": [0.01, 0.02],
    "excitation.sigma": [0.004, 0.06],
}


def test_grid_expansion_names_and_hashes(tmp_path):
    study = load_study(write_study(tmp_path / "s.toml", GRID))
    assert [a.dim for a in study.grid] == ["damping_exponent", "damping_ratio", "sigma"]
    cases = expand(study)
    # sigma is not split: each case holds every sigma of the grid (one batched loop)
    assert [c.values for c in cases] == [
        {"damping.exponent": n, "damping.ratio": z} for n in (0, 1.5) for z in (0.01, 0.02)
    ]
    assert [c.index for c in cases] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    for case in cases:
        assert case.scene.excitation.sigma == (0.004, 0.06)
        assert case.scene.damping.exponent == case.values["damping.exponent"]
        assert case.hash == hashlib.sha256(canonical_json(case.scene, "sweep").encode()).hexdigest()
    assert len({c.hash for c in cases}) == 4
    # the hash is the resolved config: the same case from another file has the same hash
    again = expand(load_study(write_study(tmp_path / "t.toml", GRID)))
    assert [c.hash for c in again] == [c.hash for c in cases]
    assert case_hash(cases[0].scene, "branch") != cases[0].hash
    split = expand(load_study(write_study(tmp_path / "u.toml", GRID, split_sigma=True)))
    assert len(split) == 8 and split[1].values["excitation.sigma"] == 0.06
    assert split[1].scene.excitation.sigma == (0.06,)


def test_paper_study_file():
    study = load_study(CONFIGS / "studies" / "fig15.toml")  # scene path relative to the study
    cases = expand(study)
    assert study.kind == "sweep" and len(cases) == 4
    assert [c.values["damping.exponent"] for c in cases] == [0, 0.5, 1, 1.5]
    scene = cases[0].scene
    assert scene.damping.law == "contact" and scene.damping.ratio == 0.01
    assert scene.sweep.directions == ("down",)
    assert min(scene.excitation.sigma) == 0.002 and max(scene.excitation.sigma) == 0.08


@pytest.mark.parametrize(
    "grid, key, reason",
    [
        ({"damping.foo": [1]}, "damping.foo", "unknown key"),
        ({"nosuch.key": [1]}, "nosuch.key", "known table"),
        ({"damping.ratio": [0.01, -1]}, "damping.ratio", "must be >= 0"),
        ({"damping.law": ["viscous", "dry"]}, "damping.law", "expected one of"),
        ({"damping.ratio": 0.01}, "grid.damping.ratio", "non-empty list"),
        ({"damping.ratio": [0.01, 0.01]}, "grid.damping.ratio", "distinct"),
    ],
)
def test_bad_grid_is_one_line_exit_2(tmp_path, capsys, grid, key, reason):
    path = write_study(tmp_path / "bad.toml", grid)
    code, _, err = run_cli(["study", path, "-o", tmp_path / "x.nc"], capsys)
    assert code == 2
    assert err.count("\n") == 1 and f"{path}: {key}: " in err and reason in err
    assert not (tmp_path / "x.nc").exists() and not parts_folder(tmp_path / "x.nc").exists()


def test_unknown_study_key_and_kind(tmp_path, capsys):
    path = write_study(tmp_path / "bad.toml", {"damping.ratio": [0.01]})
    path.write_text(path.read_text().replace('kind = "sweep"', 'kind = "sweeps"'))
    code, _, err = run_cli(["study", path, "-o", tmp_path / "x.nc"], capsys)
    assert code == 2 and f"{path}: kind: " in err
    path.write_text(path.read_text().replace('kind = "sweeps"', 'kinds = "sweep"'))
    code, _, err = run_cli(["study", path, "-o", tmp_path / "x.nc"], capsys)
    assert code == 2 and f"{path}: kinds: unknown key" in err


def sweep_vars(ds):
    return ds[list(VARIABLES)]


def test_combined_dataset_dims_and_numbers(tmp_path, capsys):
    out = tmp_path / "study.nc"
    path = write_study(tmp_path / "s.toml", GRID)
    code, stdout, err = run_cli(["study", path, "-o", out, "--workers", "2", "-q"], capsys)
    assert code == 0, err
    assert "4 cases: 4 computed, 0 resumed, 0 failed" in stdout
    ds = open_dataset(out)
    assert ds.attrs["hertzsweep_kind"] == "study" and ds.attrs["study_kind"] == "sweep"
    assert ds.amplitude.dims == (
        "direction",
        "damping_exponent",
        "damping_ratio",
        "sigma",
        "frequency_ratio",
        "harmonic",
    )
    assert ds.jump_frequency_ratio.dims == (
        "direction",
        "damping_exponent",
        "damping_ratio",
        "sigma",
    )
    assert ds.case_failed.dims == ("damping_exponent", "damping_ratio", "sigma")
    assert np.all(ds.case_failed == 0)
    np.testing.assert_array_equal(ds.damping_exponent, [0, 1.5])
    np.testing.assert_array_equal(ds.sigma, [0.004, 0.06])
    assert ds.damping_exponent.attrs["units"] == "1" and ds.damping_exponent.attrs["long_name"]
    # the varying config values are coordinates, not global attributes
    assert "damping_exponent" not in ds.attrs and "damping_ratio" not in ds.attrs
    assert ds.attrs["damping_law"] == "contact"
    # every case equals its own single-trajectory sweep (bit for bit)
    for case in expand(load_study(path)):
        single = run_sweep(case.scene)
        sel = ds.sel(
            damping_exponent=case.values["damping.exponent"],
            damping_ratio=case.values["damping.ratio"],
        )
        assert np.array_equal(sel.amplitude.values, single.amplitude)
        assert np.array_equal(
            sel.jump_frequency_ratio.values, single.jump_frequency_ratio, equal_nan=True
        )
        assert sel.case_id.item() == case.hash
    assert np.nanmax(ds.contact_loss_fraction) > 0.2  # sigma = 6 % impacts
    # one case per sigma gives the same numbers
    split_out = tmp_path / "split.nc"
    split = write_study(tmp_path / "split.toml", GRID, split_sigma=True)
    code, stdout, err = run_cli(["study", split, "-o", split_out, "--workers", "2", "-q"], capsys)
    assert code == 0 and "8 cases: 8 computed" in stdout, err
    assert sweep_vars(open_dataset(split_out)).equals(sweep_vars(ds))


def unstable_at_run_time(tmp_path):
    """A study of two cases; the second (N = 12) fails in the kernel, not before."""
    return write_study(
        tmp_path / "s.toml",
        {"solver.steps_per_period": [64, 12]},
        damping={"ratio": 0.05, "exponent": 0},
        excitation={"sigma": [2.0]},
        sweep={"start": 0.5, "stop": 0.5},
    )


def test_failed_case_is_reported_and_others_complete(tmp_path, capsys):
    # N = 12 passes the preflight's stability estimate (11.0 at w = 0.5) but the impacts
    # of sigma = 2 with contact damping n = 0 reach a compression beyond it: the kernel
    # stops that case at run time (a case that fails the preflight stops the whole study
    # before any runs, see test_preflight.py); the other case runs
    out = tmp_path / "study.nc"
    path = unstable_at_run_time(tmp_path)
    code, stdout, err = run_cli(["study", path, "-o", out, "--workers", "2", "-q"], capsys)
    assert code == 1
    lines = err.strip().splitlines()
    assert len(lines) == 2 and "1 of 2 cases failed" in lines[1]
    assert "solver.steps_per_period=12: StabilityError:" in lines[0]
    assert "stability limit" in lines[0] and ".error.json" in lines[0]
    cases = expand(load_study(path))
    record = json.loads((parts_folder(out) / f"{cases[1].hash}.error.json").read_text())
    assert record["grid"] == {"solver.steps_per_period": 12}
    assert record["config"]["steps_per_period"] == 12
    assert record["config"]["damping_exponent"] == 0
    assert record["error"]["type"] == "StabilityError"
    assert "Traceback" in record["error"]["traceback"]
    ds = open_dataset(out)
    assert ds.case_failed.dims == ("solver_steps_per_period",)
    np.testing.assert_array_equal(ds.case_failed, [0, 1])
    good = ds.sel(solver_steps_per_period=64)
    assert np.array_equal(good.amplitude.values, run_sweep(cases[0].scene).amplitude)
    assert np.all(np.isnan(ds.amplitude.sel(solver_steps_per_period=12)))
    assert np.all(ds.settled.sel(solver_steps_per_period=12) == -1)
    assert "StabilityError" in ds.attrs["study_failures"] and ds.attrs["study_failed"] == 1


def test_branch_study_pads_points(tmp_path, capsys):
    from hertzsweep.drivers.continuation import run_branch
    from hertzsweep.output.dataset import branch_dataset

    # two spans give branches of different lengths: the shorter is padded along `point`
    out = tmp_path / "branch.nc"
    path = write_study(
        tmp_path / "b.toml",
        {"sweep.stop": [0.98, 1.05], "excitation.sigma": [0.004, 0.01]},
        sweep={"start": 0.9, "step": 0.05},
    )
    path.write_text(path.read_text().replace('kind = "sweep"', 'kind = "branch"'))
    code, stdout, err = run_cli(["study", path, "-o", out, "--workers", "2", "-q"], capsys)
    assert code == 0, err
    ds = open_dataset(out)
    assert ds.attrs["study_kind"] == "branch"
    assert ds.amplitude.dims == ("sweep_stop", "sigma", "point", "harmonic")
    assert ds.multiplier_real.dims == ("sweep_stop", "sigma", "point", "multiplier")
    for case in expand(load_study(path)):
        part = branch_dataset(run_branch(case.scene), case.scene).to_xarray()
        sel = ds.sel(sweep_stop=case.values["sweep.stop"])
        n = part.sizes["point"]
        assert np.array_equal(sel.amplitude.values[:, :n], part.amplitude.values)
        assert np.all(np.isnan(sel.amplitude.values[:, n:]))
        assert np.all(sel.stable.values[:, n:] == -1)
    assert (
        ds.sizes["point"]
        > 100
        > int(np.isfinite(ds.frequency_ratio.sel(sweep_stop=0.98).isel(sigma=0)).sum())
    )


class InProcess(Engine):
    """Runs each case at once, in this process (what the pools do, without the pool)."""

    name = "in process"

    def __init__(self):
        self.outcomes = {}

    def submit(self, case, runner):
        self.outcomes[case.hash] = run_case(runner, case.scene)
        return case.hash

    def completed(self, handles, timeout):
        return [(handle, self.outcomes.pop(handle)) for handle in handles]

    def stop(self, handles):
        pass

    def close(self):
        pass


def test_driver_hands_results_to_on_case_and_writes_nothing(tmp_path, monkeypatch):
    # The driver runs each case to its driver's result and hands it to the caller's
    # on_case; it writes no file (the output layer does, through on_case)
    monkeypatch.chdir(tmp_path)
    path = unstable_at_run_time(tmp_path)
    cases = expand(load_study(path))
    before = sorted(tmp_path.rglob("*"))
    kept = []

    def on_case(case, outcome):
        kept.append((case, outcome))
        return outcome

    run = run_study(cases, InProcess(), run_sweep, on_case, skip=cases[1:])
    assert sorted(tmp_path.rglob("*")) == before
    assert [case for case, _ in kept] == cases[:1] == run.computed and run.resumed == cases[1:]
    assert np.array_equal(kept[0][1].result.amplitude, run_sweep(cases[0].scene).amplitude)
    # a case that fails comes back as its error, with the traceback; the others go on
    run = run_study(cases, InProcess(), run_sweep, on_case)
    ((case, error),) = run.failed
    assert case is cases[1] and error["type"] == "StabilityError"
    assert "Traceback" in error["traceback"] and run.computed == cases[:1]


def test_unreadable_part_is_not_resumed(tmp_path):
    bad = tmp_path / "x.nc"
    bad.write_bytes(b"CDF\x01 not a netCDF file")
    assert read_part(bad) is None
    assert read_part(tmp_path / "absent.nc") is None


# --------------------------------------------------------------------------- slow
@pytest.mark.slow
def test_dask_local_cluster_gives_the_local_pool_numbers(tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    path = write_study(tmp_path / "s.toml", GRID)
    local, remote = tmp_path / "local.nc", tmp_path / "dask.nc"
    code, _, err = run_cli(["study", path, "-o", local, "--workers", "2", "-q"], capsys)
    assert code == 0, err
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        argv = ["study", path, "-o", remote, "--scheduler", cluster.scheduler_address, "-q"]
        code, stdout, err = run_cli(argv, capsys)
    assert code == 0, err
    assert "on Dask cluster (2 slots)" in stdout
    a, b = open_dataset(local), open_dataset(remote)
    assert sweep_vars(a).equals(sweep_vars(b)) and a.case_id.equals(b.case_id)


def slow_study(tmp_path):
    # six cases of about 0.3 s each (one worker): SIGTERM lands while they run
    grid = {"damping.exponent": [0, 0.5, 1, 1.5, 2, 2.5], "excitation.sigma": [0.004, 0.06]}
    return write_study(tmp_path / "slow.toml", grid, sweep={"settle_periods": 6000})


def start(path, out, *extra):
    cmd = [sys.executable, "-m", "hertzsweep", "study", str(path), "-o", str(out), "-q", *extra]
    return subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )


def wait_for_parts(folder, count, proc, timeout=120.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if folder.exists() and len(list(folder.glob("*.nc"))) >= count:
            return
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.02)
    raise AssertionError("no part appeared")


def interrupted(path, out):
    """The study run on one worker and sent SIGTERM once its first part is kept: the
    process (ended with exit status 128 + SIGTERM) and its standard error."""
    proc = start(path, out, "--workers", "1")
    wait_for_parts(parts_folder(out), 1, proc)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signal.SIGTERM, err
    return proc, err


def group_gone(pgid, timeout=10.0):
    deadline = time.monotonic() + timeout
    while True:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        if time.monotonic() > deadline:
            return False
        time.sleep(0.1)


def snapshot(folder):
    return {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in folder.glob("*.nc")}


@pytest.mark.slow
def test_sigterm_then_resume_equals_the_uninterrupted_study(tmp_path):
    path = slow_study(tmp_path)
    out = tmp_path / "study.nc"
    folder = parts_folder(out)
    proc, err = interrupted(path, out)
    assert "interrupted by SIGTERM" in err and "--resume" in err
    assert group_gone(proc.pid)  # the workers ended with the driver
    assert not out.exists()
    before = snapshot(folder)
    assert 1 <= len(before) < 6
    for name in before:
        assert read_part(folder / name, name[:-3]) is not None
    resumed = start(path, out, "--workers", "1", "--resume")
    stdout, err = resumed.communicate(timeout=120)
    assert resumed.returncode == 0, err
    assert f"6 cases: {6 - len(before)} computed, {len(before)} resumed, 0 failed" in stdout
    after = snapshot(folder)
    assert len(after) == 6 and all(after[name] == before[name] for name in before)
    whole = tmp_path / "whole.nc"
    fresh = start(path, whole, "--workers", "2")
    _, err = fresh.communicate(timeout=120)
    assert fresh.returncode == 0, err
    a, b = open_dataset(out), open_dataset(whole)
    assert sweep_vars(a).equals(sweep_vars(b)) and a.case_id.equals(b.case_id)


@pytest.mark.slow
def test_sigkill_leaves_no_corrupt_part_or_output(tmp_path):
    path = slow_study(tmp_path)
    out = tmp_path / "study.nc"
    folder = parts_folder(out)
    proc = start(path, out, "--workers", "2")
    wait_for_parts(folder, 2, proc)
    proc.kill()
    proc.wait(timeout=30)
    try:  # the workers notice that their driver is gone and end
        assert group_gone(proc.pid)
    finally:
        if not group_gone(proc.pid, 0.0):
            os.killpg(proc.pid, signal.SIGKILL)  # this test's own session
        proc.communicate(timeout=30)
    assert not out.exists()
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}")]
    hashes = {c.hash for c in expand(load_study(path))}
    parts = list(folder.glob("*.nc"))
    assert len(parts) >= 2
    for part in parts:  # every part present opens and is the case it names
        assert part.stem in hashes and read_part(part, part.stem) is not None
