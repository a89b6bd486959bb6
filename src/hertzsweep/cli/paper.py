"""``hertzsweep paper``: the paper's figures and validation table (``make paper``)."""

from __future__ import annotations

import click

from .group import cli


@cli.command("paper")
@click.argument("config_dir", type=click.Path(exists=True, file_okay=False))
@click.argument("out_dir", type=click.Path(file_okay=False))
@click.option("--quick", is_flag=True, help="The reduced configuration (each run's 'quick').")
def paper_command(config_dir: str, out_dir: str, quick: bool) -> None:
    """The paper's Figures 3-17 and validation.md, from CONFIG_DIR/paper.toml into OUT_DIR:
    every run's dataset (OUT_DIR/NAME.nc), its figures (OUT_DIR/FIGURE.png) and the paper's
    numbers beside ours."""
    from ..api.runs import paper

    paper(config_dir, out_dir, quick, echo=click.echo)


__all__ = ["paper_command"]
