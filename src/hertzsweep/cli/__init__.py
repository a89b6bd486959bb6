"""The command line. Only this package opens and writes files, and only here do
errors a user can cause become one line on stderr and exit status 2.

Each command lives in a submodule that registers itself on :data:`main`'s group.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Sequence

import click

from .. import __version__
from ..errors import HertzsweepError, Interrupted

EXIT_USAGE = 2  # bad file, key, value or setting (and click's usage errors)
EXIT_INTERRUPTED = 130  # SIGINT, as a shell reports it


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="hertzsweep")
def cli() -> None:
    """Simulated stepped-sine vibration tests of a preloaded Hertzian contact
    (Rigaud & Perret-Liaudet): sweeps, time histories, periodic branches, studies."""


def fail(message: str, status: int = EXIT_USAGE) -> None:
    click.echo(f"hertzsweep: error: {message}", err=True)
    sys.exit(status)


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point: run the group; every user error ends in one line and exit 2."""
    from . import commands  # noqa: F401  (registers the core commands)

    _register_optional()
    signal.signal(signal.SIGTERM, _terminate)
    try:
        cli.main(args=list(argv) if argv is not None else None, standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.exceptions.Abort as exc:  # click wraps KeyboardInterrupt in Abort
        cause = exc.__cause__
        fail("interrupted", 128 + cause.signal_number if isinstance(cause, Interrupted)
             else EXIT_INTERRUPTED)  # fmt: skip
    except click.ClickException as exc:
        fail(exc.format_message().replace("\n", " "), exc.exit_code)
    except HertzsweepError as exc:
        fail(str(exc))
    except OSError as exc:  # a file that cannot be read or written: no traceback
        where = f"{exc.filename}: " if exc.filename else ""
        fail(f"{where}{exc.strerror or exc}")
    except Interrupted as exc:
        fail("interrupted", 128 + exc.signal_number)
    except KeyboardInterrupt:
        fail("interrupted", EXIT_INTERRUPTED)


def _terminate(signal_number: int, frame: object) -> None:
    """SIGTERM ends a run like SIGINT: what is finished is kept."""
    raise Interrupted(None, signal_number)


def _register_optional() -> None:
    """Import the feature command modules that exist (each registers its command)."""
    import importlib

    for name in ("trace", "branch", "study", "accuracy", "plot", "bench"):
        try:
            importlib.import_module(f"{__name__}.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
