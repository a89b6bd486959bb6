"""``hertzsweep accuracy``: error against cost for the solver settings of a scene."""

from __future__ import annotations

import shlex

import click

from . import options
from .group import cli

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
    from ..api.runs import accuracy_ladder, check_accuracy, run_accuracy

    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, scene.inputs)
    check_accuracy(scene)
    ladder = accuracy_ladder(scene, steps_text, settle_text, methods_text, quick)
    arguments = shlex.join([scene_file, *(f"--set={item}" for item in overrides)])
    run = run_accuracy(scene, ladder, target, options.progress(quiet), scene_arguments=arguments)
    options.write_run(run, output)


__all__ = ["accuracy_command"]
