"""Configuration: defaults, overrides, and every kind of bad input (exit 2, one line)."""

import json
import textwrap

import pytest

from hertzsweep.core.config import load_scene, parse_override

from .conftest import CONFIGS, run_cli

RIG = """
[rig]
ball_radius = 12.7e-3
youngs_modulus = 210e9
poisson_ratio = 0.29
mass = 11.4
"""


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_defaults_are_the_spec(tmp_path):
    scene = load_scene(write(tmp_path, RIG))
    assert scene.damping.ratio == 0.0045 and scene.damping.law == "viscous"
    assert scene.damping.exponent == 1.5
    assert scene.excitation.sigma == (0.006, 0.01)
    assert (scene.sweep.start, scene.sweep.stop, scene.sweep.step) == (0.90, 1.05, 0.0025)
    assert scene.sweep.frequency_ratios.size == 61
    assert scene.sweep.frequency_ratios[-1] == 1.05
    assert scene.sweep.directions == ("up", "down")
    assert (scene.sweep.settle_periods, scene.sweep.measure_periods) == (300, 20)
    assert scene.solver.steps_per_period == 256 and scene.lockin.harmonics == (1, 2)
    assert scene.rig.static_load == pytest.approx(11.4 * 9.81)


def test_overrides_and_rig_file():
    scene = load_scene(
        CONFIGS / "default.toml",
        ["damping.law=contact", "excitation.sigma=0.02", "sweep.settle_periods='auto'",
         "rig.mass=5.0"],
    )  # fmt: skip
    assert scene.damping.law == "contact"
    assert scene.excitation.sigma == (0.02,)
    assert scene.sweep.settle_periods is None
    assert scene.rig.mass == 5.0 and scene.rig.static_load == 110.0
    assert parse_override("sweep.directions=['down']") == ("sweep.directions", ["down"])


BAD = [
    ("[damping]\nratio = 0.01\nratoi = 2\n", "damping.ratoi", "unknown key"),
    ("[dampng]\nratio = 0.01\n", "dampng", "unknown table"),
    ("[damping]\nratio = 'high'\n", "damping.ratio", "expected a number"),
    ("[damping]\nlaw = 'coulomb'\n", "damping.law", "expected one of"),
    ("[sweep]\nstart = 1.0\nstop = 0.9\n", "sweep.stop", "reversed"),
    ("[sweep]\nstep = 0\n", "sweep.step", "positive"),
    ("[sweep]\nsettle_periods = 'soon'\n", "sweep.settle_periods", "auto"),
    ("[sweep]\nmeasure_periods = 2.5\n", "sweep.measure_periods", "whole number"),
    ("[sweep]\ndirections = []\n", "sweep.directions", "expected"),
    ("[excitation]\nsigma = []\n", "excitation.sigma", "non-empty"),
    ("[excitation]\nsigma = [0.01, -0.02]\n", "excitation.sigma", "positive"),
    ("[solver]\nsteps_per_period = 3\n", "solver.steps_per_period", "stability limit"),
    ("[lockin]\nharmonics = [0]\n", "lockin.harmonics", "orders > 0"),
    ("[lockin]\nharmonics = [0.2, 1]\n", "lockin.harmonics", "multiples of 1/2, 1/3, 1/4"),
    ("[lockin]\nharmonics = [0.5, 1, 0.5]\n", "lockin.harmonics", "distinct"),
    ("[solver]\nmax_steps = 0\n", "solver.max_steps", "at least 1"),
    ("[lockin]\nharmonics = [1, 128]\n", "lockin.harmonics", "Nyquist"),
    ("[sweep]\nstep = 1e-7\n", "sweep.step", "more than 100000"),
]


def test_fractional_orders_are_stored_as_their_fractions(tmp_path):
    # Whole orders stay ints (the datasets' config of a scene of whole orders is as
    # before); the others are the float of their fraction, within 1e-9: 0.3333333333 is
    # 1/3 to the last bit, and the common denominator L is the lcm of the denominators
    text = "[lockin]\nharmonics = [2, 0.3333333333, 1.5, 0.25, 1.0]\n"
    lockin = load_scene(write(tmp_path, RIG + text)).lockin
    assert lockin.harmonics == (0.25, 1 / 3.0, 1, 1.5, 2)
    assert [type(k) for k in lockin.harmonics] == [float, float, int, float, int]
    assert lockin.denominator == 12
    halves = load_scene(CONFIGS / "default.toml", ["lockin.harmonics=[2, 1.5, 1, 0.5]"]).lockin
    assert halves.harmonics == (0.5, 1, 1.5, 2) and halves.denominator == 2
    assert load_scene(CONFIGS / "default.toml").lockin.denominator == 1


@pytest.mark.parametrize("tables, key, reason", BAD)
def test_bad_scene_values(tmp_path, capsys, tables, key, reason):
    path = write(tmp_path, RIG + tables)
    code, out, err = run_cli(["validate", path], capsys)
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert str(path) in err and key in err and reason in err


@pytest.mark.parametrize(
    "field, value, reason",
    [("mass", "0", "positive"), ("mass", "-1.0", "positive"), ("ball_radius", "0.0", "positive"),
     ("poisson_ratio", "0.5", "(-1, 0.5)"), ("poisson_ratio", "-1.0", "(-1, 0.5)"),
     ("youngs_modulus", "'steel'", "number")],
)  # fmt: skip
def test_bad_rig_values(tmp_path, capsys, field, value, reason):
    text = RIG.replace(f"\n{field} = ", f"\n{field} = {value}\n#")
    code, _, err = run_cli(["validate", write(tmp_path, text)], capsys)
    assert code == 2 and err.count("\n") == 1
    assert f"rig.{field}" in err and reason in err


def test_missing_rig_key(tmp_path, capsys):
    code, _, err = run_cli(["validate", write(tmp_path, RIG.replace("mass = 11.4", ""))], capsys)
    assert code == 2 and "rig.mass" in err and "missing" in err


def test_missing_rig_file(tmp_path, capsys):
    path = write(tmp_path, 'rig = "nowhere.toml"\n')
    code, _, err = run_cli(["validate", path], capsys)
    assert code == 2 and err.count("\n") == 1
    assert "rig" in err and "nowhere.toml" in err and "does not exist" in err


def test_missing_scene_and_bad_toml(tmp_path, capsys):
    code, _, err = run_cli(["validate", tmp_path / "absent.toml"], capsys)
    assert code == 2 and "no such file" in err and err.count("\n") == 1
    code, _, err = run_cli(["validate", write(tmp_path, "[rig\n")], capsys)
    assert code == 2 and "not valid TOML" in err and err.count("\n") == 1


def test_bad_override(capsys):
    code, _, err = run_cli(["validate", CONFIGS / "default.toml", "--set", "nodot=3"], capsys)
    assert code == 2 and "table.key=value" in err and err.count("\n") == 1
    code, _, err = run_cli(
        ["validate", CONFIGS / "default.toml", "--set", "damping.ratio=-1"], capsys
    )
    # the bad value is the command line's, not the file's
    assert code == 2 and err.count("\n") == 1
    assert "--set: damping.ratio: must be >= 0" in err and "default.toml" not in err


def test_click_usage_error_is_one_line(capsys):
    code, _, err = run_cli(["sweep", CONFIGS / "default.toml"], capsys)  # no -o
    assert code == 2 and err.count("\n") == 1 and "--output" in err


def test_validate_ok_shows_margin(capsys):
    code, out, _ = run_cli(["validate", CONFIGS / "default.toml"], capsys)
    assert code == 0 and "ok" in out
    # pi * (1 + 0.01 / 0.009)^(1/6) / 0.9 = 3.95 steps; 256 / 3.95 = 64.8
    assert "64.8x the stability limit 4.0" in out


def test_rig_command_json(capsys):
    code, out, _ = run_cli(["rig", CONFIGS / "rig.toml", "--json"], capsys)
    assert code == 0
    values = json.loads(out)
    assert values["contact_stiffness"] == pytest.approx(6.09e9, rel=1e-3)
    assert values["natural_frequency"] == pytest.approx(230.8, abs=0.05)
    code, out, _ = run_cli(["rig", CONFIGS / "default.toml", "--json"], capsys)
    assert json.loads(out)["stability_margin"] == pytest.approx(64.8, abs=0.05)
