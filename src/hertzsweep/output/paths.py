"""Output files: where a command may write, the lock that keeps two runs off one output,
and the atomic write itself (standard library only: the light commands import it).

- **Checked before computing.** :func:`check_output` (no scene needed: the ``-o``
  option's callback) refuses an empty path, a folder (or a path ending in ``/``), a FIFO,
  device, socket or other special file, a symbolic link, and a path whose folder does not
  exist or is not writable; :func:`check_not_input` refuses one of the run's input files.
  Each refusal is one :class:`OutputPathError` naming the path and the reason.
- **Symbolic links are refused**, not followed: ``-o LINK`` would otherwise either replace
  the link by a regular file (the link is lost) or write into its target, which may be a
  read-only object of a data store (git-annex, DVC) or a file outside the folder the user
  looked at. Give the target itself, or remove the link. Links among the *folders* of the
  path are followed as usual.
- **Complete or absent.** :func:`atomic_path` hands out a temporary name beside the
  output, ``.OUT.<pid>.<random>.part`` (``.gitignore``: ``.*.[0-9]*.part*``), renamed to
  the output when the block succeeds and removed when it fails. A write that fails
  (no space, I/O error, permission) ends as one ``OSError`` naming the output, not the
  temporary. A run killed by SIGKILL can leave its temporary behind: the next run that
  writes the same output removes those whose process is gone
  (:func:`remove_stale_temporaries`).
- **One writer.** :func:`lock_output` takes an advisory lock (``flock``) on
  ``.hertzsweep-lock.OUT`` beside the output (``.gitignore``: ``.hertzsweep-lock.*``),
  holding the writer's pid; a second run writing the same output is refused at once
  (:class:`OutputPathError`, "another hertzsweep run is writing it (pid N)").
  :meth:`OutputLock.release` removes the file. A killed run leaves the file but not the
  lock (the kernel drops it with the process); the next run takes it over. On a file
  system without ``flock`` the run goes on unlocked.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import stat
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import HertzsweepError

try:
    import fcntl
except ImportError:  # no flock on this platform: outputs are written unlocked
    fcntl = None  # type: ignore[assignment]

TEMPORARY_MARK = ".part"  # .OUT.<pid>.<8 hex>.part[suffix]
TEMPORARY = re.compile(r"^\.(?P<name>.+)\.(?P<pid>[0-9]+)\.[0-9a-f]{8}\.part(?:\..*)?$")
LOCK_PREFIX = ".hertzsweep-lock."  # .hertzsweep-lock.OUT
FIGURE_SUFFIX = ".svg"  # the longest suffix a temporary takes (a figure's format)
NAME_MAX = 255  # [bytes] of a file name where the file system does not say
LOCK_ATTEMPTS = 5  # a lock file removed between open and flock by its holder: open again
NO_LOCKING = {errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOTSUP, errno.EINVAL, errno.ENOSYS}
SPECIAL_FILES = (  # (test, what the message calls it)
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


class OutputPathError(HertzsweepError):
    """An output path a command must not write: one line naming it and why (exit 2)."""


# --------------------------------------------------------------------------- checks
def check_output(path: str | os.PathLike) -> None:
    """Refuse, before any computation, an output path that cannot hold a regular file
    written atomically (see the module docstring).

    Raises
    ------
    OutputPathError
        Empty; a folder or ending in ``/``; a special file; a symbolic link; in a folder
        that does not exist, is not a folder or is not writable; a name too long for its
        temporary.
    """
    text = os.fspath(path)
    if text == "":
        raise OutputPathError("-o '': an empty path names no file to write")
    if text.endswith(("/", os.sep)):
        raise OutputPathError(
            f"{text}: names a folder (it ends with '/'); give the file to write, e.g. {text}OUT.nc"
        )
    check_replaceable(text)
    folder = os.path.dirname(text) or "."
    if not os.path.isdir(folder):
        reason = "is not a folder" if os.path.lexists(folder) else "does not exist"
        raise OutputPathError(f"{text}: cannot write it: the folder {folder} {reason}")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise OutputPathError(f"{text}: cannot write it: the folder {folder} is not writable")
    if len(os.fsencode(temporary_name(text, FIGURE_SUFFIX).name)) > _name_max(folder):
        raise OutputPathError(f"{text}: cannot write it: its name is too long for a temporary")


def _name_max(folder: str) -> int:
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        return NAME_MAX


def check_replaceable(path: str | os.PathLike) -> None:
    """Refuse to replace what is at ``path`` unless it is a regular file (or nothing).

    Raises
    ------
    OutputPathError
        A folder, a special file (FIFO, device, socket) or a symbolic link.
    """
    text = os.fspath(path)
    try:
        mode = os.lstat(text).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return  # nothing there (a missing folder is the caller's to report)
    except OSError as exc:
        raise OutputPathError(f"{text}: cannot write it: {exc.strerror}") from None
    if stat.S_ISREG(mode):
        return
    if stat.S_ISLNK(mode):
        target = os.readlink(text)
        raise OutputPathError(
            f"{text}: is a symbolic link (to {target}); hertzsweep does not write through "
            "links: give the target itself, or remove the link"
        )
    if stat.S_ISDIR(mode):
        raise OutputPathError(f"{text}: is a folder; give the file to write, e.g. {text}/OUT.nc")
    what = next((name for test, name in SPECIAL_FILES if test(mode)), "a special file")
    raise OutputPathError(
        f"{text}: is {what}, not a regular file; hertzsweep writes only regular files"
    )


def check_not_input(path: str | os.PathLike, inputs: Iterable[str | os.PathLike]) -> None:
    """Refuse an output that is one of the run's input files (the same file by device
    and inode, or by resolved path when one of them is gone).

    Raises
    ------
    OutputPathError
        Naming the output and the input it is.
    """
    text = os.fspath(path)
    for item in inputs:
        if _same_file(text, os.fspath(item)):
            raise OutputPathError(
                f"{text}: is an input of this run ({os.fspath(item)}); writing the output "
                "there would replace it: choose another output"
            )


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


# --------------------------------------------------------------------------- the lock
class OutputLock:
    """The lock of one output (:func:`lock_output`); :meth:`release` frees it and
    removes its file. A no-op lock (``fd`` None) stands for a file system without flock."""

    def __init__(self, path: Path, fd: int | None) -> None:
        self.path = path
        self.fd = fd

    def release(self) -> None:
        """Remove the lock file (while still holding it, so no other run holds the same
        file) and drop the lock. Safe to call twice."""
        fd, self.fd = self.fd, None
        if fd is None:
            return
        with contextlib.suppress(OSError):
            if _same_inode(self.path, fd):
                os.unlink(self.path)
        os.close(fd)


def lock_path(path: str | os.PathLike) -> Path:
    """``.hertzsweep-lock.OUT`` beside the output."""
    path = Path(path)
    return path.parent / f"{LOCK_PREFIX}{path.name}"


def lock_output(path: str | os.PathLike) -> OutputLock:
    """Take the advisory lock of an output, or refuse at once (no waiting).

    Raises
    ------
    OutputPathError
        Another process holds it (its pid named), or the lock file cannot be created in
        the output's folder (the output could not be written there either).
    """
    where = lock_path(path)
    for _ in range(LOCK_ATTEMPTS):
        try:
            fd = os.open(where, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
        except OSError as exc:
            raise OutputPathError(f"{path}: cannot write it: {exc.strerror}") from None
        if fcntl is None:
            os.close(fd)
            return OutputLock(where, None)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _read_pid(fd)
            os.close(fd)
            raise OutputPathError(
                f"{path}: another hertzsweep run is writing it (pid {holder})"
            ) from None
        except OSError as exc:
            os.close(fd)
            if exc.errno in NO_LOCKING:
                return OutputLock(where, None)
            raise OutputPathError(f"{path}: cannot lock it: {exc.strerror}") from None
        if _same_inode(where, fd):  # else its holder removed it before we locked: again
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            return OutputLock(where, fd)
        os.close(fd)
    raise OutputPathError(f"{path}: cannot lock it: its lock file {where} keeps changing")


def _same_inode(path: Path, fd: int) -> bool:
    try:
        a, b = os.stat(path), os.fstat(fd)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _read_pid(fd: int) -> str:
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        text = ""
    return text if text.isdigit() else "unknown"


# --------------------------------------------------------------------------- temporaries
def temporary_name(path: str | os.PathLike, suffix: str = "") -> Path:
    """A fresh temporary name beside ``path``: ``.NAME.<pid>.<8 hex>.part[suffix]``."""
    path = Path(path)
    token = secrets.token_hex(4)
    return path.parent / f".{path.name}.{os.getpid()}.{token}{TEMPORARY_MARK}{suffix}"


def stale_temporaries(folder: str | os.PathLike, name: str | None = None) -> list[Path]:
    """The temporaries in ``folder`` (of the output ``name``, or of any) whose process is
    gone: left by a run that was killed while writing."""
    try:
        entries = os.listdir(folder)
    except OSError:
        return []
    out = []
    for entry in sorted(entries):
        match = TEMPORARY.match(entry)
        if match is None or (name is not None and match["name"] != name):
            continue
        if not _alive(int(match["pid"])):
            out.append(Path(folder) / entry)
    return out


def remove_stale_temporaries(folder: str | os.PathLike, name: str | None = None) -> list[Path]:
    """Remove the stale temporaries in ``folder`` (:func:`stale_temporaries`, of the
    output ``name`` or of any); returns those removed."""
    removed = []
    for item in stale_temporaries(folder, name):
        with contextlib.suppress(FileNotFoundError):
            item.unlink()
            removed.append(item)
    return removed


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: alive, another user's
        return True
    return True


# --------------------------------------------------------------------------- writing
@contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """A temporary name beside ``path`` (:func:`temporary_name`, created empty with the
    usual file mode): renamed to ``path`` when the block succeeds, removed when it fails,
    so the file at ``path`` is complete or absent. ``suffix`` ends the temporary's name
    (a figure's ``.png``).

    Raises
    ------
    OutputPathError
        ``path`` is a folder, a special file or a symbolic link (never replaced).
    OSError
        Creating, writing or renaming failed: the error of the OS, naming ``path``.
    """
    path = Path(path)
    check_replaceable(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = _create_temporary(path, suffix)
    except OSError as exc:  # name the output the user gave, not a temporary
        raise _naming(exc, path) from None
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        _discard(tmp)
        raise _naming(exc, path) from None
    except BaseException:
        _discard(tmp)
        raise
    _sync_folder(path.parent)


def write_file(path: str | os.PathLike, data: bytes | memoryview) -> None:
    """Write ``data`` to ``path`` (created or truncated) and flush it to the disk.

    Raises
    ------
    OSError
        The error of the OS (no space, I/O error, ...), naming ``path``.
    """
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o666)
        try:
            _write_all(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)
    except OSError as exc:
        raise _naming(exc, Path(path)) from None


def _write_all(fd: int, data: bytes | memoryview) -> None:
    """The low-level write: every byte of ``data`` to ``fd``."""
    view = memoryview(data).cast("B")
    while view:
        written = os.write(fd, view)
        view = view[written:]


def _create_temporary(path: Path, suffix: str) -> Path:
    while True:
        tmp = temporary_name(path, suffix)
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp


def _discard(tmp: Path) -> None:
    with contextlib.suppress(OSError):
        tmp.unlink(missing_ok=True)


def sync_path(path: str | os.PathLike) -> None:
    """Flush a file (or a folder's entries) to the disk: what was written to it by a
    library that does not (netCDF4's own files) before :func:`atomic_path` renames it.

    Raises
    ------
    OSError
        The error of the OS.
    """
    fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _sync_folder(folder: Path) -> None:
    """Flush the rename to the disk (best effort: not every file system can)."""
    with contextlib.suppress(OSError):
        sync_path(folder)


def _naming(exc: OSError, path: Path) -> OSError:
    """The same OS error, naming ``path``."""
    return OSError(exc.errno, exc.strerror or str(exc), str(path))


__all__ = [
    "OutputLock",
    "OutputPathError",
    "atomic_path",
    "check_not_input",
    "check_output",
    "check_replaceable",
    "lock_output",
    "lock_path",
    "remove_stale_temporaries",
    "stale_temporaries",
    "sync_path",
    "temporary_name",
    "write_file",
]


def parts_folder(output: str | os.PathLike) -> Path:
    """``OUT.parts/``: a study's file per finished (or failed) case."""
    return Path(f"{output}.parts")
