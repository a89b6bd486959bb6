"""``hertzsweep bench``: the project's own speed figures."""

from __future__ import annotations

import json

import click

from .group import cli


@cli.command("bench")
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option("--quick", is_flag=True, help="Smaller runs (a smoke check, noisier figures).")
def bench_command(as_json: bool, quick: bool) -> None:
    """Speed figures: ns per step, a 121-point sweep, the ratio to solve_ivp."""
    from ..drivers.bench import run_all

    figures = run_all(quick=quick)
    if as_json:
        click.echo(json.dumps(figures, indent=2))
        return
    for key, value in figures.items():
        text = f"{value:.4g}" if isinstance(value, float) else str(value)
        click.echo(f"{key:44s} {text}")
