"""The tracked tree holds source, not artefacts: no large file outside ``tests/data/`` and
no built package or archive anywhere (``git ls-files``; skipped outside a git checkout)."""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_BYTES = 1 << 20  # a larger file is data or a build artefact, not source
DATA = "tests/data/"  # reference files of the tests: the one place allowed larger files
ARCHIVES = (  # built packages and archives: made from the tree or fetched, never tracked
    ".whl",
    ".tar.gz",
    ".tgz",
    ".zip",
    ".egg",
    ".tar.bz2",
    ".tar.xz",
    ".conda",
)
GIT_SECONDS = 30  # at most this long for git ls-files


def offending(files: Iterable[tuple[str, int]]) -> list[str]:
    """``PATH (SIZE bytes)`` of each tracked file that is an archive, or larger than
    :data:`MAX_BYTES` outside :data:`DATA`; ``files`` are ``(path, size)`` pairs."""
    return [
        f"{path} ({size} bytes)"
        for path, size in files
        if path.lower().endswith(ARCHIVES) or (size > MAX_BYTES and not path.startswith(DATA))
    ]


def tracked_files() -> list[tuple[str, int]]:
    """``(path, size)`` of every file git tracks (a file deleted but not yet staged is
    left out)."""
    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    done = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "-z"],
        capture_output=True,
        timeout=GIT_SECONDS,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip("not a git checkout")
    paths = [p.decode() for p in done.stdout.split(b"\0") if p]
    return [(p, (ROOT / p).lstat().st_size) for p in paths if (ROOT / p).is_file()]


def test_no_archives_or_large_files_tracked():
    bad = offending(tracked_files())
    assert not bad, "tracked files that are archives or larger than 1 MiB:\n" + "\n".join(bad)


def test_the_check_finds_archives_and_large_files():
    files = [
        ("src/hertzsweep/core/config.py", 10_000),
        ("numpy-2.4.6-cp311-cp311-manylinux_2_28_x86_64.whl", 500),
        ("vendor/numbalsoda-0.3.4.tar.gz", 240_000),
        ("docs/figure.png", MAX_BYTES + 1),
        ("tests/data/smoke-reference.nc", 5 * MAX_BYTES),
        ("tests/data/bundle.zip", 10),
    ]
    assert offending(files) == [
        "numpy-2.4.6-cp311-cp311-manylinux_2_28_x86_64.whl (500 bytes)",
        "vendor/numbalsoda-0.3.4.tar.gz (240000 bytes)",
        f"docs/figure.png ({MAX_BYTES + 1} bytes)",
        "tests/data/bundle.zip (10 bytes)",
    ]
