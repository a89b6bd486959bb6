"""Inputs and preflight: every error a user can cause ends in one line, exit 2.

Each test runs the command line in-process and asserts the exit status 2, exactly one
line on stderr that names the file (or ``--set``) and the key, and no traceback. The
reasons are asserted too: most guards have a later fallback that would also exit 2
(a FIFO's bytes are not TOML, a huge grid would also break the step budget), and only
the reason tells which guard spoke.
"""

from __future__ import annotations

import os
import socket
import stat
import threading
import time

import pytest

from hertzsweep.core import checks
from hertzsweep.core.config import MAX_INPUT_BYTES, load_scene
from hertzsweep.output.dataset import open_dataset

from .conftest import CONFIGS, run_cli

DEFAULT = CONFIGS / "default.toml"
RIG = CONFIGS / "rig.toml"
RIG_TABLE = """[rig]
ball_radius = 12.7e-3
youngs_modulus = 210e9
poisson_ratio = 0.29
mass = 11.4
"""


def one_line(code: int, err: str, where: str, key: str = "") -> str:
    """Exit 2, one line on stderr, ``hertzsweep: error: WHERE: KEY: ``, no traceback;
    returns the reason (what follows)."""
    assert code == 2, err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err
    prefix = f"hertzsweep: error: {where}: " + (f"{key}: " if key else "")
    assert err.startswith(prefix), err
    return err[len(prefix) :]


def scene_file(tmp_path, text: str = "", name: str = "scene.toml", rig: str | None = None):
    """A scene on the shipped rig file (or ``rig``, a file name) with extra TOML."""
    path = tmp_path / name
    path.write_text(f'rig = "{rig or RIG}"\n{text}')
    return path


def validate(path, capsys, *overrides):
    argv = ["validate", path]
    for text in overrides:
        argv += ["--set", text]
    return run_cli(argv, capsys)


# --------------------------------------------------------------------------- input files
@pytest.mark.parametrize("role", ["scene", "rig", "study"])
def test_non_utf8_file(tmp_path, capsys, role):
    # 0xff never occurs in UTF-8: the decoder stops at it, and the file is named
    rig = tmp_path / "rig.toml"
    rig.write_text(RIG_TABLE)
    bad = tmp_path / f"{role}-bad.toml"
    text = {"scene": 'rig = "rig.toml"\n', "rig": RIG_TABLE, "study": 'scene = "ok.toml"\n'}
    bad.write_bytes(text[role].encode() + b"# caf\xff\n")
    scene_file(tmp_path, name="ok.toml", rig="rig.toml")
    if role == "scene":
        code, _, err = validate(bad, capsys)
    elif role == "rig":
        code, _, err = validate(scene_file(tmp_path, rig=bad.name), capsys)
    else:
        code, _, err = run_cli(["study", bad, "-o", tmp_path / "out.nc", "-q"], capsys)
    reason = one_line(code, err, str(bad))
    assert reason.startswith("not UTF-8 text (byte 0xff")


@pytest.mark.parametrize("role", ["scene", "rig"])
def test_nul_bytes_are_binary(tmp_path, capsys, role):
    # NUL is valid UTF-8 but never in a TOML file: a binary file is named as one
    garbage = bytes(range(0, 256, 7)) * 4  # starts with NUL; includes non-UTF-8 bytes
    bad = tmp_path / "bad.toml"
    bad.write_bytes(garbage)
    path = bad if role == "scene" else scene_file(tmp_path, rig="bad.toml")
    code, _, err = validate(path, capsys)
    assert one_line(code, err, str(bad)) == "not a text file (a NUL byte at offset 0)\n"


def test_oversized_file_is_refused_before_reading(tmp_path, capsys):
    # a valid scene padded with comments to one byte over the limit: read whole, it
    # would validate; the limit refuses it from its size alone
    path = scene_file(tmp_path)
    pad = MAX_INPUT_BYTES + 1 - path.stat().st_size
    with path.open("a") as f:
        f.write("#" * (pad - 1) + "\n")
    assert path.stat().st_size == MAX_INPUT_BYTES + 1
    reason = one_line(*validate(path, capsys)[::2], str(path))
    assert reason.startswith(f"too large ({MAX_INPUT_BYTES + 1} bytes")
    # at the limit it is read (and valid)
    with path.open("r+") as f:
        f.truncate(MAX_INPUT_BYTES)
    assert validate(path, capsys)[0] == 0


def test_fifo_is_refused_without_opening_it(tmp_path, capsys):
    # Opening a FIFO for reading blocks until a writer comes. A writer stands by that
    # feeds it a valid scene as soon as a reader opens it (retrying every 10 ms for
    # 20 s): a reader that opened it would validate (exit 0) instead of hanging, so the
    # test fails rather than hangs without the guard.
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    done = threading.Event()

    def writer() -> None:
        deadline = time.monotonic() + 20.0
        while not done.is_set() and time.monotonic() < deadline:
            try:
                fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # ENXIO: no reader
                time.sleep(0.01)
                continue
            os.write(fd, f'rig = "{RIG}"\n'.encode())
            os.close(fd)
            return

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    try:
        code, _, err = validate(fifo, capsys)
    finally:
        done.set()
        thread.join()
    assert one_line(code, err, str(fifo)) == "not a regular file but a named pipe (FIFO)\n"


@pytest.mark.parametrize(
    "device, kind", [("/dev/zero", "character device"), ("/dev/null", "character device")]
)
def test_device_is_refused(tmp_path, capsys, device, kind):
    # /dev/zero would be read up to the size limit and /dev/null read as an empty scene:
    # both are refused for what they are, before reading
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    assert stat.S_ISCHR(os.stat(device).st_mode)
    code, _, err = validate(device, capsys)
    assert one_line(code, err, device) == f"not a regular file but a {kind}\n"
    # and as a rig file
    code, _, err = validate(scene_file(tmp_path, rig=device), capsys)
    assert one_line(code, err, device) == f"not a regular file but a {kind}\n"


def test_socket_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a short relative name: socket paths hold 108 bytes
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind("rig.sock")
        code, _, err = validate(scene_file(tmp_path, rig="rig.sock"), capsys)
    assert one_line(code, err, str(tmp_path / "rig.sock")) == "not a regular file but a socket\n"


def test_directory_is_refused(tmp_path, capsys):
    # a rig path that is a directory (click refuses a directory as SCENE itself)
    (tmp_path / "rigs").mkdir()
    code, _, err = validate(scene_file(tmp_path, rig="rigs"), capsys)
    assert one_line(code, err, str(tmp_path / "rigs")) == "not a regular file but a directory\n"
    # a study's scene that is a directory
    study = tmp_path / "study.toml"
    study.write_text('scene = "rigs"\n')
    code, _, err = run_cli(["study", study, "-o", tmp_path / "out.nc", "-q"], capsys)
    assert one_line(code, err, str(tmp_path / "rigs")) == "not a regular file but a directory\n"


# --------------------------------------------------------------------------- rig references
def test_rig_reference_cycle_and_chain(tmp_path, capsys):
    # a.toml -> b.toml -> a.toml: the first rig file that names another is at fault
    (tmp_path / "a.toml").write_text('rig = "b.toml"\n')
    (tmp_path / "b.toml").write_text('rig = "a.toml"\n')
    code, _, err = validate(tmp_path / "a.toml", capsys)
    assert "cannot name another" in one_line(code, err, str(tmp_path / "b.toml"), "rig")
    # scene -> b.toml -> c.toml (a valid rig): rig files do not chain
    (tmp_path / "c.toml").write_text(RIG_TABLE)
    (tmp_path / "b.toml").write_text('rig = "c.toml"\n')
    code, _, err = validate(scene_file(tmp_path, rig="b.toml"), capsys)
    assert "cannot name another" in one_line(code, err, str(tmp_path / "b.toml"), "rig")
    # a scene naming itself
    path = scene_file(tmp_path, "[damping]\nratio = 0.01\n", rig="scene.toml")
    code, _, err = validate(path, capsys)
    assert "names the scene file itself" in one_line(code, err, str(path), "rig")


@pytest.mark.parametrize("value", ["5", "[1, 2]", "true"])
def test_rig_of_a_wrong_type(tmp_path, capsys, value):
    path = tmp_path / "scene.toml"
    path.write_text(f"rig = {value}\n")
    for argv in (["validate", path], ["rig", path]):
        reason = one_line(*run_cli(argv, capsys)[::2], str(path), "rig")
        assert reason.startswith("expected a rig file name or a [rig] table")


def test_rig_value_errors_name_the_rig_file(tmp_path, capsys):
    rig = tmp_path / "myrig.toml"
    rig.write_text(RIG_TABLE.replace("mass = 11.4", "mass = -1.0"))
    path = scene_file(tmp_path, rig="myrig.toml")
    for argv in (["validate", path], ["rig", path]):
        reason = one_line(*run_cli(argv, capsys)[::2], str(rig), "rig.mass")
        assert reason == "must be positive, got -1.0\n"
    # a value given by --set is the command line's, even for the rig
    code, _, err = validate(DEFAULT, capsys, "rig.mass=-2.0")
    assert one_line(code, err, "--set", "rig.mass") == "must be positive, got -2.0\n"
    # the derived constants of a rig file: the rig file, and the key that is off
    rig.write_text(RIG_TABLE.replace("210e9", "1e-300"))
    code, _, err = validate(path, capsys)
    assert "contact stiffness k" in one_line(code, err, str(rig), "rig.youngs_modulus")


def test_study_naming_itself_as_its_scene(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text('scene = "study.toml"\n[grid]\n"damping.ratio" = [0.01]\n')
    code, _, err = run_cli(["study", study, "-o", tmp_path / "out.nc", "-q"], capsys)
    assert "names the study file itself" in one_line(code, err, str(study), "scene")


# --------------------------------------------------------------------------- Nyquist
@pytest.mark.parametrize("harmonics", ["[1000]", "[1, 300]", "[1, 200]", "[1, 128]"])
def test_harmonics_at_or_above_nyquist(capsys, harmonics):
    # N = 256: the lock-in's tables are read at k j mod N, so 1000 read out of range
    # (a crash), 300 wrote NaN and 200 aliased onto 56 (256 - 200); 128 = N/2 reads only
    # the sampled cosine. 127 is the highest order allowed.
    code, _, err = validate(DEFAULT, capsys, f"lockin.harmonics={harmonics}")
    reason = one_line(code, err, "--set", "lockin.harmonics")
    assert "not below the Nyquist order steps_per_period / 2 = 128" in reason
    assert validate(DEFAULT, capsys, "lockin.harmonics=[1, 127]")[0] == 0


def test_nyquist_in_the_file_names_the_file(tmp_path, capsys):
    path = scene_file(tmp_path, "[lockin]\nharmonics = [1, 200]\n")
    code, _, err = validate(path, capsys)
    assert "Nyquist" in one_line(code, err, str(path), "lockin.harmonics")


# --------------------------------------------------------------------------- fractional orders
def test_measure_periods_a_multiple_of_the_orders_denominator(tmp_path, capsys):
    # H1/2 and H3/2 read exactly only over whole periods of 2 excitation periods, H1/3
    # and H1/4 of 12: validate refuses a measure_periods that is not a multiple of L, in
    # one line naming both numbers; a multiple passes, as does the trace's --periods
    code, _, err = validate(DEFAULT, capsys, "lockin.harmonics=[0.5, 1, 1.5]",
                            "sweep.measure_periods=21")  # fmt: skip
    reason = one_line(code, err, "--set", "sweep.measure_periods")
    assert reason.startswith("21 is not a multiple of 2, the common denominator of ")
    assert "lockin.harmonics = [0.5, 1, 1.5]" in reason and "measure_periods = 20" in reason
    path = scene_file(tmp_path, "[lockin]\nharmonics = [0.25, 0.3333333333333333, 1]\n")
    reason = one_line(*validate(path, capsys)[::2], str(path), "sweep.measure_periods")
    assert reason.startswith("20 is not a multiple of 12")
    assert validate(path, capsys, "sweep.measure_periods=24")[0] == 0
    assert validate(DEFAULT, capsys, "lockin.harmonics=[0.5, 1]")[0] == 0  # 20 = 10 x 2
    out = tmp_path / "trace.nc"
    argv = ["trace", DEFAULT, "-w", "0.97", "-o", out, "--periods", "5", "-q"]
    code, _, err = run_cli([*argv, "--set", "lockin.harmonics=[0.5, 1]"], capsys)
    assert one_line(code, err, "trace", "--periods").startswith("5 is not a multiple of 2")
    assert not out.exists()


# --------------------------------------------------------------------------- the grid
def test_grid_too_long_is_counted_not_built(capsys):
    # stop = 1e300 is 4e302 points (numpy refused to build it: ValueError); step = 1e-9
    # is 1.5e8 points (built, then a MemoryError after 14 s). Both are counted and
    # refused at once: 5 s is far above the 0.3 s the command takes, below the 14 s.
    for override, key, count in [
        ("sweep.stop=1e300", "sweep.stop", "4e+302"),
        ("sweep.step=1e-9", "sweep.step", "150000001"),
    ]:
        t0 = time.perf_counter()
        code, _, err = validate(DEFAULT, capsys, override)
        assert time.perf_counter() - t0 < 5.0
        reason = one_line(code, err, "--set", key)
        assert f"has {count} frequencies, more than {checks.MAX_POINTS}" in reason


def test_grid_at_the_largest_size_passes(capsys):
    # 0.9 .. 1.05 in steps of 1.5e-6 is exactly 100001 points, one too many; 2e-6 is
    # 75001 (settle 0, measure 1 keeps the steps within the budget)
    short = ["sweep.settle_periods=0", "sweep.measure_periods=1"]
    code, _, err = validate(DEFAULT, capsys, "sweep.step=1.5e-6", *short)
    assert "100001 frequencies" in one_line(code, err, "--set", "sweep.step")
    code, out, _ = validate(DEFAULT, capsys, "sweep.step=2e-6", *short)
    assert code == 0 and "75001 frequencies" in out


def test_grid_points_rounding_to_zero_or_together(capsys):
    # the grid is rounded to 12 decimals: start = 1e-13 became w = 0 (then a
    # ZeroDivisionError in the stability limit); a step of 1e-13 makes neighbours equal
    code, _, err = validate(DEFAULT, capsys, "sweep.start=1e-13")
    assert "rounds to 0" in one_line(code, err, "--set", "sweep.start")
    code, _, err = validate(
        DEFAULT, capsys, "sweep.start=1.0", "sweep.stop=1.000000000005", "sweep.step=1e-13"
    )
    assert "collapse" in one_line(code, err, "--set", "sweep.step")


# --------------------------------------------------------------------------- the rig's constants
@pytest.mark.parametrize(
    "overrides, key, constant",
    [
        # k = 3e-302 and 5e160: finite, but outside the range where a product of two
        # derived constants stays a normal float (checks.DERIVED_RANGE)
        (["rig.youngs_modulus=1e-300"], "rig.youngs_modulus", "contact stiffness k"),
        (["rig.ball_radius=1e300"], "rig.ball_radius", "contact stiffness k"),
        # k underflows to 0: z_s = (F_s / k)^(2/3) divided by zero
        (["rig.youngs_modulus=1e-300", "rig.ball_radius=1e-300"], "rig.youngs_modulus", ""),
        # Omega^2 of a measured f0 of 1e200 Hz overflows (a float power raises)
        (["rig.natural_frequency=1e200"], "rig.natural_frequency", ""),
        # a denormal mass: Omega = inf
        (["rig.mass=1e-320"], "rig.mass", "natural circular frequency Omega is inf"),
    ],
)
def test_derived_rig_constants_finite_and_positive(capsys, overrides, key, constant):
    code, _, err = validate(DEFAULT, capsys, *overrides)
    assert constant in one_line(code, err, "--set", key)


def test_rig_command_checks_the_constants(tmp_path, capsys):
    # R = 1e300 m: the default ball mass (density x 4/3 pi R^3) overflows; with a ball
    # mass given, k = 5.4e160 is out of range
    rig = tmp_path / "rig.toml"
    rig.write_text(RIG_TABLE.replace("12.7e-3", "1e300"))
    code, _, err = run_cli(["rig", rig], capsys)
    reason = one_line(code, err, str(rig), "rig.ball_radius")
    assert reason == "the ball's mass from its radius overflows\n"
    rig.write_text(RIG_TABLE.replace("12.7e-3", "1e300") + "ball_mass = 0.067\n")
    code, _, err = run_cli(["rig", rig], capsys)
    assert "contact stiffness k is 5.4" in one_line(code, err, str(rig), "rig.ball_radius")


# --------------------------------------------------------------------------- steps
@pytest.mark.parametrize("value", ["1e9", str(2**63 - 1)])
def test_steps_per_period_is_capped(capsys, value):
    # per-period tables of N floats would be allocated (8 GB at 1e9; 2**63-1 overflows)
    code, _, err = validate(DEFAULT, capsys, f"solver.steps_per_period={value}")
    reason = one_line(code, err, "--set", "solver.steps_per_period")
    assert f"is more than the largest {checks.MAX_STEPS_PER_PERIOD}" in reason


def test_step_budget(capsys):
    # 61 frequencies x 4 trajectories x (1e12 + 20) periods x 256 steps = 6.25e16 steps,
    # 6e5 times the budget of 1e11 (15 minutes): refused, naming the key that grew
    code, _, err = validate(DEFAULT, capsys, "sweep.settle_periods=1000000000000")
    reason = one_line(code, err, "--set", "sweep.settle_periods")
    assert reason.startswith("the run would take 6.25e+16 integration steps")
    assert "solver.max_steps = 1e+11" in reason
    # "auto" is counted at its cap
    code, _, err = validate(
        DEFAULT, capsys, "sweep.settle_periods='auto'", "sweep.max_settle_periods=1e12"
    )
    assert "integration steps" in one_line(code, err, "--set", "sweep.max_settle_periods")
    # raised explicitly, the budget allows it (the run is the user's choice)
    code, out, _ = validate(
        DEFAULT, capsys, "sweep.settle_periods=1000000000000", "solver.max_steps=1e17"
    )
    assert code == 0 and "6.25e+16 integration steps of the budget 1e+17" in out


def test_max_steps_is_a_budget_not_a_setting():
    # it bounds the run and changes no result: not among the dataset's attributes (nor
    # the study's case hash), but kept by to_dict when given, so a rerun may go as far
    scene = load_scene(DEFAULT, ["solver.max_steps=1e12"])
    assert scene.solver.max_steps == 10**12
    assert not any("max_steps" in k for k in scene.attributes())
    assert scene.to_dict()["solver"]["max_steps"] == 10**12
    assert "max_steps" not in load_scene(DEFAULT).to_dict()["solver"]
    assert checks.preflight(load_scene(DEFAULT)).max_steps == checks.DEFAULT_MAX_STEPS


# --------------------------------------------------------------------------- memory
def test_memory_budget(tmp_path, capsys):
    # 5000 sigma x 2 directions x 1001 frequencies x (2 x 2 harmonics + 5 readings) x 8
    # bytes, held 3 times: 2.2 GB > 2 GiB, while its steps (1001 x 1e4 x 1 period x 256
    # = 2.6e9) are within their budget
    sigma = ", ".join(f"{1e-4 * (i + 1):.4g}" for i in range(5000))
    path = scene_file(
        tmp_path,
        f"[excitation]\nsigma = [{sigma}]\n[sweep]\nstep = 1.5e-4\n"
        "settle_periods = 0\nmeasure_periods = 1\n",
    )
    code, _, err = validate(path, capsys)
    reason = one_line(code, err, str(path), "excitation.sigma")
    assert "beyond the memory budget 2 GiB" in reason


def test_trace_record_memory(tmp_path, capsys):
    # --periods 1e9: 2 sigma x 1e9 periods x 256 samples x 4 columns = 2e12 floats
    # (2.7e4 GiB with the dataset's copies); refused before allocating, nothing written
    out = tmp_path / "trace.nc"
    argv = ["trace", DEFAULT, "-w", "0.95", "--periods", "1000000000", "-o", out, "-q"]
    code, _, err = run_cli(argv, capsys)
    assert "beyond the memory budget 2 GiB" in one_line(code, err, "trace", "--periods")
    assert not out.exists()


def test_trace_record_steps(tmp_path, capsys):
    # with a budget of 5e7 steps: recording 1e5 periods is 2 sigma x 1e5 x 256 = 5.12e7
    # steps, more than the dwells that reach w (at most 2 x 62 x 320 x 256 = 1.02e7) and
    # than the budget; 8 samples a period keep the record small (1.6e6 samples, 91 MiB)
    out = tmp_path / "trace.nc"
    argv = ["trace", DEFAULT, "-w", "0.95", "--periods", "100000", "-o", out, "-q"]
    argv += ["--samples-per-period", "8", "--set", "solver.max_steps=5e7"]
    code, _, err = run_cli(argv, capsys)
    reason = one_line(code, err, "trace", "--periods")
    assert reason.startswith("the trace would take 6.14e+07 integration steps (5.12e+07")
    assert not out.exists()


# --------------------------------------------------------------------------- stability
def test_validate_and_run_agree_on_sigma_2_zeta_1e5(tmp_path, capsys):
    # sigma = 2, zeta = 1e-5 at N = 256: the preflight's force bound is 1 + 2 / (2e-3)
    # = 1001 (zeta floored at 1e-3), a limit of 11.0 steps; the run reaches N/F_s = 413
    # (up) and 392 (down), a limit of 9.5 at w = 0.9, and runs to its end. Both accept.
    overrides = ["--set", "excitation.sigma=2", "--set", "damping.ratio=1e-5"]
    code, out, err = run_cli(["validate", DEFAULT, *overrides], capsys)
    assert code == 0 and "23.2x the stability limit 11.0" in out, err
    output = tmp_path / "x.nc"
    code, out, err = run_cli(["sweep", DEFAULT, "-o", output, "-q", *overrides], capsys)
    assert code == 0 and output.exists(), err
    force_max = float(open_dataset(output).force_max.max())
    assert 400 < force_max < 1001  # measured 413.5: reached, and within the bound


def test_stability_limit_refused_the_same_by_validate_and_run(tmp_path, capsys):
    # N = 3 is below the limit 4.0 of the default scene: every command refuses it with
    # the line validate gives, before computing (no output written)
    code, _, expected = validate(DEFAULT, capsys, "solver.steps_per_period=3")
    assert "at or below the stability limit 4.0" in one_line(
        code, expected, "--set", "solver.steps_per_period"
    )
    for command in ("sweep", "branch", "accuracy"):
        out = tmp_path / f"{command}.nc"
        argv = [command, DEFAULT, "-o", out, "-q", "--set", "solver.steps_per_period=3"]
        code, _, err = run_cli(argv, capsys)
        assert code == 2 and err == expected and not out.exists()


@pytest.mark.parametrize("command", ["sweep", "trace", "branch", "accuracy"])
def test_every_command_runs_the_preflight(tmp_path, capsys, command):
    # read_scene runs the preflight: a check only it makes (the Nyquist order) stops
    # each command before computing, with validate's line
    code, _, expected = validate(DEFAULT, capsys, "lockin.harmonics=[1, 200]")
    out = tmp_path / f"{command}.nc"
    argv = [command, DEFAULT, "-o", out, "-q", "--set", "lockin.harmonics=[1, 200]"]
    if command == "trace":
        argv += ["-w", "0.95"]
    code, _, err = run_cli(argv, capsys)
    one_line(code, err, "--set", "lockin.harmonics")
    assert err == expected and not out.exists()


def test_study_cases_run_the_preflight(tmp_path, capsys):
    # a grid value that passes the config but not the run's checks: the case is named
    study = tmp_path / "study.toml"
    study.write_text(f'scene = "{DEFAULT}"\n[grid]\n"lockin.harmonics" = [2, 200]\n')
    code, _, err = run_cli(["study", study, "-o", tmp_path / "out.nc", "-q"], capsys)
    reason = one_line(code, err, f"{study}[lockin.harmonics=200]", "lockin.harmonics")
    assert "Nyquist" in reason


# --------------------------------------------------------------------------- validate
def test_validate_reports_the_figures(capsys):
    # the default scene: 61 frequencies x 4 trajectories x (320 + 1) periods (one read
    # for the ball's mode) x 256 steps = 2.0e7 steps; results 3 x (4 x 61 x ((2 x 2 + 5
    # + 3) x 8 + 2) + 3 x 61 x 8) + 2 x 256 x 8 bytes = 78.3 kiB; limit pi (1 +
    # 0.01/0.009)^(1/6) / 0.9 = 3.95
    code, out, _ = validate(DEFAULT, capsys)
    assert code == 0
    assert "61 frequencies (4 trajectories of 321 periods a dwell)" in out
    assert "64.8x the stability limit 4.0" in out
    assert "2.01e+07 integration steps of the budget 1e+11" in out
    assert "results 78.3 kiB of the budget 2 GiB" in out
    figures = checks.preflight(load_scene(DEFAULT))
    assert figures.steps == 61 * 4 * 321 * 256
    # at most: the ball-mode period is read only where a dwell repeats (243 of 244 here)
    assert figures.steps - run_sweep_steps(DEFAULT) in (0, 256)


def run_sweep_steps(path):
    """The steps the sweep command's run takes (its kind's runner)."""
    from hertzsweep.core.kinds import KINDS

    return KINDS["sweep"].run(load_scene(path)).steps
