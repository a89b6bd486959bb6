"""The Makefile finds a suitable Python by itself: the first of python3.11, python3.12,
python3.13 and python3 that runs and is 3.11 or newer, unless PYTHON= names one.

Each case runs ``make -n install`` (commands printed, none run) in a copy of the Makefile
with a PATH holding only stub interpreters, which answer the Makefile's version check
(``-c 'import sys; sys.exit(sys.version_info < (3, 11))'``) as the named version would:
a machine whose only Python is 3.12, one with an old ``python3``, one with none.
"""

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAKE = shutil.which("make")
OLD, NEW = "3.10", "3.12"  # a version the check refuses, one it takes


def stubs(folder: Path, pythons: dict[str, str]) -> Path:
    """A folder of stub interpreters ``{name: version}``; each exits 0 when its version
    is 3.11 or newer (the Makefile's check), 1 otherwise."""
    folder.mkdir()
    for name, version in pythons.items():
        major, minor = (int(v) for v in version.split("."))
        stub = folder / name
        stub.write_text(f"#!/bin/sh\nexit {int((major, minor) < (3, 11))}\n")
        stub.chmod(0o755)
    return folder


def make_install(tmp_path: Path, pythons: dict[str, str], *args: str):
    """``make -n install`` in a copy of the Makefile, PATH = only the stubs."""
    work = tmp_path / "project"
    work.mkdir()
    shutil.copy(ROOT / "Makefile", work / "Makefile")
    (work / "pyproject.toml").write_text("")
    path = stubs(tmp_path / "bin", pythons)
    return subprocess.run(
        [MAKE, "-n", "install", *args],
        cwd=work,
        env={"PATH": str(path)},
        capture_output=True,
        text=True,
    )


def venv_python(done) -> str:
    """The interpreter ``make install`` would build .venv with."""
    (line,) = [line for line in done.stdout.splitlines() if line.endswith(" -m venv .venv")]
    return line.split()[0]


pytestmark = pytest.mark.skipif(MAKE is None, reason="no make")


@pytest.mark.parametrize(
    "pythons, found",
    [
        ({"python3.12": NEW}, "python3.12"),  # a machine whose only Python is 3.12
        ({"python3": OLD, "python3.12": NEW}, "python3.12"),
        ({"python3.13": NEW, "python3": NEW}, "python3.13"),
        ({"python3": NEW}, "python3"),  # python3 when it is new enough
        ({"python3.11": NEW, "python3.12": NEW}, "python3.11"),  # the first in order
    ],
)
def test_finds_a_suitable_python(tmp_path, pythons, found):
    done = make_install(tmp_path, pythons)
    assert done.returncode == 0, done.stderr
    assert venv_python(done) == found


def test_python_given_is_used(tmp_path):
    done = make_install(tmp_path, {"python3.12": NEW}, "PYTHON=/opt/py/bin/python3")
    assert venv_python(done) == "/opt/py/bin/python3"


def test_no_suitable_python_one_clear_line(tmp_path):
    printed = make_install(tmp_path, {"python3": OLD})
    # -n prints the check; run for real, the check fails before anything is made
    assert 'test -n ""' in printed.stdout
    done = subprocess.run(
        [MAKE, "install"],
        cwd=tmp_path / "project",
        env={"PATH": str(tmp_path / "bin")},
        capture_output=True,
        text=True,
    )
    assert done.returncode != 0
    assert "make: no Python 3.11 or newer among python3.11 python3.12" in done.stderr
    assert not (tmp_path / "project" / ".venv").exists()
