"""``hertzsweep accuracy``: error against cost for the solver settings of a scene."""

from __future__ import annotations

import math

import click

from ..core.model import check_stability
from ..drivers.accuracy import (
    AccuracyReport,
    build_ladder,
    parse_settle_list,
    parse_steps,
    run_ladder,
)
from ..drivers.accuracy import assess as assess_ladder
from ..output.dataset import accuracy_dataset, write_atomic
from . import cli
from .options import output_option, quiet_option, read_scene, scene_argument, set_option
from .progress import progress_bar


@cli.command("accuracy")
@scene_argument
@output_option
@set_option
@click.option(
    "--target",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    metavar="TOL",
    help="Recommend the cheapest setting whose H1 error (relative to the largest H1) "
    "is at most TOL.",
)
@click.option("--steps", "steps_text", default=None, metavar="N,N,...",
              help="Steps per period of the ladder (default 32,64,...,2048); the largest "
                   "is the reference's.")  # fmt: skip
@click.option("--settle", "settle_text", default=None, metavar="P,...,auto:TOL",
              help="Settling rungs: periods, 'auto' or 'auto:TOL' (default "
                   "50,100,300,1000,auto:1e-2,...,auto:1e-6); the longest fixed one is the "
                   "reference's.")  # fmt: skip
@click.option("--quick", is_flag=True, help="Fewer rungs (N 64..1024, settle 100,300,1000, "
              "auto:1e-3, auto:1e-5).")  # fmt: skip
@quiet_option
def accuracy_command(
    scene_file: str,
    output: str,
    overrides: tuple[str, ...],
    target: float | None,
    steps_text: str | None,
    settle_text: str | None,
    quick: bool,
    quiet: bool,
) -> None:
    """Error against cost for the solver settings: the speed/accuracy trade.

    Runs the scene's sweep over a ladder of settings (steps per period; fixed and auto
    settling; settle vs shooting), measures each against the reference (the finest
    setting, checked by Richardson extrapolation) in H1, H2, force extremes and jump
    frequencies, prints the table, the observed order and the Pareto front.
    """
    scene = read_scene(scene_file, overrides)
    check_stability(scene)
    steps = parse_steps(steps_text) if steps_text is not None else None
    settle = parse_settle_list(settle_text) if settle_text is not None else None
    ladder = build_ladder(scene, steps, settle, quick)
    with progress_bar(len(ladder.settings), "accuracy", not quiet, unit="setting") as progress:
        rungs, failures = run_ladder(scene, ladder, progress)
    report = assess_ladder(rungs, ladder, target, failures)
    write_atomic(accuracy_dataset(report, scene), output)
    click.echo(format_report(report))
    click.echo(f"wrote {output}")


def _number(x: float, spec: str = ".2e") -> str:
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "missed"
    return format(x, spec)


def format_report(report: AccuracyReport) -> str:
    """The table, the reference check, the observed order, the Pareto front and the
    recommendation, as printed by the command."""
    head = (f"{'setting':24s} {'err H1':>9s} {'err H2':>9s} {'err N':>9s} {'err jump':>8s} "
            f"{'steps':>11s} {'wall s':>7s} {'order':>5s}  pareto")  # fmt: skip
    lines = [head]
    scene_index = report.index(report.scene_setting)
    for i, (rung, err) in enumerate(zip(report.rungs, report.errors, strict=True)):
        mark = "*" if report.pareto[i] else ""
        if i == len(report.rungs) - 1:
            mark += " reference"
        if i == scene_index:
            mark += " scene"
        if i == report.recommended:
            mark += " recommended"
        lines.append(
            f"{rung.setting.label:24s} {_number(err.h1):>9s} {_number(err.h2):>9s} "
            f"{_number(err.force):>9s} {_number(err.jump, '.4f'):>8s} {rung.cost_steps:11d} "
            f"{rung.wall_time:7.2f} {_number(report.orders[i], '.2f'):>5s}  {mark.strip()}"
        )
    lines.append("")
    lines.append("errors against the reference: H1, H2 max abs over the sweep relative to its")
    lines.append("largest H1, H2; N: force extremes in F_s; jump: |w - w_ref| (missed: one jumped)")
    ref = report.reference.setting.label
    if report.reference_error is not None:
        e = report.reference_error
        lines.append(
            f"reference {ref}: Richardson estimate of its own error (order 2): "
            f"H1 {_number(e.h1)}, H2 {_number(e.h2)}, N {_number(e.force)}"
            + ("" if e.jump == 0 else f", jumps differ by {_number(e.jump, '.4f')}")
        )
    if report.settle_check is not None:
        lines.append(
            f"settling check: {report.settle_check_label} differs from the reference by "
            f"H1 {_number(report.settle_check.h1)}"
        )
    order = _number(report.observed_order, ".2f")
    lines.append(f"observed order (steps axis, finest triple N, 2N, 4N): {order}")
    front = sorted(
        (r.cost_steps, r.setting.label)
        for r, on in zip(report.rungs, report.pareto, strict=True)
        if on
    )
    lines.append("Pareto front (steps, err H1), cheapest first: " + ", ".join(f[1] for f in front))
    if report.target is not None:
        lines.append(_recommendation(report))
    for note in report.notes:
        lines.append(f"note: {note}")
    return "\n".join(lines)


def _recommendation(report: AccuracyReport) -> str:
    target = report.target
    if report.recommended is None:
        return f"target {target:g} on H1: no setting of the ladder meets it; refine --steps"
    rung = report.rungs[report.recommended]
    err = report.errors[report.recommended]
    text = (f"target {target:g} on H1 (max abs error relative to the largest H1, against the "
            f"reference): recommended {rung.setting.label}, error {err.h1:.2e}, "
            f"{rung.cost_steps} steps")  # fmt: skip
    scene_index = report.index(report.scene_setting)
    if scene_index is not None:
        scene_rung = report.rungs[scene_index]
        ratio = rung.cost_steps / scene_rung.cost_steps
        text += (f" ({ratio:.2f}x the scene's {scene_rung.setting.label}, whose error is "
                 f"{report.errors[scene_index].h1:.2e})")  # fmt: skip
    return text
