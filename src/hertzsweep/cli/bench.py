"""``hertzsweep bench``: the project's own speed figures."""

from __future__ import annotations

import json
import math
from typing import Any

import click

from .group import cli


@cli.command("bench")
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option("--quick", is_flag=True, help="Smaller runs (a smoke check, noisier figures).")
def bench_command(as_json: bool, quick: bool) -> None:
    """Speed figures: ns per step, a 121-point sweep, time per dwell at equal accuracy."""
    from ..api.runs import bench

    figures = bench(quick)
    if as_json:
        click.echo(json.dumps(figures, indent=2))
        return
    for key, value in figures.items():
        if isinstance(value, list):
            continue
        text = f"{value:.4g}" if isinstance(value, float) else str(value)
        click.echo(f"{key:44s} {text}")
    references = figures.get("equal_accuracy_references", [])
    rows = figures.get("equal_accuracy", [])
    for line in equal_accuracy_lines(references, rows):
        click.echo(line)


def _number(value: float | None, spec: str = ".2e") -> str:
    return "-" if value is None else format(value, spec)


def _digits3(value: float | None) -> str:
    """Three significant digits in fixed notation (0.709, 1.35, 10.0, 794)."""
    if value is None:
        return "-"
    decimals = max(0, 2 - math.floor(math.log10(abs(value)))) if value else 2
    return f"{value:.{decimals}f}"


def equal_accuracy_lines(references: list[dict[str, Any]], rows: list[dict[str, Any]]) -> list[str]:
    """The comparison at equal accuracy as two Markdown tables: each dwell's reference with
    its two checks, then each method at the loosest setting meeting each target."""
    if not rows:
        return []
    lines = [
        "",
        "Equal accuracy: one dwell from rest (300 settling + 20 measured periods); each method",
        "at the loosest setting of its ladder with |H1 - H1_ref| <= target (and the next",
        "tighter setting within it too); rtol = atol for the adaptive methods; ms per dwell,",
        "best of a few; x CD: that time over hertzsweep's central difference at the same target.",
        "",
        "| dwell | H1 reference (DOP853 rtol 1e-13) | its time s | dense-output DFT - ref "
        "| central difference Richardson - ref |",
        "|---|---|---|---|---|",
    ]
    for ref in references:
        steps = ref["richardson_steps"]
        lines.append(
            f"| {ref['scene']} | {ref['h1']:.12f} | {ref['seconds']:.1f} "
            f"| {ref['dense_difference']:.1e} | {ref['richardson_difference']:.1e} "
            f"(N {steps} + {2 * steps}) |"
        )
    lines += [
        "",
        "| dwell | target | method | setting | error | next looser: error | ms/dwell | x CD |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        looser = "-" if row["looser"] is None else f"{row['looser']}: {row['looser_error']:.1e}"
        lines.append(
            f"| {row['scene']} | {row['target']:.0e} | {row['method']} | {row['setting']} "
            f"| {_number(row['error'], '.1e')} | {looser} | {_digits3(row['ms_per_dwell'])} "
            f"| {_digits3(row['ratio_to_central_difference'])} |"
        )
    return lines
