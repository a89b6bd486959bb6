"""Output files: refused before computing when they cannot be written, written whole or
not at all, under a lock, with temporaries that git ignores and a killed run's removed.

Every refusal is one line on stderr, ``hertzsweep: error: PATH: reason``, exit status 2,
no traceback, and nothing computed or left behind."""

from __future__ import annotations

import dataclasses
import errno
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from hertzsweep.output import paths
from hertzsweep.output.dataset import open_dataset

from .conftest import CONFIGS, ROOT, run_cli, run_on_a_small_disk
from .test_study import write_study

# The smoke scene cut to 2 directions x 1 sigma x 5 frequencies (0.95 ... 0.96, step
# 0.0025) of 210 periods: about a second of computing, enough to have a dataset to write.
SMALL = ["--set", "sweep.start=0.95", "--set", "sweep.stop=0.96", "--set", "excitation.sigma=0.01"]
TEMPORARY = re.compile(r"^\.x\.nc\.[0-9]+\.[0-9a-f]{8}\.part$")


def scene_copy(folder: Path) -> Path:
    """The smoke scene and its rig file copied into ``folder`` (inputs a test may lose)."""
    shutil.copy(CONFIGS / "rig.toml", folder / "rig.toml")
    shutil.copy(CONFIGS / "smoke.toml", folder / "smoke.toml")
    return folder / "smoke.toml"


def sweep(scene, out, capsys, *extra):
    return run_cli(["sweep", scene, "-o", out, "-q", *SMALL, *extra], capsys)


def assert_refused(code, stdout, err, path):
    """Exit 2, exactly one line on stderr naming ``path``, no traceback, nothing written."""
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("hertzsweep: error: "), err
    assert str(path) in err and "Traceback" not in err
    assert "wrote" not in stdout


def hidden(folder: Path) -> list[str]:
    """What a run may leave beside its output: temporaries and lock files."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.fixture
def no_computing(monkeypatch):
    """Every command's driver replaced by one that fails the test when it is called: a
    refused output must end the command before anything is computed."""
    from hertzsweep.core.kinds import KINDS

    def computed(*args, **kwargs):
        raise AssertionError("computed although the output was refused")

    for name, kind in list(KINDS.items()):
        monkeypatch.setitem(KINDS, name, dataclasses.replace(kind, run=computed))


# --------------------------------------------------------------------------- 1. checks
def test_empty_output_is_refused(tmp_path, capsys, no_computing, monkeypatch):
    # -o '' named the working directory: "Device or resource busy" after the whole run
    monkeypatch.chdir(tmp_path)
    code, stdout, err = sweep(CONFIGS / "smoke.toml", "", capsys)
    assert_refused(code, stdout, err, "-o ''")
    assert list(tmp_path.iterdir()) == []


def test_folder_or_trailing_slash_is_refused(tmp_path, capsys, no_computing):
    # `-o newdir/` wrote a file named newdir; an existing folder is refused as well
    new = f"{tmp_path}/newdir/"
    code, stdout, err = sweep(CONFIGS / "smoke.toml", new, capsys)
    assert_refused(code, stdout, err, new)
    assert "names a folder (it ends with '/')" in err and list(tmp_path.iterdir()) == []
    folder = tmp_path / "existing"
    folder.mkdir()
    code, stdout, err = sweep(CONFIGS / "smoke.toml", folder, capsys)
    assert_refused(code, stdout, err, folder)
    assert (
        f"{folder}: is a folder" in err
        and folder.is_dir()
        and list(folder.iterdir()) == []
        and hidden(tmp_path) == []
    )


def test_special_files_are_never_replaced(tmp_path, capsys, no_computing):
    # /dev/null (a character device), a FIFO and a socket: refused, each left as it was
    # (as root, os.replace used to make /dev/null a regular file)
    fifo = tmp_path / "pipe.nc"
    os.mkfifo(fifo)
    sock_path = tmp_path / "sock.nc"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.bind(str(sock_path))
    try:
        for path, test, what in [
            (Path(os.devnull), stat.S_ISCHR, "character device"),
            (fifo, stat.S_ISFIFO, "FIFO"),
            (sock_path, stat.S_ISSOCK, "socket"),
        ]:
            code, stdout, err = sweep(CONFIGS / "smoke.toml", path, capsys)
            assert_refused(code, stdout, err, path)
            assert what in err and test(os.lstat(path).st_mode)
    finally:
        sock.close()
    assert hidden(tmp_path) == [] and not Path("/dev/.hertzsweep-lock.null").exists()


def test_symbolic_link_is_refused(tmp_path, capsys, no_computing):
    # decision: refused, not followed (module docstring of hertzsweep.output.paths); the
    # link and its target stay as they were, a dangling link creates no target
    target = tmp_path / "target.nc"
    target.write_bytes(b"an earlier dataset")
    link = tmp_path / "link.nc"
    link.symlink_to(target.name)
    dangling = tmp_path / "dangling.nc"
    dangling.symlink_to("nowhere.nc")
    for path in (link, dangling):
        code, stdout, err = sweep(CONFIGS / "smoke.toml", path, capsys)
        assert_refused(code, stdout, err, path)
        assert "symbolic link" in err and path.is_symlink()
    assert target.read_bytes() == b"an earlier dataset"
    assert not (tmp_path / "nowhere.nc").exists() and hidden(tmp_path) == []


def test_input_file_is_refused(tmp_path, capsys, no_computing):
    # -o equal to the scene overwrote it with HDF5; the rig file under another spelling
    # and a hard link to the scene are the same files
    scene = scene_copy(tmp_path)
    (tmp_path / "sub").mkdir()
    hard = tmp_path / "hard.toml"
    os.link(scene, hard)
    before = {p: p.read_bytes() for p in (scene, tmp_path / "rig.toml")}
    for out in (scene, tmp_path / "sub" / ".." / "rig.toml", hard):
        code, stdout, err = sweep(scene, out, capsys)
        assert_refused(code, stdout, err, out)
        assert "is an input of this run" in err
    assert {p: p.read_bytes() for p in before} == before
    assert hidden(tmp_path) == []


def test_missing_or_unwritable_folder_is_refused(tmp_path, capsys, no_computing, monkeypatch):
    # a folder that does not exist, a file in place of the folder, a folder the user may
    # not write (os.access answers False; chmod does not bind root: see the test below),
    # a name whose temporary would be too long
    afile = tmp_path / "afile"
    afile.write_text("")
    locked = tmp_path / "locked"
    locked.mkdir()
    real_access = os.access
    monkeypatch.setattr(
        os, "access", lambda p, mode, **kw: os.fspath(p) != str(locked) and real_access(p, mode)
    )
    for out, reason in [
        (tmp_path / "missing" / "x.nc", "does not exist"),
        (afile / "x.nc", "is not a folder"),
        (locked / "x.nc", "is not writable"),
        # 240 bytes: a file name may have 255, its temporary .NAME.<pid>.<8 hex>.part.svg
        # 20 to 27 more
        (tmp_path / ("a" * 240), "its name is too long"),
    ]:
        code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
        assert_refused(code, stdout, err, out)
        assert reason in err
    assert not (tmp_path / "missing").exists() and list(locked.iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a 0o500 folder")
def test_read_only_folder_is_refused(tmp_path, capsys, no_computing):
    folder = tmp_path / "ro"
    folder.mkdir(mode=0o500)
    try:
        code, stdout, err = sweep(CONFIGS / "smoke.toml", folder / "x.nc", capsys)
    finally:
        folder.chmod(0o700)
    assert_refused(code, stdout, err, folder / "x.nc")
    assert list(folder.iterdir()) == []


def other_commands(tmp_path: Path) -> list[tuple[str, list, Path]]:
    """(name, argv without -o, an input file of it) for every writing command but sweep."""
    scene = scene_copy(tmp_path)
    csv = tmp_path / "jumps.csv"
    shutil.copy(CONFIGS / "measured" / "paper-down-jumps.csv", csv)
    study = write_study(tmp_path / "s.toml", {"damping.ratio": [0.01, 0.02]})
    dataset = tmp_path / "in.nc"
    shutil.copy(ROOT / "tests" / "data" / "smoke-reference.nc", dataset)
    free = ["--free", "damping.ratio"]
    return [
        ("trace", ["trace", scene, "-w", "0.95", "-q"], scene),
        ("branch", ["branch", scene, "-q"], tmp_path / "rig.toml"),
        ("accuracy", ["accuracy", scene, "--quick", "-q"], scene),
        ("fit", ["fit", csv, "--scene", scene, *free, "-q"], csv),
        ("import", ["import", csv], csv),
        ("rerun", ["rerun", dataset, "-q"], dataset),
        ("study", ["study", study, "--workers", "1", "-q"], study),
    ]


def test_every_writing_command_checks_its_output(tmp_path, capsys, no_computing):
    # each command refuses a trailing slash (the option's check) and its own input file
    # (its claim after reading its inputs), before computing
    for name, argv, source in other_commands(tmp_path):
        before = source.read_bytes()
        code, stdout, err = run_cli([*argv, "-o", f"{tmp_path}/new/"], capsys)
        assert_refused(code, stdout, err, f"{tmp_path}/new/")
        code, stdout, err = run_cli([*argv, "-o", source], capsys)
        assert_refused(code, stdout, err, source)
        assert "is an input of this run" in err, name
        assert source.read_bytes() == before, name
    assert not list(tmp_path.glob("*.parts")) and hidden(tmp_path) == []


def test_plot_checks_its_figure_path_before_drawing(tmp_path, capsys, monkeypatch):
    # plot's -o is the same checked option: a FIFO or a link with a figure's name, a
    # folder, an empty path are refused before the dataset is read or drawn
    import hertzsweep.output.figures as plot_command

    def no_drawing(*args, **kwargs):
        raise AssertionError("drew a figure for an output it cannot write")

    monkeypatch.setattr(plot_command, "figure", no_drawing)
    dataset = tmp_path / "in.nc"
    shutil.copy(ROOT / "tests" / "data" / "smoke-reference.nc", dataset)
    os.mkfifo(tmp_path / "fifo.png")
    (tmp_path / "link.png").symlink_to(tmp_path / "elsewhere.png")
    for bad in (tmp_path / "fifo.png", tmp_path / "link.png", f"{tmp_path}/new/", ""):
        code, stdout, err = run_cli(["plot", dataset, "-o", bad], capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert "Traceback" not in err and stdout == ""
    assert stat.S_ISFIFO((tmp_path / "fifo.png").lstat().st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo.png", "in.nc", "link.png"]


# --------------------------------------------------------------------------- 2. write failures
def test_disk_full_while_writing_is_one_line(tmp_path, capsys, monkeypatch):
    # the disk fills half way through the low-level write: one line naming the output
    # and the OS's reason, the temporary and the lock removed, the earlier file untouched
    out = tmp_path / "x.nc"
    out.write_bytes(b"an earlier run's dataset")
    seen = []

    def half_then_full(fd, data):
        seen.append(Path(os.readlink(f"/proc/self/fd/{fd}")).name)
        os.write(fd, bytes(memoryview(data)[: len(data) // 2]))
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(paths, "_write_all", half_then_full)
    code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    assert_refused(code, stdout, err, out)
    assert f"{out}: No space left on device" in err and "NetCDF" not in err
    assert len(seen) == 1 and TEMPORARY.match(seen[0]), seen
    assert sorted(tmp_path.iterdir()) == [out] and out.read_bytes() == b"an earlier run's dataset"


def test_io_error_on_rename_is_one_line(tmp_path, capsys, monkeypatch):
    # the rename onto the output fails (EIO): one line, the complete temporary removed
    out = tmp_path / "x.nc"
    real_replace = os.replace

    def failing_replace(src, dst, **kwargs):
        if Path(dst) == out:
            raise OSError(errno.EIO, os.strerror(errno.EIO))
        return real_replace(src, dst, **kwargs)

    monkeypatch.setattr(os, "replace", failing_replace)
    code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    assert_refused(code, stdout, err, out)
    assert f"{out}: Input/output error" in err
    assert list(tmp_path.iterdir()) == []


def test_permission_denied_creating_the_temporary_is_one_line(tmp_path, capsys, monkeypatch):
    # the folder refuses the temporary once the run has computed (EACCES): one line
    out = tmp_path / "x.nc"

    def refused(path, suffix):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES))

    monkeypatch.setattr(paths, "_create_temporary", refused)
    code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    assert_refused(code, stdout, err, out)
    assert f"{out}: Permission denied" in err and list(tmp_path.iterdir()) == []


def test_a_really_full_disk_is_one_line(tmp_path):
    # a 32 kB tmpfs in a private mount namespace (root, unshare): the dataset (about
    # 57 kB) does not fit; skipped where mounting is not allowed
    hertzsweep = [sys.executable, "-m", "hertzsweep"]
    argv = [*hertzsweep, "sweep", str(CONFIGS / "smoke.toml"), "-o", "full/x.nc", "-q", *SMALL]
    stdout, stderr = run_on_a_small_disk(tmp_path, argv, "32k")
    assert stdout.split() == ["status=2"], stdout  # nothing left in full/
    assert stderr == "hertzsweep: error: full/x.nc: No space left on device\n"


# --------------------------------------------------------------------------- 3. temporaries
def git_ignored(name: str) -> bool:
    done = subprocess.run(
        ["git", "check-ignore", "--no-index", "-q", name], cwd=ROOT, capture_output=True
    )
    assert done.returncode in (0, 1), done.stderr
    return done.returncode == 0


@pytest.mark.skipif(
    shutil.which("git") is None or not (ROOT / ".git").exists(), reason="not a git checkout"
)
def test_temporary_and_lock_names_are_git_ignored(tmp_path, capsys, monkeypatch):
    # the names a real write uses (seen while writing), a figure's temporary (suffix
    # .png), and the lock file; the output itself is not ignored
    from hertzsweep.output import dataset

    seen = []
    original = dataset.write_netcdf

    def spy(ds, path):
        seen.append(Path(path).name)
        seen.extend(p.name for p in Path(path).parent.iterdir() if p.name.startswith("."))
        original(ds, path)

    monkeypatch.setattr(dataset, "write_netcdf", spy)
    code, _, err = sweep(CONFIGS / "smoke.toml", tmp_path / "x.nc", capsys)
    assert code == 0, err
    temporary, *others = seen
    assert TEMPORARY.match(temporary), temporary
    assert sorted(others) == sorted([temporary, ".hertzsweep-lock.x.nc"])
    figure = paths.temporary_name(tmp_path / "f.png", ".png").name
    for name in (temporary, figure, ".hertzsweep-lock.x.nc"):
        assert git_ignored(f"tests/{name}"), name
    assert not git_ignored("tests/x.nc")
    assert hidden(tmp_path) == []


KILLED_WRITER = """
import os, signal, sys
from hertzsweep.output.paths import atomic_path
with atomic_path(sys.argv[1]) as tmp:
    tmp.write_bytes(b"half a dataset")
    os.kill(os.getpid(), signal.SIGKILL)
"""


def test_killed_runs_temporary_is_removed_by_the_next_run(tmp_path, capsys):
    # a writer killed (SIGKILL) inside the atomic write leaves its temporary; the next
    # run writing the same output removes it, says so in one line, and keeps a live
    # process's temporary and another output's
    out = tmp_path / "x.nc"
    killed = subprocess.run([sys.executable, "-c", KILLED_WRITER, str(out)], timeout=60)
    assert killed.returncode == -signal.SIGKILL
    (left,) = [p for p in tmp_path.iterdir() if TEMPORARY.match(p.name)]
    live = tmp_path / f".x.nc.{os.getppid()}.0123abcd.part"  # pytest's parent: alive
    live.write_bytes(b"")
    other = tmp_path / f".y.nc.{left.name.split('.')[3]}.0123abcd.part"
    other.write_bytes(b"")
    code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    assert code == 0 and f"wrote {out}" in stdout
    assert err.count("\n") == 1 and "removed 1 temporary file(s)" in err and left.name in err
    assert not left.exists() and live.exists() and other.exists()
    assert open_dataset(out).attrs["hertzsweep_kind"] == "sweep"


# --------------------------------------------------------------------------- 4. the lock
HOLDER = """
import sys, time
from hertzsweep.output.paths import lock_output
lock = lock_output(sys.argv[1])
print("locked", flush=True)
time.sleep(120)
"""


def test_second_writer_is_refused(tmp_path, capsys, no_computing):
    # another process holds the output's lock (as a running sweep does): this run is
    # refused at once, naming that process; nothing computed, the earlier file untouched
    out = tmp_path / "x.nc"
    out.write_bytes(b"an earlier run's dataset")
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(out)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    finally:
        holder.kill()
        holder.wait(timeout=30)
    assert_refused(code, stdout, err, out)
    assert f"another hertzsweep run is writing it (pid {holder.pid})" in err
    assert out.read_bytes() == b"an earlier run's dataset"


def test_lock_of_a_finished_or_killed_run_is_taken_over(tmp_path, capsys):
    # a killed holder leaves its lock file but not the lock: the next run writes; runs
    # one after another in one process each take and release it, leaving no file
    out = tmp_path / "x.nc"
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(out)], stdout=subprocess.PIPE, text=True
    )
    assert holder.stdout.readline().strip() == "locked"
    holder.kill()
    holder.wait(timeout=30)
    assert hidden(tmp_path) == [".hertzsweep-lock.x.nc"]
    for _ in range(2):
        code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
        assert code == 0 and err == "" and f"wrote {out}" in stdout
        assert hidden(tmp_path) == []


# --------------------------------------------------------------------------- 5. studies
def small_study(tmp_path: Path) -> Path:
    # two cases of 4 frequencies x 44 periods x 64 steps: a blink each on one worker
    return write_study(tmp_path / "s.toml", {"damping.ratio": [0.01, 0.02]})


def test_study_part_that_cannot_be_written_is_a_failed_case(tmp_path, capsys, monkeypatch):
    # the first part's write fails (no space): that case is recorded as failed (one
    # line, its error record written), the other is written, exit 1 as for a failed case
    from hertzsweep.jobs import study as study_output

    real_write = study_output.write_atomic
    failed = []

    def first_fails(ds, path):
        if not failed:
            failed.append(Path(path))
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real_write(ds, path)

    monkeypatch.setattr(study_output, "write_atomic", first_fails)
    out = tmp_path / "study.nc"
    code, stdout, err = run_cli(
        ["study", small_study(tmp_path), "-o", out, "--workers", "1", "-q"], capsys
    )
    lines = err.splitlines()
    assert code == 1 and len(lines) == 2 and "Traceback" not in err, err
    assert "case failed" in lines[0] and "No space left on device" in lines[0]
    assert str(failed[0]) in lines[0] and ".error.json" in lines[0]
    assert lines[1] == "hertzsweep: error: 1 of 2 cases failed"
    assert sorted(open_dataset(out).case_failed.values.tolist()) == [0, 1]
    assert not failed[0].exists() and len(list(study_output.parts_folder(out).glob("*.json"))) == 1


def test_study_with_no_part_written_leaves_the_earlier_output_said(tmp_path, capsys, monkeypatch):
    # every part and every error record fails to be written: each case is a failed case
    # (saying its record could not be written), no output; the earlier OUT.nc is left as
    # it was and the last line says it is an earlier run's
    from hertzsweep.jobs import study as study_output

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(args[-1]))

    monkeypatch.setattr(study_output, "write_atomic", full)
    monkeypatch.setattr(study_output, "atomic_path", full)
    out = tmp_path / "study.nc"
    out.write_bytes(b"an earlier run's dataset")
    code, stdout, err = run_cli(
        ["study", small_study(tmp_path), "-o", out, "--workers", "1", "-q"], capsys
    )
    lines = err.splitlines()
    assert code == 1 and len(lines) == 3 and "Traceback" not in err, err
    assert all("its record could not be written: No space left on device" in x for x in lines[:2])
    assert lines[2].startswith("hertzsweep: error: 2 of 2 cases failed; no output written; ")
    assert f"{out} is left as it was: an earlier run's" in lines[2]
    assert out.read_bytes() == b"an earlier run's dataset" and hidden(tmp_path) == []


def test_stopped_study_says_the_output_is_an_earlier_runs(tmp_path, capsys, monkeypatch):
    # a stop requested before any case finished (as SIGTERM would): exit 143, one line,
    # naming the earlier OUT.nc left in place
    from hertzsweep.cli import study as study_cli

    class StopAtOnce(study_cli.StopRequest):
        def __call__(self) -> int:
            return signal.SIGTERM

    monkeypatch.setattr(study_cli, "StopRequest", StopAtOnce)
    out = tmp_path / "study.nc"
    out.write_bytes(b"an earlier run's dataset")
    code, stdout, err = run_cli(
        ["study", small_study(tmp_path), "-o", out, "--workers", "1", "-q"], capsys
    )
    assert code == 128 + signal.SIGTERM and err.count("\n") == 1, err
    assert "interrupted by SIGTERM: 0 of 2 cases finished" in err
    assert f"{out} is left as it was: an earlier run's" in err
    assert out.read_bytes() == b"an earlier run's dataset" and hidden(tmp_path) == []


# --------------------------------------------------------------------------- 6. OUT.partial.nc
@pytest.fixture
def interrupted_sweep(monkeypatch):
    """The sweep driver runs, then reports an interrupt with its whole result as the
    partial one (as SIGINT after the last dwell would)."""
    from hertzsweep.core.kinds import KINDS
    from hertzsweep.errors import Interrupted

    real = KINDS["sweep"]

    def run_then_interrupt(scene, progress=None):
        raise Interrupted(real.run(scene, progress), signal.SIGINT)

    monkeypatch.setitem(KINDS, "sweep", dataclasses.replace(real, run=run_then_interrupt))


def test_partial_output_is_written_atomically(tmp_path, capsys, interrupted_sweep):
    out = tmp_path / "x.nc"
    code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    assert code == 130 and err.splitlines()[-1] == "hertzsweep: error: interrupted"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.partial.nc"]
    assert open_dataset(tmp_path / "x.partial.nc").attrs["complete"] == 0


def test_partial_output_that_cannot_be_written_is_one_line(
    tmp_path, capsys, interrupted_sweep, monkeypatch
):
    # no space for OUT.partial.nc: one line says so, the run still ends as interrupted,
    # nothing left; a symbolic link at OUT.partial.nc is refused and kept
    out = tmp_path / "x.nc"

    def full(fd, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with monkeypatch.context() as patch:
        patch.setattr(paths, "_write_all", full)
        code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    partial = tmp_path / "x.partial.nc"
    assert code == 130 and "Traceback" not in err
    # (click ends an interrupted command's line on stderr: a blank line before the last)
    assert [line for line in err.splitlines() if line] == [
        f"hertzsweep: cannot keep the finished dwells: {partial}: No space left on device",
        "hertzsweep: error: interrupted",
    ]
    assert list(tmp_path.iterdir()) == []
    partial.symlink_to("elsewhere.nc")
    code, stdout, err = sweep(CONFIGS / "smoke.toml", out, capsys)
    assert code == 130 and "symbolic link" in err.splitlines()[0] and str(partial) in err
    assert partial.is_symlink() and sorted(p.name for p in tmp_path.iterdir()) == ["x.partial.nc"]


def test_partial_output_is_never_an_input(tmp_path, capsys, interrupted_sweep):
    # the scene is named x.partial.nc, the OUT.partial.nc of -o x.nc: it is kept as it
    # was, one line says why no partial file was written
    shutil.copy(CONFIGS / "rig.toml", tmp_path / "rig.toml")
    scene = tmp_path / "x.partial.nc"
    shutil.copy(CONFIGS / "smoke.toml", scene)
    before = scene.read_bytes()
    code, stdout, err = sweep(scene, tmp_path / "x.nc", capsys)
    assert code == 130 and "Traceback" not in err
    assert "cannot keep the finished dwells" in err and "is an input of this run" in err
    assert scene.read_bytes() == before and hidden(tmp_path) == []
