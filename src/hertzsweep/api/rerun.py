"""Running again the command that made a dataset, from the dataset alone
(``hertzsweep rerun``).

Every dataset holds its whole resolved configuration (``config_json``: a scene's tables,
or a study's grid and resolved base scene) and the command's own arguments
(``command_json``: trace's frequency, periods, branch and samples; accuracy's ladder and
target). The scene (or study) is rebuilt from them, overrides applied as the original
command would have, and the same driver runs: without overrides the data variables equal
the original's bit for bit, except the accuracy dataset's ``wall_time``, a measurement of
the machine. The scene files the dataset was made from are not read (they may have
changed or be gone).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

from ..core.config import Scene, apply_overrides, from_command_line, scene_from_dict
from ..core.kinds import KINDS, RERUN_KINDS, STUDY, STUDY_KINDS, kind_named
from ..errors import ConfigError, HertzsweepError
from .runs import (
    Progress,
    Run,
    check_trace,
    run_accuracy,
    run_branch,
    run_random,
    run_sweep,
    run_trace,
)


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


def scene_of(config: dict[str, Any], overrides: Mapping[str, Any], source: str) -> Scene:
    """The scene of a dataset's ``config_json`` with overrides, checked as a scene file
    is (a bad override is named as ``--set``)."""
    keys = apply_overrides(config, overrides)
    try:
        scene = scene_from_dict(config, source=source)
    except ConfigError as exc:
        raise from_command_line(exc, keys) from None
    return replace(scene, overridden=keys)


# --------------------------------------------------------------------------- scene kinds
def rerun_sweep(scene: Scene, command: dict[str, Any], progress: Progress, sink: Any) -> Run:
    return run_sweep(scene, progress)


def trace_streams(scene: Scene, command: dict[str, Any]) -> bool:
    """Whether a rerun trace's record streams to its file (and the record within the
    budgets, as ``trace`` checks it)."""
    arguments = (int(command["periods"]), command.get("samples_per_period"))
    return check_trace(scene, *arguments, source="rerun")


def rerun_trace(scene: Scene, command: dict[str, Any], progress: Progress, sink: Any) -> Run:
    w = float(command["frequency_ratio"])
    periods, branch = int(command["periods"]), str(command["branch"])
    samples = command.get("samples_per_period")
    return run_trace(scene, w, periods, branch, samples, progress, sink=sink)


def rerun_branch(scene: Scene, command: dict[str, Any], progress: Progress, sink: Any) -> Run:
    return run_branch(scene, progress)


def rerun_random(scene: Scene, command: dict[str, Any], progress: Progress, sink: Any) -> Run:
    return run_random(scene, progress)


def rerun_accuracy(scene: Scene, command: dict[str, Any], progress: Progress, sink: Any) -> Run:
    """The ladder that ran (its settings, reference last) on the scene, with its
    Richardson partner (the reference at half its steps, when it ran) and the scene's own
    setting re-derived from the scene."""
    from ..drivers.accuracy import Ladder, Setting

    settings = tuple(Setting(**setting) for setting in command["settings"])
    reference = settings[-1]
    partner = replace(reference, steps_per_period=reference.steps_per_period // 2)
    ladder = Ladder(
        settings=settings,
        reference=reference,
        partner=partner if partner in settings else None,
        scene_setting=Setting.of_scene(scene),
    )
    return run_accuracy(scene, ladder, command.get("target"), progress)


Runner = Callable[[Scene, dict[str, Any], Progress, Any], Run]
RUNNERS: dict[str, Runner] = {name: KINDS[name].rerun for name in RERUN_KINDS}
"""kind -> how to run its driver from ``command_json`` (``Kind.rerun``)."""


# --------------------------------------------------------------------------- studies
def study_of(config: dict[str, Any], overrides: Mapping[str, Any], source: str) -> Any:
    """The study of a study dataset's ``config_json`` (``kind``, ``split_sigma``, ``split_rms``,
    ``grid`` and the resolved base ``scene``), the overrides applied to its base scene."""
    from ..drivers.study import GridAxis, Study, dimension_name

    try:
        base = dict(config["scene"])
        study_kind = config["kind"]
        grid = config["grid"]
        split_sigma = bool(config.get("split_sigma", False))
        split_rms = bool(config.get("split_rms", False))
    except (KeyError, TypeError) as exc:
        raise HertzsweepError(f"{source}: not a study's configuration ({exc})") from None
    if study_kind not in STUDY_KINDS:
        raise ConfigError(source, "kind", f"expected one of {', '.join(STUDY_KINDS)}")
    scene_of(base, overrides, source)  # the base scene must be valid
    axes = tuple(GridAxis(key, dimension_name(key), tuple(values)) for key, values in grid.items())
    return Study(
        source=source,
        kind=study_kind,
        base=base,
        grid=axes,
        split_sigma=split_sigma,
        split_rms=split_rms,
    )


def what_to_rerun(attributes: Mapping[str, Any], path: str) -> tuple[str, Runner | None]:
    """The kind of a dataset and its runner (None for a study).

    Raises
    ------
    HertzsweepError
        Not a hertzsweep dataset, or a kind no command simulates (measured, fit).
    """
    try:
        kind = kind_named(attributes.get("hertzsweep_kind"))
    except HertzsweepError as exc:
        raise exc.with_context(path) from None
    run = RUNNERS.get(kind.name)
    if run is None and kind.source != STUDY:  # not made by a simulation: nothing to rerun
        known = ", ".join([*RUNNERS, "study"])
        raise HertzsweepError(f"{path}: cannot rerun a {kind.name} dataset ({known} only)")
    return kind.name, run


__all__ = [
    "RUNNERS",
    "json_attribute",
    "rerun_accuracy",
    "rerun_branch",
    "rerun_random",
    "rerun_sweep",
    "rerun_trace",
    "scene_of",
    "study_of",
    "trace_streams",
    "what_to_rerun",
]
