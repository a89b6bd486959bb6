"""Every dataset kind is a complete record: CF-1.11 clean by the IOOS compliance checker
(full score, Appendix A checks included, no checker exception, no network), traceable to
the code that made it and to its whole configuration; writing it imports neither dask nor
distributed.

The five datasets are made once per test session by the real commands on a tiny scene
(:func:`kind_files`; ``tests/test_rerun.py`` reruns the same files).
"""

from __future__ import annotations

import atexit
import functools
import json
import os
import platform
import shutil
import socket
import subprocess
import sys
import tempfile
import textwrap
import warnings
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from hertzsweep import __version__
from hertzsweep.core.config import load_scene, scene_from_dict
from hertzsweep.output.dataset import (
    INDEX,
    ORDER,
    REFERENCES,
    absolute_arguments,
    open_dataset,
    source_checkout,
    write_atomic,
)

ROOT = Path(__file__).resolve().parents[1]
KINDS = ("sweep", "trace", "branch", "study", "accuracy")
# A tiny scene: the paper's rig, contact damping, 2 levels x 5 frequencies x 2 directions,
# 40 + 4 periods of 64 steps (a few hundred thousand steps per command).
SCENE = """\
[rig]
geometry = "double-sphere-plane"
ball_radius = 12.7e-3
youngs_modulus = 210e9
poisson_ratio = 0.29
mass = 11.4
static_load = 110.0

[damping]
ratio = 0.01
law = "contact"
exponent = 1.5

[excitation]
sigma = [0.01, 0.03]

[sweep]
start = 0.90
stop = 1.00
step = 0.025
settle_periods = 40
measure_periods = 4

[solver]
steps_per_period = 64
"""
# A study on it: a string grid key (a label coordinate) and sigma, down sweeps only.
STUDY = """\
kind = "sweep"
scene = "scene.toml"
[sweep]
directions = ["down"]
[grid]
"damping.law" = ["viscous", "contact"]
"excitation.sigma" = [0.01, 0.03]
"""
COMMANDS = {  # kind -> the command line that makes it (the output and -q added)
    "sweep": ["sweep", "scene.toml"],
    "trace": ["trace", "scene.toml", "--frequency", "0.95", "--periods", "2",
              "--samples-per-period", "32"],
    "branch": ["branch", "scene.toml"],
    "study": ["study", "study.toml", "--workers", "1"],
    "accuracy": ["accuracy", "scene.toml", "--steps", "64,128,256", "--settle", "20,40",
                 "--target", "1e-3"],
}  # fmt: skip


def run(argv: list[str]) -> None:
    """``hertzsweep ARGV`` in this process, as the program (``sys.argv`` is what a
    dataset's ``history`` records); a non-zero exit fails the test."""
    from hertzsweep.cli import main

    argv = [str(a) for a in argv]
    saved = sys.argv
    sys.argv = ["hertzsweep", *argv]
    try:
        main(argv)
    except SystemExit as exc:
        assert not exc.code, f"hertzsweep {' '.join(argv)}: exit {exc.code}"
    finally:
        sys.argv = saved


@functools.cache
def kind_files() -> dict[str, Path]:
    """Each kind's dataset, made once per session in a folder removed at exit, by the
    commands of :data:`COMMANDS` run from that folder (relative paths, as a user types
    them)."""
    folder = Path(tempfile.mkdtemp(prefix="hertzsweep-kinds-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    (folder / "scene.toml").write_text(SCENE)
    (folder / "study.toml").write_text(STUDY)
    files = {}
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        for kind in KINDS:
            run([*COMMANDS[kind], "-o", f"{kind}.nc", "-q"])
            files[kind] = folder / f"{kind}.nc"
    finally:
        os.chdir(cwd)
    return files


@pytest.fixture(scope="module")
def files() -> dict[str, Path]:
    return kind_files()


@pytest.fixture
def no_network(monkeypatch):
    """Any attempt to open a network connection fails the test."""

    def refuse(*args, **kwargs):
        raise AssertionError(f"network use: {args}")

    monkeypatch.setattr(socket.socket, "connect", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)


def compliance(path: Path) -> tuple[int, int, dict[str, str], list[str]]:
    """CF-1.11 by the compliance checker, every priority and the Appendix A checks:
    ``(scored, possible, checker exceptions, messages of the failed checks)``."""
    from compliance_checker.runner import CheckSuite

    suite = CheckSuite(options={"cf": {"enable_appendix_a_checks"}})
    with warnings.catch_warnings():  # its other checkers' deprecations, not ours
        warnings.simplefilter("ignore", DeprecationWarning)
        suite.load_all_available_checkers()
    ds = suite.load_dataset(str(path))
    groups, errors = suite.run_all(ds, ["cf:1.11"], [], None)["cf:1.11"]
    report = suite.build_structure("cf:1.11", groups, str(path), 1)  # 1: every priority
    failed = [
        f"{result.name}: {message}"
        for level in ("high_priorities", "medium_priorities", "low_priorities")
        for result in report[level]
        if result.value[0] != result.value[1]
        for message in result.msgs
    ]
    found = {name: str(error[0]) for name, error in errors.items()}
    return report["scored_points"], report["possible_points"], found, failed


# --------------------------------------------------------------------------- CF
@pytest.mark.parametrize("kind", KINDS)
def test_compliance_checker_full_score(kind, files, no_network):
    scored, possible, errors, failed = compliance(files[kind])
    assert not errors, errors  # the checker ran every check (no crash on a string label)
    assert not failed, failed
    assert scored == possible and possible > 300  # every check counted, none missed


def test_the_compliance_check_can_fail(files, tmp_path, no_network):
    """What xarray's own writer made before: a _FillValue on coordinates, units on a
    string label, a string coordinate variable: the checker scores it below full."""
    ds = open_dataset(files["sweep"])
    old = tmp_path / "xarray.nc"
    ds["direction"].attrs["units"] = "1"
    for var in ds.variables.values():
        var.encoding = {}  # xarray's defaults, as it writes a dataset it built
    ds.to_netcdf(old, engine="netcdf4")
    scored, possible, errors, failed = compliance(old)
    assert scored < possible and any("_FillValue" in message for message in failed)
    assert "check_coordinate_variables_strict_monotonicity" in errors


@pytest.mark.parametrize("kind", KINDS)
def test_cf_details(kind, files):
    with netCDF4.Dataset(files[kind]) as nc:
        assert nc.Conventions == "CF-1.11" and nc.references == REFERENCES
        coordinates = {name for var in nc.variables.values()
                       for name in getattr(var, "coordinates", "").split()}  # fmt: skip
        coordinates |= {name for name in nc.variables if name in nc.dimensions}
        for name, var in nc.variables.items():
            assert var.long_name, name
            if name in coordinates:
                assert "_FillValue" not in var.ncattrs(), name
            if var.dtype == "S1":  # a string label: characters, UTF-8, no units
                assert var.dimensions[-1].startswith("string") and var._Encoding == "utf-8"
                assert "units" not in var.ncattrs(), name
            else:
                assert "units" in var.ncattrs(), name
            if name in ("point", "multiplier", "bifurcation", "flight_count",
                        "bifurcation_point", "branch_bridges", "steps_per_period"):  # fmt: skip
                assert var.dtype == INDEX, (name, var.dtype)
            if name == "harmonic":  # orders k: whole, or 1/2, 1/3, 1/4 of the excitation's
                assert var.dtype == ORDER, (name, var.dtype)
        for name in ("direction", "damping_law", "setting_label"):
            if name in nc.variables:  # labels, not CF coordinate variables (numeric only)
                assert nc.variables[name].dimensions[-1].startswith("string")


def test_a_string_coordinate_reads_back_as_strings(files):
    ds = open_dataset(files["sweep"])
    assert list(ds.direction.values) == ["up", "down"] and "units" not in ds.direction.attrs
    study = open_dataset(files["study"])
    assert list(study.damping_law.values) == ["viscous", "contact"]
    assert study.damping_law.attrs["config_key"] == "damping.law"


@pytest.mark.parametrize("kind", KINDS)
def test_written_and_read_back_identical(kind, files, tmp_path):
    ds = open_dataset(files[kind])
    write_atomic(ds, tmp_path / "again.nc")
    xr.testing.assert_identical(open_dataset(tmp_path / "again.nc"), ds)


# --------------------------------------------------------------------------- provenance
def git_head() -> str | None:
    if source_checkout() is None:
        return None
    done = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True
    )
    return done.stdout.strip() if done.returncode == 0 else None


@pytest.mark.parametrize("kind", KINDS)
def test_provenance(kind, files):
    import numba

    attrs = open_dataset(files[kind]).attrs
    assert attrs["hertzsweep_version"] == __version__ and __version__ in attrs["source"]
    assert attrs["python_version"] == platform.python_version()
    assert attrs["numpy_version"] == np.__version__
    assert attrs["numba_version"] == numba.__version__
    head = git_head()
    if head is None:  # an installed copy: no commit to name
        assert "git_commit" not in attrs
    else:
        assert attrs["git_commit"] == head and attrs["git_modified"] in (0, 1)
    # the command line with absolute paths, and the folder it ran in
    folder = files[kind].parent
    history = attrs["history"]
    assert f" -o {folder / (kind + '.nc')} " in history and f"(in {folder}; " in history
    source = "study.toml" if kind == "study" else "scene.toml"
    assert f" {folder / source} " in history


def test_version_identifies_the_code():
    """The version comes from git at install time (setuptools-scm): a release ``X.Y.Z``
    at a tag, else ``X.Y.Z.devN+gHASH`` naming a commit of this repository (an editable
    install keeps the version of its install; ``git_commit`` is read at run time)."""
    from packaging.version import Version

    version = Version(__version__)  # PEP 440
    if git_head() is None or version.local is None:
        return
    node = version.local.split(".")[0]
    assert node.startswith("g"), version
    done = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet", f"{node[1:]}^{{commit}}"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, f"{__version__}: {node[1:]} is no commit of this repository"


@pytest.mark.parametrize("kind", ["sweep", "trace", "branch", "accuracy"])
def test_config_json_is_the_whole_scene(kind, files):
    attrs = open_dataset(files[kind]).attrs
    scene = load_scene(files[kind].parent / "scene.toml")
    config = json.loads(attrs["config_json"])
    assert list(config) == ["rig", "damping", "excitation", "sweep", "solver", "lockin", "model"]
    assert scene_from_dict(config, source=scene.source) == scene  # the same scene, resolved
    assert config["rig"]["static_load"] == 110.0 and config["sweep"]["settle_periods"] == 40


def test_config_json_of_a_study(files):
    config = json.loads(open_dataset(files["study"]).attrs["config_json"])
    assert config["kind"] == "sweep" and config["split_sigma"] is False
    assert config["grid"] == {"damping.law": ["viscous", "contact"],
                              "excitation.sigma": [0.01, 0.03]}  # fmt: skip
    base = scene_from_dict(config["scene"])
    assert base.sweep.directions == ("down",)  # the study's own override of its scene
    assert base.rig == load_scene(files["study"].parent / "scene.toml").rig


def test_command_json(files):
    def command(kind):
        return json.loads(open_dataset(files[kind]).attrs["command_json"])

    assert command("sweep") == {"command": "sweep"}
    assert command("trace") == {"command": "trace", "frequency_ratio": 0.95, "periods": 2,
                                "branch": "upper", "samples_per_period": 32}  # fmt: skip
    accuracy = command("accuracy")
    labels = open_dataset(files["accuracy"]).setting_label.values
    assert accuracy["target"] == 1e-3 and len(accuracy["settings"]) == labels.size
    assert accuracy["settings"][-1] == {"steps_per_period": 256, "settle_periods": 40,
                                        "tolerance": None, "steady_state": "settle",
                                        "method": "rk4"}  # fmt: skip


def test_absolute_arguments(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "scene.toml").write_text("")
    argv = ["hertzsweep", "sweep", "scene.toml", "-o", "out.nc", "--set", "a.b=1", "--overlay=s.nc"]
    assert absolute_arguments(argv) == [
        "hertzsweep", "sweep", str(tmp_path / "scene.toml"), "-o", str(tmp_path / "out.nc"),
        "--set", "a.b=1", f"--overlay={tmp_path / 's.nc'}",
    ]  # fmt: skip


# --------------------------------------------------------------------------- no dask
WRITE_IN_A_FRESH_PROCESS = textwrap.dedent(
    """
    import sys
    import numpy as np
    import xarray as xr
    from hertzsweep.output.dataset import write_atomic

    ds = xr.Dataset(
        {"amplitude": (("direction", "w"), np.ones((2, 3))),
         "kind": ("direction", np.array(["fold", ""], dtype=object))},
        coords={"direction": ("direction", np.array(["up", "down"], dtype=object)),
                "w": ("w", [0.9, 1.0, 1.1]), "frequency": ("w", [200.0, 230.0, 250.0])},
    )
    def loaded():
        return sorted(m for m in sys.modules if m.split(".")[0] in ("dask", "distributed"))
    before = loaded()  # xarray itself imports dask.array when it builds a Dataset
    write_atomic(ds, sys.argv[1])
    print(",".join(sorted(set(loaded()) - set(before))))
    print("distributed" in sys.modules)
    """
)


def test_writing_imports_neither_dask_nor_distributed(tmp_path):
    done = subprocess.run(
        [sys.executable, "-c", WRITE_IN_A_FRESH_PROCESS, str(tmp_path / "w.nc")],
        capture_output=True,
        text=True,
        check=True,
    )
    imported, distributed = done.stdout.splitlines()
    assert imported == "" and distributed == "False"
    assert list(open_dataset(tmp_path / "w.nc").direction.values) == ["up", "down"]


@pytest.mark.parametrize("settle", ["300", '"auto"'])
@pytest.mark.parametrize("path", sorted((ROOT / "configs").rglob("*.toml")), ids=str)
def test_to_dict_round_trips_every_scene(path, settle):
    """``Scene.to_dict`` gives tables ``scene_from_dict`` reads back into the same scene,
    through JSON, for every scene of configs/ (fixed and automatic settling)."""
    from hertzsweep.core.config import read_toml

    raw = read_toml(path)
    if set(raw) & {"kind", "grid", "run"} or "rig" not in raw:
        pytest.skip("not a scene")
    scene = load_scene(path, [f"sweep.settle_periods={settle}"])
    config = json.loads(json.dumps(scene.to_dict()))
    assert scene_from_dict(config, source=scene.source) == scene


def test_scene_file_is_absolute(files):
    attrs = open_dataset(files["sweep"]).attrs
    assert attrs["scene_file"] == str(files["sweep"].parent / "scene.toml")
