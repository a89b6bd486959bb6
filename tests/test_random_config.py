"""A random scene (``excitation.kind = "random"``): its keys, the ``[random]`` table, their
checks and the preflight of its run; a sine scene's attributes and tables are those it had
before random excitation existed."""

from __future__ import annotations

import math
import textwrap

import pytest

from hertzsweep.core import checks
from hertzsweep.core.config import (
    QUIET_DEFAULTS,
    ExcitationConfig,
    RandomConfig,
    Scene,
    load_scene,
    scene_from_dict,
)
from hertzsweep.errors import ConfigError

from .conftest import CONFIGS, PAPER_RIG, make_scene, run_cli

RANDOM_SCENE = """
[rig]
ball_radius = 12.7e-3
youngs_modulus = 210e9
poisson_ratio = 0.29
mass = 11.4
static_load = 110.0

[damping]
ratio = 0.0045

[excitation]
kind = "random"
rms = [0.005, 0.01, 0.05]
band = [0.1, 4.0]
seed = 3

[random]
realisations = 8
duration_periods = 500
transient_periods = 50
segment_periods = 32
force_bins = 64
trace_periods = 10
"""
# A sine scene's attribute names before random excitation (configs/default.toml's rig)
SINE_ATTRIBUTES = {
    "ball_radius", "youngs_modulus", "poisson_ratio", "mass", "static_load", "ball_mass",
    "ball_density", "natural_frequency", "damping_ratio", "damping_law", "damping_exponent",
    "excitation_sigma", "sweep_start", "sweep_stop", "sweep_step", "sweep_directions",
    "sweep_settle_periods", "sweep_measure_periods", "sweep_tolerance",
    "sweep_max_settle_periods", "sweep_jump_threshold", "sweep_steady_state", "solver_method",
    "steps_per_period", "lockin_harmonics", "model_kind", "rig_geometry",
}  # fmt: skip
SINE_TABLES = {"rig", "damping", "excitation", "sweep", "solver", "lockin", "model"}
RANDOM_ATTRIBUTES = {"excitation_kind", "excitation_rms", "excitation_band", "excitation_seed"}
RANDOM_ATTRIBUTES |= {  # but those left out at their default (first_realisation)
    f"random_{key}"
    for key in RandomConfig.__dataclass_fields__
    if ("random", key) not in QUIET_DEFAULTS
}


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def random_scene(excitation=None, random=None, **tables) -> Scene:
    """A random scene on the paper's rig (levels 0.01), with changes to its tables."""
    return make_scene(
        excitation={"kind": "random", "rms": [0.01], **(excitation or {})},
        random=random or {},
        **tables,
    )


# --------------------------------------------------------------------------- loading
def test_a_random_scene_loads(tmp_path):
    scene = load_scene(write(tmp_path, RANDOM_SCENE))
    assert scene.is_random
    excitation = scene.excitation
    assert (excitation.kind, excitation.rms, excitation.band, excitation.seed) == (
        "random", (0.005, 0.01, 0.05), (0.1, 4.0), 3,
    )  # fmt: skip
    assert scene.random == RandomConfig(8, 500, 50, 32, 64, 10)
    assert scene.excitation.sigma == ExcitationConfig().sigma  # kept, not used


def test_the_defaults():
    assert ExcitationConfig() == ExcitationConfig(
        sigma=(0.006, 0.01), kind="sine", rms=(), band=(0.2, 3.0), seed=0
    )
    assert RandomConfig() == RandomConfig(
        realisations=16,
        duration_periods=2000,
        transient_periods=200,
        segment_periods=64,
        force_bins=200,
        trace_periods=0,
    )
    scene = random_scene()
    assert scene.random == RandomConfig() and scene.excitation.band == (0.2, 3.0)
    assert load_scene(CONFIGS / "default.toml").excitation.kind == "sine"


def test_rms_takes_a_number_and_whole_floats_are_whole():
    scene = random_scene({"rms": 0.02, "seed": 4.0}, {"realisations": 2.0})
    assert scene.excitation.rms == (0.02,) and scene.excitation.seed == 4
    assert scene.random.realisations == 2 and isinstance(scene.random.realisations, int)


DROP = object()  # as a value: the key left out

BAD = [  # (excitation changes, [random] changes, other tables, key, reason)
    ({"kind": "noise"}, {}, {}, "excitation.kind", "expected one of 'sine', 'random'"),
    ({"kind": 1}, {}, {}, "excitation.kind", "expected one of"),
    ({"rms": []}, {}, {}, "excitation.rms", "non-empty list"),
    ({"rms": DROP}, {}, {}, "excitation.rms", "needs its levels"),
    ({"rms": [0.01, 0.0]}, {}, {}, "excitation.rms", "must be positive"),
    ({"rms": [-0.01]}, {}, {}, "excitation.rms", "must be positive"),
    ({"rms": [math.nan]}, {}, {}, "excitation.rms", "finite"),
    ({"rms": [math.inf]}, {}, {}, "excitation.rms", "finite"),
    ({"rms": ["0.01"]}, {}, {}, "excitation.rms", "expected a number"),
    ({"rms": [0.01, 0.01]}, {}, {}, "excitation.rms", "distinct"),
    ({"band": [0.2]}, {}, {}, "excitation.band", "expected two numbers"),
    ({"band": [0.2, 1.0, 3.0]}, {}, {}, "excitation.band", "expected two numbers"),
    ({"band": 3.0}, {}, {}, "excitation.band", "expected two numbers"),
    ({"band": [3.0, 0.2]}, {}, {}, "excitation.band", "0 < w_low < w_high"),
    ({"band": [1.0, 1.0]}, {}, {}, "excitation.band", "0 < w_low < w_high"),
    ({"band": [0.0, 3.0]}, {}, {}, "excitation.band", "0 < w_low < w_high"),
    ({"band": [-1.0, 3.0]}, {}, {}, "excitation.band", "0 < w_low < w_high"),
    ({"band": [0.2, math.inf]}, {}, {}, "excitation.band", "finite"),
    ({"band": ["a", 1.0]}, {}, {}, "excitation.band", "expected a number"),
    ({"seed": -1}, {}, {}, "excitation.seed", "must be >= 0"),
    ({"seed": 1.5}, {}, {}, "excitation.seed", "whole number"),
    ({"seed": True}, {}, {}, "excitation.seed", "whole number"),
    ({}, {"realisations": 0}, {}, "random.realisations", "at least 1"),
    ({}, {"realisations": 2.5}, {}, "random.realisations", "whole number"),
    ({}, {"duration_periods": 0}, {}, "random.duration_periods", "at least 1"),
    ({}, {"duration_periods": "long"}, {}, "random.duration_periods", "whole number"),
    ({}, {"segment_periods": 0}, {}, "random.segment_periods", "at least 1"),
    ({}, {"segment_periods": 64.5}, {}, "random.segment_periods", "whole number"),
    ({}, {"transient_periods": -1}, {}, "random.transient_periods", "must be >= 0"),
    ({}, {"transient_periods": 2001}, {}, "random.transient_periods", "longer than"),
    ({}, {"segment_periods": 2001}, {}, "random.segment_periods", "longer than"),
    ({}, {"force_bins": 1}, {}, "random.force_bins", "at least 2"),
    ({}, {"force_bins": 10.5}, {}, "random.force_bins", "whole number"),
    ({}, {"trace_periods": -1}, {}, "random.trace_periods", "must be >= 0"),
    ({}, {"trace_periods": 2001}, {}, "random.trace_periods", "longer than"),
    ({}, {"bogus": 1}, {}, "random.bogus", "unknown key"),
    # the ball model integrates with the central difference, random or not
    ({}, {}, {"model": {"kind": "ball"}, "solver": {"method": "rk4"}}, "model.kind", "'ball'"),
]


@pytest.mark.parametrize(
    ("excitation", "random", "tables", "key", "reason"),
    BAD,
    ids=[f"{case[3]}:{i}" for i, case in enumerate(BAD)],
)
def test_every_bad_value_names_its_key(excitation, random, tables, key, reason):
    given = {"kind": "random", "rms": [0.01], **excitation}
    raw = {"rig": dict(PAPER_RIG), "excitation": {k: v for k, v in given.items() if v is not DROP}}
    raw.update({"random": random, **tables})
    with pytest.raises(ConfigError) as caught:
        scene_from_dict(raw, source="s.toml")
    assert (caught.value.source, caught.value.key) == ("s.toml", key)
    assert reason in caught.value.reason, caught.value.reason


def test_a_bad_random_value_on_the_command_line_is_one_line(tmp_path, capsys):
    path = write(tmp_path, RANDOM_SCENE)
    code, _, err = run_cli(["validate", path, "--set", "random.transient_periods=600"], capsys)
    assert code == 2 and err.count("\n") == 1, err
    assert err.startswith("hertzsweep: error: --set: random.transient_periods: ")


def test_a_sine_scene_checks_its_random_table_too():
    # the [random] table is a table of the scene, valid or not whatever the kind
    with pytest.raises(ConfigError, match="random.force_bins"):
        make_scene(random={"force_bins": 1})
    # but a sine scene needs no levels, and may run rk4 and the ball model
    make_scene(solver={"method": "rk4"})
    make_scene(model={"kind": "ball"})


@pytest.mark.parametrize(
    "tables",
    [{"solver": {"method": "rk4"}}, {"model": {"kind": "ball"}}],
    ids=["rk4", "ball"],
)
def test_a_random_scene_runs_rk4_and_the_ball_model(tables):
    # both are accepted (refused before their random kernels existed), and kept
    scene = random_scene(**tables)
    assert scene.is_random
    assert (scene.solver.method, scene.model.kind) == (
        tables.get("solver", {}).get("method", "central-difference"),
        tables.get("model", {}).get("kind", "single"),
    )
    assert checks.preflight(scene).stability_margin > 1.0  # validate's preflight too


# --------------------------------------------------------------------------- the datasets
def test_a_sine_scenes_attributes_and_tables_are_unchanged(tmp_path):
    scene = load_scene(CONFIGS / "default.toml")
    assert set(scene.attributes()) == SINE_ATTRIBUTES
    tables = scene.to_dict()
    assert set(tables) == SINE_TABLES and tables["excitation"] == {"sigma": [0.006, 0.01]}
    # random keys given to a sine scene change neither
    extra = scene.with_overrides(
        {"excitation.rms": [0.02], "excitation.seed": 5, "random.realisations": 3}
    )
    assert extra.attributes() == scene.attributes() and extra.to_dict() == scene.to_dict()
    # and its tables read back into an equal scene, as before
    assert scene_from_dict(tables, source=scene.source) == scene


def test_a_random_scene_has_every_table(tmp_path):
    scene = load_scene(write(tmp_path, RANDOM_SCENE))
    attributes = scene.attributes()
    assert set(attributes) == SINE_ATTRIBUTES | RANDOM_ATTRIBUTES
    assert attributes["excitation_rms"] == [0.005, 0.01, 0.05]
    assert attributes["excitation_band"] == [0.1, 4.0]
    assert (attributes["excitation_kind"], attributes["excitation_seed"]) == ("random", 3)
    assert attributes["random_realisations"] == 8 and attributes["random_trace_periods"] == 10
    tables = scene.to_dict()
    assert set(tables) == SINE_TABLES | {"random"}
    assert tables["random"]["segment_periods"] == 32
    assert scene_from_dict(tables, source=scene.source) == scene


def test_overrides_keep_a_sine_scenes_random_keys():
    # a sine scene's random keys are left out of its tables, not lost: setting the kind
    # makes the random scene they describe
    sine = make_scene(excitation={"rms": [0.03], "band": [0.5, 2.0]}, random={"realisations": 4})
    scene = sine.with_overrides({"excitation.kind": "random"})
    assert scene.is_random and scene.excitation.rms == (0.03,)
    assert scene.excitation.band == (0.5, 2.0) and scene.random.realisations == 4


# --------------------------------------------------------------------------- preflight
def test_the_preflight_of_a_random_scene(tmp_path):
    scene = load_scene(write(tmp_path, RANDOM_SCENE))
    figures = checks.preflight(scene)
    assert figures.points == 1
    assert figures.trajectories == 3 * 8  # levels x realisations
    assert figures.periods_per_dwell == 550  # transient + duration
    assert figures.steps == 3 * 8 * 550 * 256
    assert figures.max_steps == checks.DEFAULT_MAX_STEPS
    assert figures.memory == checks.random_bytes(scene) and figures.memory < 2**30
    # the linear response's RMS at the largest level: 0.05 sqrt(pi / (4 zeta 3.9)) = 0.336
    # at most (the whole axis' integral), so the force is estimated at 1 + 10 x 0.336 and
    # the limit 2 pi (4.36)^(1/6) / 2 = 4.04 steps a period (h omega_max < 2)
    force = 1.0 + 10.0 * 0.05 * math.sqrt(math.pi * (1 + 4 * 0.0045**2) / (4 * 0.0045 * 3.9))
    assert checks.random_force_bound(scene) == pytest.approx(force, rel=1e-12)
    limit = 2.0 * math.pi * force ** (1.0 / 6.0) / 2.0
    assert figures.stability_limit == pytest.approx(limit, rel=1e-12)
    assert figures.stability_margin == pytest.approx(256 / limit, rel=1e-12)


def test_the_paper_scene_fits_its_budgets():
    # five levels x 16 realisations x 2,200 periods of 256 steps: 4.5e7 steps; the forcing
    # (16 records of 563,200 floats and one being made) is 85 MB of the whole
    scene = random_scene({"rms": [0.002, 0.005, 0.01, 0.02, 0.05]})
    figures = checks.preflight(scene)
    assert figures.steps == 5 * 16 * 2200 * 256
    assert 19 * 2200 * 256 * 8 < figures.memory < 256 * 2**20


PREFLIGHT_BAD = [  # (excitation, random, tables, key, reason)
    ({"band": [0.2, 128.0]}, {}, {}, "excitation.band", "Nyquist"),
    ({"band": [0.2, 8.0]}, {}, {"solver": {"steps_per_period": 16}}, "excitation.band", "Nyquist"),
    (
        {"band": [1.001, 1.0015]},
        {"duration_periods": 100, "transient_periods": 0, "segment_periods": 10},
        {},
        "excitation.band",
        "holds no line",
    ),
    ({"rms": [1.0]}, {}, {"solver": {"steps_per_period": 4}}, "excitation.band", "Nyquist"),
    (
        {"rms": [1.0], "band": [0.2, 1.5]},
        {},
        {"solver": {"steps_per_period": 4}},
        "solver.steps_per_period",
        "stability limit",
    ),
    ({"rms": [1e300]}, {}, {}, "excitation.rms", "stability limit"),
    ({}, {"realisations": 10**6}, {}, "random.realisations", "integration steps"),
    ({}, {"duration_periods": 10**9}, {}, "random.duration_periods", "integration steps"),
    ({}, {"realisations": 1000}, {"solver": {"max_steps": 10**15}}, "random.realisations", "GiB"),
    (
        {},
        {"segment_periods": 2000, "realisations": 100},
        {},
        "random.segment_periods",
        "Welch segments",
    ),
    (  # 60 levels' traces of 2000 periods of 256 samples x 4 columns, held 3 times
        {"rms": [0.001 * (i + 1) for i in range(60)]},
        {"trace_periods": 2000, "realisations": 1},
        {},
        "random.trace_periods",
        "the trace",
    ),
    ({}, {}, {"solver": {"steps_per_period": 2**21}}, "solver.steps_per_period", "2**20"),
]


@pytest.mark.parametrize(
    ("excitation", "random", "tables", "key", "reason"),
    PREFLIGHT_BAD,
    ids=[f"{case[3]}:{i}" for i, case in enumerate(PREFLIGHT_BAD)],
)
def test_the_preflight_refuses_naming_the_key(excitation, random, tables, key, reason):
    scene = random_scene(excitation, random, **tables)
    with pytest.raises(ConfigError) as caught:
        checks.preflight(scene)
    assert caught.value.key == key, caught.value
    assert reason in caught.value.reason, caught.value.reason


def test_the_sweeps_grid_and_harmonics_do_not_bind_a_random_scene():
    # a grid of 1e6 points or a harmonic above the Nyquist order refuse a sine scene only
    sweep = {"start": 0.1, "stop": 10.0, "step": 1e-6}
    checks.preflight(random_scene(sweep=sweep, lockin={"harmonics": [200]}))
    with pytest.raises(ConfigError, match="sweep.step"):
        checks.preflight(make_scene(sweep=sweep))


def test_validate_accepts_a_random_scene(tmp_path, capsys):
    code, out, err = run_cli(["validate", write(tmp_path, RANDOM_SCENE)], capsys)
    assert (code, err) == (0, ""), err
    assert "24 trajectories of 50 + 500 periods" in out
