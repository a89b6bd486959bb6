"""``hertzsweep compare RUN.nc REFERENCE.nc``: a run against a reference dataset (for CI).

Exit status: 0 when the run is within tolerance of the reference; 1 when it is not (a
coordinate mismatch, a variable outside tolerance or missing); 2 for a usage error (a
file missing or unreadable, datasets of different kinds, an unknown ``--var`` variable).
The tolerances are :data:`hertzsweep.output.compare.TOLERANCES`.
"""

from __future__ import annotations

import click

from ..errors import Failed
from .group import cli


@cli.command("compare")
@click.argument("run_file", metavar="RUN.nc", type=click.Path(dir_okay=False))
@click.argument("reference_file", metavar="REFERENCE.nc", type=click.Path(dir_okay=False))
@click.option(
    "--rtol",
    type=float,
    default=None,
    metavar="R",
    help="Relative tolerance of the variables compared relatively (amplitudes, forces, "
    "times; default 1e-6).",
)
@click.option(
    "--atol",
    type=float,
    default=None,
    metavar="A",
    help="Absolute tolerance of the same variables, in their units (default 1e-10 in "
    "units of F_s, 1e-12 s).",
)
@click.option(
    "--var",
    "var_tolerances",
    multiple=True,
    metavar="NAME=RTOL[,ATOL]",
    help="Tolerance of one variable: |run - reference| <= ATOL + RTOL |reference| "
    "(phases: the difference wrapped; ATOL omitted keeps its default); repeatable.",
)
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def compare_command(
    run_file: str,
    reference_file: str,
    rtol: float | None,
    atol: float | None,
    var_tolerances: tuple[str, ...],
    as_json: bool,
) -> None:
    """Compare RUN.nc with REFERENCE.nc: the same kind, dimensions and coordinates, every
    data variable within tolerance. Exit 0 when within tolerance, 1 when not, 2 on a usage
    error. Amplitudes are relative, phases absolute in degrees with wrap-around, jump
    frequencies within one grid step, flags and strings exact; configuration differences
    are listed."""
    from ..api import compare
    from ..api.runs import parse_variable_tolerances

    variables = parse_variable_tolerances(var_tolerances)
    result = compare(run_file, reference_file, rtol=rtol, atol=atol, variables=variables)
    click.echo(result.report.to_json() if as_json else result.text)
    if not result.ok:  # exit status 1
        raise Failed(f"{run_file} is outside tolerance of {reference_file}")
