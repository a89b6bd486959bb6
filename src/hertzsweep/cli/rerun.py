"""``hertzsweep rerun IN.nc -o OUT.nc [--set k=v]``: run again the command that made a
dataset, from the dataset alone.

Every dataset holds its whole resolved configuration (``config_json``: a scene's tables,
or a study's grid and resolved base scene) and the command's own arguments
(``command_json``: trace's frequency, periods, branch and samples; accuracy's ladder and
target). ``rerun`` rebuilds the scene (or study) from them, applies ``--set`` overrides
as the original command would have, runs the same driver and writes a dataset of the same
kind: without overrides its data variables equal the original's bit for bit, except the
accuracy dataset's ``wall_time``, a measurement of the machine. The scene files the
dataset was made from are not read (they may have changed or be gone).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping
from typing import Any

import click

from ..core.config import apply_override, parse_override, scene_from_dict
from ..core.model import check_stability
from ..errors import ConfigError, HertzsweepError
from ..output.kinds import STUDY, Kind, kind_of
from . import options
from .group import cli
from .progress import progress_bar

WORKERS_HELP = "Local worker processes for a study (default: the number of cores)."


@cli.command("rerun")
@click.argument("input_file", metavar="IN.nc", type=click.Path(exists=True, dir_okay=False))
@options.output_option
@options.set_option
@click.option("--workers", type=click.IntRange(min=1), default=None, help=WORKERS_HELP)
@options.quiet_option
def rerun_command(
    input_file: str,
    output: str,
    overrides: tuple[str, ...],
    workers: int | None,
    quiet: bool,
) -> None:
    """Run again the command that made IN.nc (sweep, trace, branch, study, accuracy) from
    its config_json and command_json, with --set overrides applied; OUT.nc is a dataset of
    the same kind (without overrides, the same data bit for bit)."""
    ds = options.read_attributes(input_file)  # its record of how it was made: no data
    options.claim_output(output, (input_file,))
    try:
        kind = kind_of(ds)
    except HertzsweepError as exc:
        raise exc.with_context(input_file) from None
    run = RUNNERS.get(kind.name)
    if run is None and kind.source != STUDY:  # not made by a simulation: nothing to rerun
        known = ", ".join([*RUNNERS, "study"])
        raise HertzsweepError(f"{input_file}: cannot rerun a {kind.name} dataset ({known} only)")
    config = json_attribute(ds.attrs, "config_json", input_file)
    command = json_attribute(ds.attrs, "command_json", input_file)
    source = f"{os.path.abspath(input_file)}:config_json"
    if run is None:
        _rerun_study(kind, config, overrides, source, output, workers, quiet)
        return
    scene = scene_of(config, overrides, source)
    if kind.name == "trace" and _trace_streams(scene, command):
        options.write_streamed(
            kind, scene, output, lambda sink: run(kind, scene, command, not quiet, sink)
        )
        return
    result = run(kind, scene, command, not quiet)
    options.write_result(kind, result, scene, output)


# --------------------------------------------------------------------------- reading
def json_attribute(attributes: Mapping[str, Any], name: str, path: str) -> dict[str, Any]:
    """A global attribute holding a JSON object.

    Raises
    ------
    HertzsweepError
        The attribute is missing (a dataset made before it was recorded) or is not a JSON
        object.
    """
    text = attributes.get(name)
    if not isinstance(text, str):
        raise HertzsweepError(
            f"{path}: no {name} attribute (a dataset made by an older hertzsweep): "
            "it cannot be rerun"
        )
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise HertzsweepError(f"{path}: {name} is not valid JSON ({exc})") from None
    if not isinstance(value, dict):
        raise HertzsweepError(f"{path}: {name} is not a JSON object")
    return value


def overridden(raw: dict[str, Any], overrides: tuple[str, ...]) -> set[str]:
    """Apply ``--set table.key=value`` overrides to raw scene tables, in place; returns
    the keys set."""
    keys = set()
    for text in overrides:
        key, value = parse_override(text)
        apply_override(raw, key, value)
        keys.add(key)
    return keys


def scene_of(config: dict[str, Any], overrides: tuple[str, ...], source: str):
    """The scene of a dataset's ``config_json`` with ``--set`` overrides, checked as a
    scene file is (a bad override is named as ``--set``)."""
    keys = overridden(config, overrides)
    try:
        return scene_from_dict(config, source=source)
    except ConfigError as exc:
        if exc.key in keys:
            raise ConfigError("--set", exc.key, exc.reason) from None
        raise


# --------------------------------------------------------------------------- scene kinds
def _rerun_sweep(kind: Kind, scene, command: dict[str, Any], bar: bool) -> Any:
    from ..drivers.sweep import dwell_count

    with progress_bar(dwell_count(scene), "sweep", bar) as progress:
        return kind.run(scene, progress)


def _trace_streams(scene, command: dict[str, Any]) -> bool:
    """Whether the trace's record streams to its file (:func:`~hertzsweep.core.checks.
    check_record`, which also refuses a record beyond the budgets, as ``trace`` does)."""
    from ..core.checks import check_record

    arguments = (int(command["periods"]), command.get("samples_per_period"))
    return check_record(scene, *arguments, source="rerun")


def _rerun_trace(kind: Kind, scene, command: dict[str, Any], bar: bool, sink=None) -> Any:
    from ..drivers.trace import trace_count

    w = float(command["frequency_ratio"])
    branch = str(command["branch"])
    arguments = {
        "periods": int(command["periods"]),
        "branch": branch,
        "samples_per_period": command.get("samples_per_period"),
    }
    with progress_bar(trace_count(scene, w, branch), "trace", bar) as progress:
        return kind.run(scene, w, progress=progress, sink=sink, **arguments)


def _rerun_branch(kind: Kind, scene, command: dict[str, Any], bar: bool) -> Any:
    from ..drivers.continuation import progress_total

    with progress_bar(progress_total(scene), "branch", bar, unit="%") as progress:
        return kind.run(scene, progress)


def _rerun_accuracy(kind: Kind, scene, command: dict[str, Any], bar: bool) -> Any:
    """The ladder that ran (its settings, reference last) on the scene, with its
    Richardson partner (the reference at half its steps, when it ran) and the scene's own
    setting re-derived from the scene."""
    from dataclasses import replace

    from ..drivers.accuracy import Ladder, Setting

    check_stability(scene)
    settings = tuple(Setting(**setting) for setting in command["settings"])
    reference = settings[-1]
    partner = replace(reference, steps_per_period=reference.steps_per_period // 2)
    ladder = Ladder(
        settings=settings,
        reference=reference,
        partner=partner if partner in settings else None,
        scene_setting=Setting.of_scene(scene),
    )
    target = command.get("target")
    with progress_bar(len(settings), "accuracy", bar, unit="setting") as progress:
        return kind.run(scene, ladder, target, progress)


Runner = Callable[[Kind, Any, dict[str, Any], bool], Any]
RUNNERS: dict[str, Runner] = {  # kind -> how to run its driver from command_json
    "sweep": _rerun_sweep,
    "trace": _rerun_trace,
    "branch": _rerun_branch,
    "accuracy": _rerun_accuracy,
}


# --------------------------------------------------------------------------- studies
def study_of(config: dict[str, Any], overrides: tuple[str, ...], source: str):
    """The study of a study dataset's ``config_json`` (``kind``, ``split_sigma``,
    ``grid`` and the resolved base ``scene``), the overrides applied to its base scene."""
    from ..drivers.study import GridAxis, Study, dimension_name
    from ..output.kinds import STUDY_KINDS

    try:
        base = dict(config["scene"])
        study_kind = config["kind"]
        grid = config["grid"]
        split_sigma = bool(config.get("split_sigma", False))
    except (KeyError, TypeError) as exc:
        raise HertzsweepError(f"{source}: not a study's configuration ({exc})") from None
    if study_kind not in STUDY_KINDS:
        raise ConfigError(source, "kind", f"expected one of {', '.join(STUDY_KINDS)}")
    scene_of(base, overrides, source)  # the base scene must be valid
    axes = tuple(GridAxis(key, dimension_name(key), tuple(values)) for key, values in grid.items())
    return Study(source=source, kind=study_kind, base=base, grid=axes, split_sigma=split_sigma)


def _rerun_study(
    kind: Kind,
    config: dict[str, Any],
    overrides: tuple[str, ...],
    source: str,
    output: str,
    workers: int | None,
    quiet: bool,
) -> None:
    """The study's cases on a local pool, into ``OUT.parts/``, then ONE dataset, as
    ``hertzsweep study`` does (exit status 1 when cases failed)."""
    from ..drivers.study import LocalPool, expand
    from ..output.dataset import history_line
    from .study import conclude

    study = study_of(config, overrides, source)
    cases = expand(study)
    history = history_line()
    engine = LocalPool(workers)
    try:
        with progress_bar(len(cases), "study", not quiet, unit="case") as progress:
            run = kind.run(study, cases, output, engine, history=history, progress=progress)
    finally:
        engine.close()
    conclude(kind, study, cases, output, history, run, engine)


__all__ = ["RUNNERS", "json_attribute", "rerun_command", "scene_of", "study_of"]
