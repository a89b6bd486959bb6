"""The command line. Only the output layer and this package write files, and only here
(:func:`main`) do exceptions become one line on stderr and an exit status:

- :class:`~hertzsweep.errors.HertzsweepError`, click's usage errors, a file that cannot
  be read or written: 2;
- :class:`~hertzsweep.errors.Failed`: 1;
- :class:`~hertzsweep.errors.Stopped`, :class:`~hertzsweep.errors.Interrupted`, SIGINT:
  128 + the signal number (130 for SIGINT, 143 for SIGTERM).

Each command lives in a submodule that registers itself on the group
(:mod:`hertzsweep.cli.group`).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence

import click

from ..errors import Failed, HertzsweepError, Interrupted, Stopped
from . import signals
from .group import cli

EXIT_USAGE = 2  # bad file, key, value or setting (and click's usage errors)
EXIT_FAILED = 1  # the command ran and reports a failure (a study case failed, ...)
EXIT_INTERRUPTED = 130  # SIGINT, as a shell reports it


def fail(message: str, status: int = EXIT_USAGE) -> None:
    click.echo(f"hertzsweep: error: {message}", err=True)
    sys.exit(status)


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point: run the group; every error ends in one line and its exit status.

    Called with ``argv`` (tests, scripts), it returns or raises ``SystemExit`` as usual.
    As the ``hertzsweep`` program (``argv`` None), once the command has finished and its
    output is written and closed, the process ends at once: the interpreter's teardown
    (finalising numba, xarray, netCDF4 and their caches: about 0.6 s) does no work a
    finished command needs.
    """
    if argv is not None:
        _run(argv)
        return
    try:
        _run(None)
        status = 0
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def _run(argv: Sequence[str] | None) -> None:
    """Run the group on ``argv`` and map every exception to its message and exit status."""
    signals.install()
    if not (sys.argv[1:] if argv is None else argv):  # bare: the usage and the commands
        with click.Context(cli, info_name="hertzsweep") as ctx:
            click.echo(cli.get_help(ctx), err=True)
        sys.exit(EXIT_USAGE)
    try:
        cli.main(args=list(argv) if argv is not None else None, standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.exceptions.Abort as exc:  # click wraps KeyboardInterrupt in Abort
        fail("interrupted", _interrupted_status(exc.__cause__))
    except click.ClickException as exc:
        fail(exc.format_message().replace("\n", " "), exc.exit_code)
    except HertzsweepError as exc:
        fail(str(exc))
    except Failed as exc:
        fail(str(exc), EXIT_FAILED)
    except Stopped as exc:
        fail(str(exc), 128 + exc.signal_number)
    except OSError as exc:  # a file that cannot be read or written: no traceback
        where = f"{exc.filename}: " if exc.filename else ""
        fail(f"{where}{exc.strerror or exc}")
    except KeyboardInterrupt as exc:
        fail("interrupted", _interrupted_status(exc))


def _interrupted_status(exc: BaseException | None) -> int:
    """128 + the signal that stopped a run (SIGINT when not known)."""
    return 128 + exc.signal_number if isinstance(exc, Interrupted) else EXIT_INTERRUPTED
