"""``hertzsweep import FILE.csv -o OUT.nc``: measurements into a ``measured`` dataset.

(The command is ``import``; a Python module cannot be named so.)
"""

from __future__ import annotations

import click

from . import options
from .group import cli


@cli.command("import")
@click.argument("csv_file", metavar="FILE.csv", type=click.Path(dir_okay=False))
@options.output_option
def import_command(csv_file: str, output: str) -> None:
    """Measured sweeps (columns direction,sigma,frequency,amplitude,phase[,harmonic]) or
    jump frequencies (direction,sigma,jump_frequency) into a dataset of kind measured:
    the sweep layout, NaN where not measured. A bad file ends with one line naming the
    file, the line and the column (exit 2)."""
    from ..api.runs import run_import

    options.claim_output(output, (csv_file,))
    options.write_run(run_import(csv_file), output)


__all__ = ["import_command"]
