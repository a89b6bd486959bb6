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
