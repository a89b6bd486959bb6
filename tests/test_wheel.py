"""The wheel alone: built from the checkout, installed in a fresh virtual environment and
run from a folder outside any git checkout, it reports its version, imports from itself
(not from the checkout's ``src``) and runs the default example scene to the same table as
``make demo`` (``hertzsweep sweep configs/default.toml`` in the checkout)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SECONDS = 900  # per command: a build, an install from the index, a sweep that compiles first

pytestmark = pytest.mark.slow


def run(argv: list[str], cwd: Path, env: dict[str, str] | None = None) -> str:
    """Run a command; its stdout, or the test fails with its stderr."""
    done = subprocess.run(
        [str(a) for a in argv],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=SECONDS,
        check=False,
    )
    assert done.returncode == 0, (
        f"{' '.join(map(str, argv))}: exit {done.returncode}\n{done.stderr}"
    )
    return done.stdout


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """``(venv, work, env)``: a fresh virtual environment holding the wheel, a working
    folder outside the checkout, and an environment with no PYTHONPATH in which git finds
    no checkout."""
    tmp = tmp_path_factory.mktemp("wheel")
    build = ROOT / "build"  # setuptools' build folder, made in the checkout by the build
    had_build = build.exists()
    try:
        run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", tmp / "dist", ROOT], tmp)
    finally:
        if not had_build:
            shutil.rmtree(build, ignore_errors=True)
    (wheel,) = (tmp / "dist").glob("hertzsweep-*.whl")
    run([sys.executable, "-m", "venv", tmp / "venv"], tmp)
    venv = tmp / "venv"
    run([venv / "bin" / "python", "-m", "pip", "install", "--quiet", wheel], tmp)
    env = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
    env.update(GIT_DIR=str(tmp / "no-git"), GIT_CEILING_DIRECTORIES=str(tmp))
    work = tmp / "work"
    work.mkdir()
    return venv, work, env


def test_the_installed_command_has_a_version(installed):
    venv, work, env = installed
    out = run([venv / "bin" / "hertzsweep", "--version"], work, env)
    assert re.search(r"\d+\.\d+", out) and "0+unknown" not in out, out


def test_the_installed_package_is_the_wheel_with_its_examples(installed):
    venv, work, env = installed
    code = (
        "import hertzsweep; from hertzsweep.core.examples import example_path; "
        "print(hertzsweep.__file__); print(example_path('default'))"
    )
    package, example = run([venv / "bin" / "python", "-c", code], work, env).splitlines()
    assert Path(package).is_relative_to(venv) and not Path(package).is_relative_to(ROOT)
    assert Path(example).is_relative_to(venv) and Path(example).is_file()
    assert (Path(example).parent / "rig.toml").is_file()


def test_the_installed_example_prints_the_demo_table(installed, tmp_path):
    venv, work, env = installed
    program = [venv / "bin" / "hertzsweep", "sweep", "--example", "default"]
    installed_lines = run([*program, "-o", "out.nc"], work, env).splitlines()
    checkout = Path(sys.executable).with_name("hertzsweep")
    demo = [checkout, "sweep", "configs/default.toml", "-o", tmp_path / "demo.nc"]
    demo_lines = run(demo, ROOT).splitlines()
    assert installed_lines[-1].startswith("wrote ") and demo_lines[-1].startswith("wrote ")
    assert installed_lines[:-1] == demo_lines[:-1]
    assert (work / "out.nc").is_file()
