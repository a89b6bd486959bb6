"""Shared fixtures: the paper's rig and small scenes built from it."""

from __future__ import annotations

from pathlib import Path

import pytest

from hertzsweep.core.config import load_scene, scene_from_dict

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"
DATA = Path(__file__).resolve().parent / "data"

PAPER_RIG = {
    "geometry": "double-sphere-plane",
    "ball_radius": 12.7e-3,
    "youngs_modulus": 210e9,
    "poisson_ratio": 0.29,
    "mass": 11.4,
    "static_load": 110.0,
}


def make_scene(**tables):
    """A scene on the paper's rig; keyword tables override the defaults."""
    raw = {"rig": dict(PAPER_RIG)}
    for name, table in tables.items():
        raw[name] = dict(table)
    return scene_from_dict(raw, source="<test>")


@pytest.fixture
def default_scene():
    return load_scene(CONFIGS / "default.toml")


def run_cli(argv, capsys):
    """Run ``hertzsweep ARGV`` in-process; returns (exit status, stdout, stderr)."""
    from hertzsweep.cli import main

    try:
        main([str(a) for a in argv])
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    out, err = capsys.readouterr()
    return code, out, err


def run_on_a_small_disk(tmp_path, argv, size):
    """Run ``argv`` in ``tmp_path`` with a tmpfs of ``size`` mounted on ``tmp_path/full``
    in a private mount namespace (root, unshare); skips where that is not allowed.
    Returns ``(stdout, stderr)``: stdout ends with ``status=N`` and what ``full`` holds."""
    import os
    import shutil
    import subprocess

    if os.geteuid() != 0 or shutil.which("unshare") is None:
        pytest.skip("needs root and unshare to mount a small tmpfs")
    (tmp_path / "full").mkdir()
    script = (
        f"mount -t tmpfs -o size={size} tmpfs full || exit 99; "
        f'{subprocess.list2cmdline(argv)}; echo "status=$?"; ls -A full'
    )
    done = subprocess.run(
        ["unshare", "--mount", "sh", "-c", script],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    if done.returncode == 99 or "status=" not in done.stdout:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    return done.stdout, done.stderr
