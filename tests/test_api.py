"""The Python API (``import hertzsweep as hs``): each verb returns the Dataset its command
writes, bit for bit apart from ``history``; the same typed errors with the command line's
messages; no exits, no printing, no signal handlers; a lean ``import hertzsweep``.
"""

from __future__ import annotations

import contextlib
import io
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import hertzsweep as hs
from hertzsweep.errors import ConfigError, HertzsweepError

from .conftest import CONFIGS, run_cli

ROOT = Path(__file__).resolve().parents[1]
# the attributes that record how a dataset was asked for: the command line (or the Python
# call) and the time it ran
RECORDS_THE_CALL = ("history",)

SMALL = {  # the smoke scene cut to a few dwells: each kind runs in about a second
    "sweep.start": 0.97,
    "sweep.stop": 0.98,
    "sweep.step": 0.005,
    "sweep.settle_periods": 40,
    "sweep.measure_periods": 4,
    "excitation.sigma": [0.01],
    "solver.steps_per_period": 64,
}


def set_options(overrides: dict) -> list[str]:
    """``--set`` options of the same overrides (TOML values)."""

    def toml(value):
        return repr(value).replace("'", '"') if not isinstance(value, bool) else str(value).lower()

    return [item for key, value in overrides.items() for item in ("--set", f"{key}={toml(value)}")]


def same(api: xr.Dataset, path: Path, drop_vars: tuple[str, ...] = ()) -> None:
    """The API's dataset is the command's file, apart from what records the call."""
    written = hs.open_dataset(path)
    a = api.drop_vars(drop_vars, errors="ignore")
    b = written.drop_vars(drop_vars, errors="ignore")
    for ds in (a, b):
        for name in RECORDS_THE_CALL:
            ds.attrs.pop(name, None)
    xr.testing.assert_identical(a, b)
    assert list(a.attrs) == list(b.attrs)  # the same order, too


@pytest.fixture(scope="module")
def small_scene():
    return hs.load_scene(CONFIGS / "smoke.toml", overrides=SMALL)


# --------------------------------------------------------------------------- the same data
def test_sweep_is_the_commands_file(tmp_path, capsys, small_scene):
    out = tmp_path / "sweep.nc"
    code, printed, err = run_cli(
        ["sweep", CONFIGS / "smoke.toml", "-o", out, "-q", *set_options(SMALL)], capsys
    )
    assert code == 0, err
    ds = hs.sweep(small_scene)
    same(ds, out)
    assert printed == f"{hs.summary(ds)}\nwrote {out}\n"  # the table the command prints
    assert ds.attrs["history"].split(": ", 1)[1].startswith("python: hertzsweep.sweep(")


def test_trace_is_the_commands_file(tmp_path, capsys, small_scene):
    out = tmp_path / "trace.nc"
    argv = ["trace", CONFIGS / "smoke.toml", "-w", "0.975", "--periods", "4", "-o", out, "-q"]
    code, _, err = run_cli([*argv, *set_options(SMALL)], capsys)
    assert code == 0, err
    ds = hs.trace(small_scene, 0.975, periods=4)
    same(ds, out)
    assert hs.summary(ds).startswith("sigma 0.01 w 0.9750 upper: H1 ")


def test_branch_is_the_commands_file(tmp_path, capsys, small_scene):
    out = tmp_path / "branch.nc"
    code, _, err = run_cli(
        ["branch", CONFIGS / "smoke.toml", "-o", out, "-q", *set_options(SMALL)], capsys
    )
    assert code == 0, err
    ds = hs.branch(small_scene)
    same(ds, out)
    with pytest.raises(HertzsweepError, match="branch datasets have no summary"):
        hs.summary(ds)


def test_accuracy_is_the_commands_file(tmp_path, capsys, small_scene):
    # wall_time is a measurement of the machine (and the recommendation rests on it)
    out = tmp_path / "accuracy.nc"
    ladder = ["--steps", "32,64", "--settle", "20,40", "--methods", "central-difference"]
    code, _, err = run_cli(
        ["accuracy", CONFIGS / "smoke.toml", "-o", out, "-q", *ladder, *set_options(SMALL)], capsys
    )
    assert code == 0, err
    ds = hs.accuracy(small_scene, steps=[32, 64], settle=[20, 40], methods=["central-difference"])
    same(ds, out, drop_vars=("wall_time", "recommended", "pareto"))


def test_study_is_the_commands_file(tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text(
        (CONFIGS / "smoke.toml")
        .read_text()
        .replace('rig = "rig.toml"', f'rig = "{CONFIGS / "rig.toml"}"')
    )
    study = tmp_path / "study.toml"
    study.write_text(
        textwrap.dedent(
            """
            kind = "sweep"
            scene = "scene.toml"
            [sweep]
            start = 0.97
            stop = 0.98
            step = 0.005
            settle_periods = 40
            measure_periods = 4
            [solver]
            steps_per_period = 64
            [grid]
            "damping.ratio" = [0.004, 0.005]
            """
        )
    )
    out = tmp_path / "study.nc"
    code, _, err = run_cli(["study", study, "-o", out, "--workers", "1", "-q"], capsys)
    assert code == 0, err
    same(hs.study(study, workers=1), out)


def test_import_and_fit_are_the_commands_files(tmp_path, capsys):
    csv = CONFIGS / "measured" / "paper-up-jumps.csv"
    measured = tmp_path / "measured.nc"
    code, _, err = run_cli(["import", csv, "-o", measured], capsys)
    assert code == 0, err
    m = hs.import_measurements(csv)
    same(m, measured)
    scene_file = CONFIGS / "measured" / "paper-scene.toml"
    fit_file = tmp_path / "fit.nc"
    argv = ["fit", csv, "--scene", scene_file, "--free", "damping.ratio", "-o", fit_file, "-q"]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    same(hs.fit(csv, hs.load_scene(scene_file), ["damping.ratio"]), fit_file)


# --------------------------------------------------------------------------- scenes
def test_overrides_mean_what_set_means():
    a = hs.load_scene(CONFIGS / "default.toml", overrides={"excitation.sigma": [0.01]})
    b = hs.load_scene(CONFIGS / "default.toml").with_overrides({"excitation.sigma": [0.01]})
    assert a == b and a.excitation.sigma == (0.01,)
    tables = hs.load_scene(CONFIGS / "default.toml").to_dict()
    built = hs.Scene.from_dict(tables, source=a.source)
    assert built.with_overrides({"excitation.sigma": [0.01]}) == a


def test_a_scene_from_tables_finds_its_rig_file_beside_base_dir():
    tables = {"rig": "rig.toml", "excitation": {"sigma": [0.01]}}
    scene = hs.Scene.from_dict(tables, base_dir=CONFIGS)
    assert scene.rig == hs.load_scene(CONFIGS / "default.toml").rig
    assert tables == {"rig": "rig.toml", "excitation": {"sigma": [0.01]}}  # not changed
    with pytest.raises(ConfigError, match="rig file .* does not exist"):
        hs.Scene.from_dict(tables, base_dir=ROOT)


def test_an_override_is_named_as_the_command_line_names_it(tmp_path, capsys):
    with pytest.raises(ConfigError) as caught:
        hs.load_scene(CONFIGS / "default.toml", overrides={"damping.ratio": -1})
    code, _, err = run_cli(
        ["validate", CONFIGS / "default.toml", "--set", "damping.ratio=-1"], capsys
    )
    assert code == 2 and err == f"hertzsweep: error: {caught.value}\n"
    assert str(caught.value).startswith("--set: damping.ratio:")
    # a run's check (the stability limit) on an overridden key: the same, when it runs
    scene = hs.load_scene(CONFIGS / "smoke.toml").with_overrides({"solver.steps_per_period": 3})
    with pytest.raises(ConfigError) as caught:
        hs.sweep(scene)
    assert str(caught.value).startswith("--set: solver.steps_per_period: ")


def test_example_scenes():
    assert hs.example_scene("smoke").to_dict() == hs.load_scene(CONFIGS / "smoke.toml").to_dict()
    with pytest.raises(HertzsweepError, match="unknown example 'nope'"):
        hs.example_scene("nope")


def test_rig_is_what_rig_json_prints(capsys):
    import json

    code, out, _ = run_cli(["rig", CONFIGS / "default.toml", "--json"], capsys)
    assert code == 0
    printed = json.loads(out)
    constants = hs.rig(hs.load_scene(CONFIGS / "default.toml"))
    assert constants == printed
    assert hs.rig(CONFIGS / "default.toml") == printed
    # eq. 15 on the paper's rig: f0 = 230.8 Hz
    assert constants["natural_frequency"] == pytest.approx(230.776, abs=1e-3)


# --------------------------------------------------------------------------- reading, comparing
def test_compare_and_plot(tmp_path, small_scene):
    ds = hs.sweep(small_scene)
    assert hs.compare(ds, ds).ok and hs.compare(ds, ds).worst is None
    moved = ds.copy(deep=True)
    moved["amplitude"][0, 0, 1, 0] *= 1.001
    result = hs.compare(moved, ds)
    assert not result.ok
    assert result.worst["variable"] == "amplitude"
    assert result.worst["coords"]["frequency_ratio"] == pytest.approx(0.975)
    assert "amplitude" in result.text and str(result) == result.text
    path = hs.save(ds, tmp_path / "x.nc")
    assert hs.compare(path, ds).ok
    import matplotlib.figure

    fig = hs.plot(ds, "amplitude")
    assert isinstance(fig, matplotlib.figure.Figure)
    assert list(tmp_path.iterdir()) == [tmp_path / "x.nc"]  # plot wrote nothing
    with pytest.raises(HertzsweepError, match="sweep datasets have views"):
        hs.plot(ds, "nope")


# --------------------------------------------------------------------------- manners
def test_the_api_never_prints_exits_or_takes_signals(capsys, small_scene):
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    hs.sweep(small_scene)
    with pytest.raises(ConfigError):
        hs.load_scene(CONFIGS / "default.toml", overrides={"sweep.step": 0})
    out, err = capsys.readouterr()
    assert out == "" and err == ""
    assert {s: signal.getsignal(s) for s in handlers} == handlers


def test_progress_shows_the_bar_when_asked(capsys, small_scene):
    hs.sweep(small_scene, progress=True)
    out, err = capsys.readouterr()
    assert out == "" and "sweep:" in err and "/6 dwells" in err


def test_import_hertzsweep_loads_nothing_heavy():
    heavy = ("numpy", "xarray", "numba", "matplotlib", "click")
    code = (
        f"import sys, hertzsweep; print(sorted(m for m in {heavy} if m in sys.modules)); "
        "print(len(hertzsweep.__all__))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    heavy, count = done.stdout.split("\n")[:2]
    assert heavy == "[]"
    assert int(count) == len(hs.__all__)


def test_every_public_name_resolves_and_is_documented():
    for name in hs.__all__:
        value = getattr(hs, name)
        assert value is not None
        if callable(value):
            assert (value.__doc__ or "").strip(), f"{name} has no docstring"
    with pytest.raises(AttributeError):
        hs.not_a_name  # noqa: B018


def test_ctrl_c_raises_keyboard_interrupt_within_a_second(tmp_path):
    # a sweep of many long dwells; SIGINT as Jupyter's interrupt sends it, no handler of
    # ours installed: KeyboardInterrupt (Interrupted) once the compiled call in flight
    # returns, with the finished dwells
    script = textwrap.dedent(
        f"""
        import sys, time
        import hertzsweep as hs
        scene = hs.load_scene({str(CONFIGS / "smoke.toml")!r}, overrides={{
            "sweep.step": 0.0001, "sweep.settle_periods": 2000, "excitation.sigma": [0.01],
            "solver.steps_per_period": 2048}})
        hs.sweep(hs.load_scene({str(CONFIGS / "smoke.toml")!r}, overrides={SMALL!r}))
        print("running", flush=True)
        try:
            hs.sweep(scene)
        except KeyboardInterrupt as exc:
            seen = time.monotonic()
            print("interrupted", type(exc).__name__, exc.partial is not None, seen, flush=True)
        """
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert proc.stdout.readline().strip() == "running"
    time.sleep(1.0)
    asked = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    words = out.split()
    assert words[:3] == ["interrupted", "Interrupted", "True"], out + err
    # the bound: a dwell here is 2010 periods of 2048 steps, 4e6 steps (tens of ms)
    assert float(words[3]) - asked < 1.0


# --------------------------------------------------------------------------- bad inputs
def test_bad_inputs_raise_the_command_lines_errors(tmp_path):
    """Every class of the bad-input table (tests/test_bad_inputs.py) that the API can be
    given: the same typed error, the same message as the command's one line."""
    from .test_bad_inputs import CASES, make_special, run_in_process

    compared, by_group = 0, {}
    failures = []
    for case in CASES:
        if case.argv[0] not in API_COMMANDS:
            continue
        if case.idle or case.fresh or case.group == "outputs":
            continue  # a network's wait, a process of its own, the command's own output
        folder = tmp_path / case.id.replace("/", "_")
        folder.mkdir()
        for name, content in case.files.items():
            (folder / name).write_bytes(content if isinstance(content, bytes) else content.encode())
        for kind, name in case.special:  # FIFOs, devices, links, a sparse giant: never read
            make_special(folder, kind, name)
        argv = [a.replace("{dir}", str(folder)) if isinstance(a, str) else a for a in case.argv]
        here = os.getcwd()
        try:  # parsed where it runs: click checks its paths (a directory) against the folder
            os.chdir(folder)
            call = api_call(argv)
        finally:
            os.chdir(here)
        if call is None:
            continue  # the command line's own syntax: no API counterpart
        status, err, _ = run_in_process(argv, folder)
        line = err.strip().splitlines()[0] if err.strip() else b""  # bytes: a name may not
        if line.startswith(b"hertzsweep: error: -o:"):
            continue  # the command's output file: the API writes none
        message = api_message(call, folder)  # be UTF-8 (surrogate escapes)
        if status == 2 and line != b"hertzsweep: error: " + message.encode(
            errors="surrogateescape"
        ):
            failures.append(f"{case.id}: command: {line!r}\n    api: {message!r}")
        compared += 1
        by_group[case.group] = by_group.get(case.group, 0) + 1
    assert not failures, "\n".join(failures)
    # every class but the outputs' (the API writes no file) and the scheduler's network
    # cases is compared
    assert set(by_group) >= {"values", "keys", "set", "files", "absurd", "commands"}, by_group
    assert compared > 300, by_group


IMPORT_OPTIONS = ("preset", "rms", "phase_convention", "phase_unit", "sensitivity", "static_load",
                  "sigma", "force_amplitude", "direction", "moving_mass")  # fmt: skip
API_COMMANDS = {
    "export",
    "validate",
    "rig",
    "sweep",
    "trace",
    "branch",
    "accuracy",
    "import",
    "fit",
    "compare",
    "plot",
    "study",
}


def api_call(argv):
    """The API call of a command line, from the command's own parsed options; None when
    the command line itself is at fault (click's usage errors, an output refused)."""
    import click

    from hertzsweep.api.runs import parse_overrides, parse_variable_tolerances
    from hertzsweep.cli.group import cli
    from hertzsweep.cli.importing import parse_columns

    name, *args = [os.fsdecode(a) for a in argv]
    if name not in API_COMMANDS:
        return None
    command = cli.get_command(None, name)
    try:
        ctx = command.make_context(name, list(args))
    except (click.ClickException, HertzsweepError, OSError):
        return None
    p = ctx.params
    if p.get("map_file"):
        return None  # --map is the command line's file of options

    def scene():
        return hs.load_scene(p["scene_file"], overrides=parse_overrides(p["overrides"]))

    calls = {
        "validate": lambda: scene(),
        "rig": lambda: hs.rig(p["file"]),
        "sweep": lambda: hs.sweep(scene()),
        "trace": lambda: hs.trace(
            scene(),
            p["frequency_ratio"],
            periods=p["periods"],
            branch=p["branch"],
            samples_per_period=p["samples_per_period"],
        ),
        "branch": lambda: hs.branch(scene()),
        "accuracy": lambda: hs.accuracy(
            scene(),
            p["target"],
            steps=p["steps_text"],
            settle=p["settle_text"],
            methods=p["methods_text"],
            quick=p["quick"],
        ),
        "import": lambda: hs.import_measurements(
            p["measured_file"],
            columns=parse_columns(p["columns_text"]),
            **{k: p[k] for k in IMPORT_OPTIONS},
            rig=p["rig_file"],
        ),
        "export": lambda: hs.export(
            p["input_file"],
            p["output"],
            p["file_format"],
            sensitivity=p["sensitivity"],
            static_load=p["static_load"],
        ),
        "fit": lambda: hs.fit(
            p["measured_file"],
            scene(),
            p["free_text"].split(","),
            method=p["method"],
            compare_laws=p["compare_laws"],
        ),
        "compare": lambda: hs.compare(
            p["run_file"],
            p["reference_file"],
            p["rtol"],
            p["atol"],
            parse_variable_tolerances(p["var_tolerances"]),
        ),
        "plot": lambda: hs.plot(
            p["input_file"],
            p["view"],
            harmonics=p["harmonics"],
            sigmas=p["sigmas"],
            overlay=p["overlay"],
            wrap_phase=p["wrap_phase"],
        ),
        "study": lambda: hs.study(p["study_file"], p["workers"], p["scheduler"]),
    }
    return calls[name]


def api_message(call, folder: Path) -> str:
    """What the API raised, as the command line prints it (an OSError as ``FILE: reason``);
    "" when it raised nothing."""
    here = os.getcwd()
    out = io.StringIO()
    try:
        os.chdir(folder)
        with contextlib.redirect_stdout(out):
            call()
    except HertzsweepError as exc:
        return str(exc)
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        return f"{where}{exc.strerror or exc}"
    finally:
        os.chdir(here)
        assert out.getvalue() == ""  # the API printed nothing
    return ""


def test_the_parity_check_can_fail(tmp_path):
    # an API message that differs from the command's is reported
    call = api_call(["validate", str(CONFIGS / "default.toml"), "--set", "damping.ratio=-1"])
    assert api_message(call, tmp_path).startswith("--set: damping.ratio:")
    assert api_message(lambda: None, tmp_path) == ""
    np.testing.assert_equal(api_call(["bogus"]), None)
