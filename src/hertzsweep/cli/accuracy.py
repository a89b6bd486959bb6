"""``hertzsweep accuracy``: error against cost for the solver settings of a scene."""

from __future__ import annotations

import shlex

import click

from ..core.model import check_stability
from ..drivers.accuracy import build_ladder, parse_methods, parse_settle_list, parse_steps
from ..output.kinds import KINDS
from . import options
from .group import cli
from .progress import progress_bar

ACCURACY = KINDS["accuracy"]
TARGET_HELP = (
    "Recommend the fastest setting (wall time) whose H1 error (relative to the largest H1) "
    "is at most TOL."
)
STEPS_HELP = (
    "Steps per period of every method's rungs (default: central-difference 32,64,...,2048, "
    "rk4 16,...,256); the most accurate method's largest is the reference's."
)
METHODS_HELP = "Integration methods on the ladder (default: every one: central-difference,rk4)."
SETTLE_HELP = (
    "Settling rungs: periods, 'auto' or 'auto:TOL' (default 50,100,300,1000,auto:1e-2,...,"
    "auto:1e-6); the longest fixed one is the reference's."
)
QUICK_HELP = (
    "Fewer rungs (central-difference N 64..1024, rk4 32..128, settle 100,300,1000, "
    "auto:1e-3, auto:1e-5)."
)


@cli.command("accuracy")
@options.scene_argument
@options.output_option
@options.set_option
@click.option(
    "--target",
    type=click.FloatRange(min=0.0, min_open=True),
    default=None,
    metavar="TOL",
    help=TARGET_HELP,
)
@click.option("--steps", "steps_text", default=None, metavar="N,N,...", help=STEPS_HELP)
@click.option("--settle", "settle_text", default=None, metavar="P,...,auto:TOL", help=SETTLE_HELP)
@click.option("--methods", "methods_text", default=None, metavar="M,M", help=METHODS_HELP)
@click.option("--quick", is_flag=True, help=QUICK_HELP)
@options.quiet_option
def accuracy_command(
    scene_file: str,
    output: str,
    overrides: tuple[str, ...],
    target: float | None,
    steps_text: str | None,
    settle_text: str | None,
    methods_text: str | None,
    quick: bool,
    quiet: bool,
) -> None:
    """Error against cost for the solver settings: the speed/accuracy trade.

    Runs the scene's sweep over a ladder of settings (integration method; steps per
    period; fixed and auto settling; settle vs shooting), measures each against the
    reference (the most accurate method's finest setting, checked by Richardson
    extrapolation) in H1, H2, force extremes and jump frequencies, prints the table, the
    observed order and the Pareto front of wall time against error.
    """
    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, scene.inputs)
    check_stability(scene)
    steps = parse_steps(steps_text) if steps_text is not None else None
    settle = parse_settle_list(settle_text) if settle_text is not None else None
    methods = parse_methods(methods_text) if methods_text is not None else None
    ladder = build_ladder(scene, steps, settle, quick, methods=methods)
    with progress_bar(len(ladder.settings), "accuracy", not quiet, unit="setting") as progress:
        report = ACCURACY.run(scene, ladder, target, progress)
    report.scene_arguments = shlex.join([scene_file, *(f"--set={item}" for item in overrides)])
    options.write_result(ACCURACY, report, scene, output)


__all__ = ["accuracy_command"]
