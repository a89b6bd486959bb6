"""The click group every command registers on (``@cli.command(...)``)."""

from __future__ import annotations

import click

from .. import __version__


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="hertzsweep")
def cli() -> None:
    """Simulated stepped-sine vibration tests of a preloaded Hertzian contact
    (Rigaud & Perret-Liaudet): sweeps, time histories, periodic branches, studies."""


__all__ = ["cli"]
