"""The click group every command registers on (``@cli.command(...)``), loading each
command's module only when that command runs.

:data:`COMMANDS` is the one list of commands: the module that defines each and the line
``hertzsweep --help`` shows for it (a dataset kind's from its registry entry). Listing the
commands (``--help``) imports none of them, and a command imports only its own module, so
``hertzsweep rig`` never loads the compiler, xarray or matplotlib, and ``hertzsweep sweep``
never loads matplotlib or dask.
"""

from __future__ import annotations

import difflib
import importlib

import click

from .. import __version__
from ..api.choices import KINDS

TOOLS: dict[str, tuple[str, str]] = {  # the commands that make no dataset kind of their own
    "rig": ("commands", "Derived constants of a rig, or of a scene's rig."),
    "validate": ("commands", "Check a scene: exit 0, or one line naming file, key, reason."),
    "plot": ("plot", "The paper-style figure of any dataset."),
    "compare": ("compare", "A run against a reference dataset (exit 1 outside tolerance)."),
    "paper": ("paper", "The paper's figures and validation table."),
    "rerun": ("rerun", "Run again the command that made a dataset, from the dataset."),
    "export": ("importing", "A dataset as UFF 58/58b or CSV, for the tools rigs use."),
    "bench": ("bench", "The project's own speed figures."),
}
ORDER = (  # of ``hertzsweep --help``
    "rig", "validate", "sweep", "random", "trace", "branch", "study", "accuracy", "plot",
    "compare", "paper", "rerun", "import", "export", "fit", "bench",
)  # fmt: skip
COMMANDS: dict[str, tuple[str, str]] = {  # name -> (module in hertzsweep.cli, help line)
    **TOOLS,
    **{kind.command: (kind.cli_module, kind.help) for kind in KINDS.values()},
}
COMMANDS = {name: COMMANDS[name] for name in ORDER}
"""Every command: the tools, and the command of each dataset kind
(:data:`hertzsweep.core.kinds.KINDS`), in the order of :data:`ORDER`."""


class LazyGroup(click.Group):
    """A group whose commands are imported on first use (see :data:`COMMANDS`)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in self.commands and name in COMMANDS:
            importlib.import_module(f"{__package__}.{COMMANDS[name][0]}")  # registers it
        return self.commands.get(name)

    def resolve_command(self, ctx: click.Context, args: list[str]) -> tuple:
        """The command named by ``args[0]``; an unknown name is refused with the nearest
        commands (``hertzsweep swep``: did you mean sweep?)."""
        name = args[0]
        if name not in COMMANDS and not name.startswith("-"):
            near = difflib.get_close_matches(name, list(COMMANDS), n=3, cutoff=0.6)
            options = ", ".join(near[:-1]) + " or " + near[-1] if len(near) > 1 else "".join(near)
            hint = f"; did you mean {options}?" if near else ""
            raise click.UsageError(f"no command {name!r}{hint} (hertzsweep --help lists them)")
        return super().resolve_command(ctx, args)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The command list of ``--help`` from :data:`COMMANDS`, importing nothing."""
        with formatter.section("Commands"):
            formatter.write_dl([(name, line) for name, (_, line) in COMMANDS.items()])


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="hertzsweep")
def cli() -> None:
    """Simulated stepped-sine vibration tests of a preloaded Hertzian contact
    (Rigaud & Perret-Liaudet): sweeps, time histories, periodic branches, studies."""


__all__ = ["COMMANDS", "LazyGroup", "cli"]
