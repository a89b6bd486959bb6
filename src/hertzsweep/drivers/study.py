"""Parameter studies: a base scene and a grid of config values; every combination a case.

A study file (TOML)::

    kind = "sweep"                       # or "branch", or "random"
    scene = "fig15-scene.toml"           # relative to the study file; or inline scene tables
    [grid]
    "damping.exponent" = [0, 0.5, 1, 1.5]
    "excitation.sigma" = [0.002, 0.005, 0.01, 0.02, 0.04, 0.08]

Inline scene tables (``rig = "..."`` or ``[rig]``, ``[damping]``, ``[sweep]``, ...) give the
whole base scene when there is no ``scene`` key, and override single keys of the named
scene when there is one. ``split_sigma = true`` makes every sigma of the grid its own case
(finer parallelism); by default the sigma values of the grid are all given to each case,
whose trajectories then run together in one compiled loop
(:func:`hertzsweep.drivers.sweep.run_sweep`).

A random study (``kind = "random"``, its scene ``excitation.kind = "random"``) runs each
case with :func:`hertzsweep.drivers.random.run_random`; its levels are ``excitation.rms``
(the dimension ``rms``), folded into each case like sigma, and ``split_rms = true`` makes
every level its own case. A realisation's stream depends only on the seed and its number,
so a level's realisations give the same numbers alone as among the other levels: a split
study's spectra and statistics are those of one run of every level, bit for bit, except
the histogram (``force_pdf``): a run's bins span its largest level, so a split case's
span its own level (those of a run of that level alone). A grid over ``excitation.seed``
changes the streams (a new sample of the process). The realisations of a case run in
lockstep in one case, unless ``split_realisations = G`` (a whole number, at most the
fewest ``random.realisations`` of any case): each case then runs as G sub-cases
(:func:`sub_cases`), each a contiguous group of its realisations (sizes differing by at
most one, ``random.first_realisation`` and ``random.realisations`` set), each an ordinary
case of the engine (its own hash, part, resume, failure); their parts are merged into the
case's dataset, bit for bit that of the unsplit case
(:func:`hertzsweep.jobs.realisations.merged_part`).

A case is identified by the sha256 of its resolved scene's canonical JSON
(``Scene.attributes()`` and the kind, :func:`case_hash`). Cases run on an :class:`Engine`:
a local pool of worker processes (:class:`LocalPool`) or an existing Dask cluster
(:class:`DaskCluster`); both run the same function, :func:`run_case`, with the driver
function of the study's kind (given by the caller), so the results are identical.

This module runs cases to *results* and writes nothing: :func:`run_study` hands each
finished case to a callable ``on_case(case, outcome)`` of the caller's, which keeps it
(:mod:`hertzsweep.jobs.study` writes it to ``OUT.parts/<hash>.nc``).
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import itertools
import json
import os
import signal
import time
import traceback
from collections import deque
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..core.checks import preflight
from ..core.config import (
    CLASSES,
    Scene,
    apply_override,
    read_scene_files,
    same_file,
    scene_from_dict,
)
from ..core.kinds import KINDS, RMS_KEY, SIGMA_KEY, STUDY_KINDS
from ..errors import ConfigError, HertzsweepError

DEFAULT_KIND = "sweep"  # a study file without `kind` (the SPEC's default)
LEVEL_KEYS = {name: KINDS[name].level_key for name in STUDY_KINDS}  # a kind's levels: the
# list-valued key a case's run takes whole (a dimension of its result)
LEVEL_DIMS = {SIGMA_KEY: "sigma", RMS_KEY: "rms"}  # their dimensions, named as in the parts
EXCITATION_OF = {name: KINDS[name].excitation for name in STUDY_KINDS}  # a kind's scenes
STUDY_KEYS = ("kind", "scene", "grid", "split_sigma", "split_rms", "split_realisations")
REALISATIONS_KEY = "random.realisations"
FIRST_REALISATION_KEY = "random.first_realisation"
POLL_SECONDS = 0.2  # how often the driver looks at finished cases and stop requests
QUEUE_PER_SLOT = 2  # cases in flight per worker slot: keeps workers busy, stops fast
PRELOADED = (  # imported once by the local pool's fork server, inherited by every worker
    __name__,
    "hertzsweep.drivers.sweep",
    "hertzsweep.drivers.continuation",
    "hertzsweep.drivers.random",
    "hertzsweep.drivers.preload",  # and the kernels loaded from numba's cache
)
CASE_KINDS = STUDY_KINDS  # what one case of a study can be (hertzsweep.core.kinds)

Runner = Callable[[Scene], Any]  # a driver function: one case's scene -> its result


# --------------------------------------------------------------------------- study files
@dataclass(frozen=True)
class GridAxis:
    """One grid key: the dotted config key, its dimension name and its values."""

    key: str
    dim: str
    values: tuple[Any, ...]


@dataclass(frozen=True)
class Study:
    """A parsed study file.

    Attributes
    ----------
    source : the study file.
    kind : the kind of every case (``"sweep"``, ``"branch"`` or ``"random"``).
    base : the base scene as a raw mapping (rig inlined), the grid not yet applied.
    grid : the grid keys in file order.
    split_sigma : every sigma of the grid its own case (default: all sigma in each case).
    split_rms : every rms level of a random study's grid its own case (default: all
        levels in each case).
    split_realisations : a random study runs each case as this many sub-cases, each a
        contiguous group of its realisations (default 1: all in one).
    """

    source: str
    kind: str
    base: dict[str, Any]
    grid: tuple[GridAxis, ...]
    split_sigma: bool = False
    split_rms: bool = False
    split_realisations: int = 1

    @property
    def level_key(self) -> str:
        """The dotted key of the levels of the study's kind (:data:`LEVEL_KEYS`)."""
        return LEVEL_KEYS[self.kind]

    @property
    def split_levels(self) -> bool:
        """Every level its own case: ``split_rms`` for a random study, else ``split_sigma``."""
        return self.split_rms if self.level_key == RMS_KEY else self.split_sigma

    @property
    def case_axes(self) -> tuple[GridAxis, ...]:
        """The axes the cases vary along (the grid but the folded level axis)."""
        return tuple(a for a in self.grid if self.split_levels or a.key != self.level_key)

    @property
    def level_axis(self) -> GridAxis | None:
        """The grid axis of the levels (sigma, or rms for a random study), if any."""
        return next((a for a in self.grid if a.key == self.level_key), None)


@dataclass(frozen=True)
class Case:
    """One combination of the grid.

    Attributes
    ----------
    index : position along each of the study's :attr:`Study.case_axes`.
    values : ``{dotted key: value}`` along those axes.
    scene : the resolved scene.
    hash : sha256 of the scene's canonical JSON and the kind (:func:`case_hash`).
    whole : for a sub-case of a study's ``split_realisations`` (a group of the
        realisations of a case, its scene's ``random.first_realisation`` and
        ``random.realisations``), the case it is part of; None for a case.
    """

    index: tuple[int, ...]
    values: dict[str, Any]
    scene: Scene
    hash: str
    whole: Case | None = None

    @property
    def label(self) -> str:
        """``damping.exponent=0.5, ...`` (``base`` for the only case of an empty grid);
        a sub-case's adds its realisations (``realisations 5-9``, ``realisation 5``)."""
        label = grid_label(self.values) or "base"
        if self.whole is None:
            return label
        run = self.scene.random
        first, last = run.first_realisation, run.first_realisation + run.realisations - 1
        return (
            f"{label}, realisation {first}"
            if first == last
            else f"{label}, realisations {first}-{last}"
        )


def grid_label(values: dict[str, Any]) -> str:
    """``key=value, ...`` of a case's grid values (empty for an empty grid)."""
    return ", ".join(f"{k}={v}" for k, v in values.items())


def dimension_name(key: str) -> str:
    """SPEC: a grid key's dimension is the key with "." replaced by "_", except
    ``excitation.sigma``, which is ``sigma`` (and ``excitation.rms``, ``rms``: the levels
    keep their datasets' dimension)."""
    return LEVEL_DIMS.get(key, key.replace(".", "_"))


def _scalar(value: Any) -> bool:
    return isinstance(value, bool | int | float | str)


def load_study(path: str | os.PathLike, kinds: Collection[str]) -> Study:
    """Read and check a study file: every grid value is validated on the base scene.

    Parameters
    ----------
    path : path
        The study file.
    kinds : collection of str
        The kinds a study may run (those the caller has a driver for).

    Raises
    ------
    ConfigError
        Naming the study file and the key: unknown top-level key, a ``kind`` not in
        ``kinds``, a grid key that is not a config key, a value that is not a list of
        distinct numbers or strings, or a value the config rejects.
    """
    path = Path(path)
    source = str(path)
    # reads the file and inlines `rig = "..."` relative to it
    raw, inputs = read_scene_files(path)
    study_rig = inputs[1] if len(inputs) > 1 else source  # where the study's own rig is
    for key in raw:
        if key not in STUDY_KEYS and key not in CLASSES:
            known = ", ".join((*STUDY_KEYS, *CLASSES))
            raise ConfigError(source, key, f"unknown key (known: {known})")
    kind = raw.pop("kind", DEFAULT_KIND)
    if kind not in kinds:
        known = ", ".join(repr(k) for k in kinds)
        raise ConfigError(source, "kind", f"expected one of {known}, got {kind!r}")
    split = {name: raw.pop(name, False) for name in ("split_sigma", "split_rms")}
    for name, value in split.items():
        if not isinstance(value, bool):
            raise ConfigError(source, name, f"expected true or false, got {value!r}")
    _check_levels(source, kind, split, raw.get("grid", {}))
    groups = _split_realisations(source, kind, raw.pop("split_realisations", 1))
    grid_raw = raw.pop("grid", {})
    if not isinstance(grid_raw, dict):
        raise ConfigError(source, "grid", f"expected a table of key = [values], got {grid_raw!r}")
    scene_ref = raw.pop("scene", None)
    given: set[str] = set()  # the tables and keys the study gives over its scene file
    if scene_ref is None:
        base, base_source, rig_source = raw, source, study_rig
    else:
        if not isinstance(scene_ref, str):
            raise ConfigError(source, "scene", f"expected a file name, got {scene_ref!r}")
        scene_path = Path(scene_ref) if Path(scene_ref).is_absolute() else path.parent / scene_ref
        if not scene_path.exists():
            raise ConfigError(source, "scene", f"scene file {str(scene_path)!r} does not exist")
        if same_file(scene_path, path):
            raise ConfigError(source, "scene", f"names the study file itself ({scene_ref!r})")
        base, scene_inputs = read_scene_files(scene_path)
        base_source = str(scene_path)
        rig_source = (  # the rig's values: the study's, or the scene file's rig
            study_rig if "rig" in raw else scene_inputs[-1]
        )
        for table, entries in raw.items():
            if table == "rig" or not isinstance(entries, dict):
                base[table] = entries
                given.add(table)
                continue
            for name, value in entries.items():
                apply_override(base, f"{table}.{name}", value, source=source)
                given.add(f"{table}.{name}")
    # the base itself must be valid; an error names the file the value came from: the
    # study, its scene file or the rig file
    try:
        scene = scene_from_dict(copy.deepcopy(base), source=base_source, rig_source=rig_source)
    except ConfigError as exc:
        from_study = exc.key in given or exc.key.partition(".")[0] in given
        if exc.source == base_source != source and from_study:
            raise ConfigError(source, exc.key, exc.reason) from None
        raise
    if scene.excitation.kind != EXCITATION_OF[kind]:
        reason = (
            f"a {kind} study runs scenes of excitation.kind = {EXCITATION_OF[kind]!r}; its "
            f"scene has {scene.excitation.kind!r}"
        )
        raise ConfigError(source, "kind", reason)
    grid = []
    for key, values in grid_raw.items():
        if not isinstance(values, list) or not values:
            raise ConfigError(source, f"grid.{key}", "expected a non-empty list of values")
        if not all(_scalar(v) for v in values):
            raise ConfigError(source, f"grid.{key}", f"values must be numbers or strings: {values}")
        if len(set(values)) != len(values):
            raise ConfigError(source, f"grid.{key}", f"values must be distinct: {values}")
        for value in values:
            trial = copy.deepcopy(base)
            apply_override(trial, key, value, source=source)
            scene_from_dict(trial, source=source)
        grid.append(GridAxis(key, dimension_name(key), tuple(values)))
    dims = [a.dim for a in grid]
    if len(set(dims)) != len(dims):
        raise ConfigError(source, "grid", f"two keys give the same dimension: {dims}")
    _check_groups(source, groups, grid, scene)
    return Study(source, kind, base, tuple(grid), split_realisations=groups, **split)


def _check_groups(source: str, groups: int, grid: Sequence[GridAxis], scene: Scene) -> None:
    """``split_realisations`` is at most the fewest ``random.realisations`` of any case
    (the grid's, else the base scene's).

    Raises
    ------
    ConfigError
        Naming the study file and the key.
    """
    axis = next((a for a in grid if a.key == REALISATIONS_KEY), None)
    fewest = min(axis.values) if axis is not None else scene.random.realisations
    if groups > fewest:
        reason = f"{groups} groups of realisations, but a case has only {fewest} realisations"
        raise ConfigError(source, "split_realisations", reason)


def _split_realisations(source: str, kind: str, value: Any) -> int:
    """The study's ``split_realisations``: a whole number >= 1, other than 1 only in a
    random study (the only kind with realisations).

    Raises
    ------
    ConfigError
        Naming the study file and the key.
    """
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ConfigError(
            source, "split_realisations", f"expected a whole number >= 1, got {value!r}"
        )
    if value != 1 and kind != "random":
        reason = f"a {kind} study has no realisations to split (only a random study has)"
        raise ConfigError(source, "split_realisations", reason)
    return value


def realisation_groups(realisations: int, groups: int) -> list[tuple[int, int]]:
    """``(first, count)`` of ``groups`` contiguous groups of ``realisations``, in order,
    their sizes differing by at most one, the larger first (16 in 3: 6, 5, 5)."""
    size, extra = divmod(realisations, groups)
    out, first = [], 0
    for g in range(groups):
        count = size + (g < extra)
        out.append((first, count))
        first += count
    return out


def sub_cases(study: Study, case: Case, raw: dict[str, Any]) -> list[Case]:
    """The sub-cases of a case of a study's ``split_realisations`` (the case itself when
    it is 1): each runs one group of its realisations (:func:`realisation_groups`), its
    scene the case's (``raw``, its mapping) with ``random.first_realisation`` and
    ``random.realisations`` set, its hash its own."""
    if study.split_realisations == 1:
        return [case]
    out = []
    start = case.scene.random.first_realisation  # the case's own first, 0 by default
    for first, count in realisation_groups(
        case.scene.random.realisations, study.split_realisations
    ):
        group = copy.deepcopy(raw)
        apply_override(group, FIRST_REALISATION_KEY, start + first, source=study.source)
        apply_override(group, REALISATIONS_KEY, count, source=study.source)
        scene = scene_from_dict(group, source=case.scene.source)
        out.append(Case(case.index, case.values, scene, case_hash(scene, study.kind), case))
    return out


def _check_levels(source: str, kind: str, split: dict[str, bool], grid: Any) -> None:
    """A study splits, and grids, only the levels its kind's scenes use: ``split_rms`` and
    ``excitation.rms`` in a random study, ``split_sigma`` and ``excitation.sigma`` in the
    others (the other key would make cases that differ in a value their run ignores).

    Raises
    ------
    ConfigError
        Naming the study file and the key.
    """
    levels = LEVEL_KEYS[kind]
    for name, key in (("split_sigma", SIGMA_KEY), ("split_rms", RMS_KEY)):
        if key == levels:
            continue
        reason = f"a {kind} study's levels are {levels}, not {key}"
        if split[name]:
            raise ConfigError(source, name, reason)
        if isinstance(grid, dict) and key in grid:
            raise ConfigError(source, f"grid.{key}", reason)


def json_default(value: Any) -> Any:
    """``json.dumps(default=...)``: numpy values as plain lists and numbers."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {value!r}")


def canonical_json(scene: Scene, kind: str) -> str:
    """The resolved configuration as canonical JSON (sorted keys, no spaces): what
    identifies a case. The scene's source file is not part of it."""
    payload = {"kind": kind, "scene": scene.attributes()}
    return json.dumps(payload, sort_keys=True, separators=(",", ":"), default=json_default)


def case_hash(scene: Scene, kind: str) -> str:
    """sha256 (hex) of :func:`canonical_json`."""
    return hashlib.sha256(canonical_json(scene, kind).encode()).hexdigest()


def expand(study: Study) -> list[Case]:
    """Every case of the grid, in C order of :attr:`Study.case_axes`; with
    ``split_realisations`` > 1, every case's sub-cases in its place (:func:`sub_cases`,
    :func:`whole_cases` gives the cases back).

    Raises
    ------
    ConfigError
        A combination the config rejects (e.g. ``sweep.start`` above ``sweep.stop``), or
        one a check of its run refuses (:func:`hertzsweep.core.checks.preflight`: the
        stability limit, the Nyquist order, the budgets of steps and memory, ...), naming
        the study file and the case.
    """
    axes = study.case_axes
    levels = study.level_axis
    cases = []
    for index in itertools.product(*(range(len(a.values)) for a in axes)):
        values = {a.key: a.values[i] for a, i in zip(axes, index, strict=True)}
        raw = copy.deepcopy(study.base)
        if levels is not None and not study.split_levels:
            apply_override(raw, levels.key, list(levels.values), source=study.source)
        for key, value in values.items():
            single = [value] if key == study.level_key else value
            apply_override(raw, key, single, source=study.source)
        label = grid_label(values)
        source = f"{study.source}[{label}]" if label else study.source
        scene = scene_from_dict(copy.deepcopy(raw), source=source)
        preflight(scene)  # every check the case's run makes, before any case runs
        case = Case(index, values, scene, case_hash(scene, study.kind))
        cases += sub_cases(study, case, raw)
    return cases


def whole_cases(cases: Sequence[Case]) -> list[Case]:
    """The cases of a study, once each, in order: a sub-case's whole case in its place."""
    out: dict[tuple[int, ...], Case] = {}
    for case in cases:
        out.setdefault(case.index, case.whole or case)
    return list(out.values())


# --------------------------------------------------------------------------- one case
@dataclass
class CaseOutcome:
    """What a worker returns: the case's result (that of the kind's driver), or the
    error that stopped it (``{"type", "message", "traceback"}``)."""

    result: Any = None
    error: dict[str, str] | None = None
    seconds: float = 0.0


def error_record(exc: BaseException, with_traceback: bool = True) -> dict[str, str]:
    """``{"type", "message", "traceback"}`` of an exception (in its ``except`` block)."""
    return {
        "type": type(exc).__name__,
        "message": str(exc),
        "traceback": traceback.format_exc() if with_traceback else "",
    }


def run_case(runner: Runner, scene: Scene) -> CaseOutcome:
    """Run one case (in a worker process, local or Dask) with the kind's driver, e.g.
    :func:`hertzsweep.drivers.sweep.run_sweep`. Never raises for the case's own
    errors: they come back as :attr:`CaseOutcome.error`."""
    t0 = time.perf_counter()
    try:
        result = runner(scene)
    except Exception as exc:  # a failed case is recorded, the others go on
        return CaseOutcome(error=error_record(exc), seconds=time.perf_counter() - t0)
    return CaseOutcome(result=result, seconds=time.perf_counter() - t0)


# --------------------------------------------------------------------------- engines
DRIVER_CHECK_SECONDS = 1.0  # how often a local worker checks that its driver still lives


def _worker_init(driver: int) -> None:
    """Local workers leave SIGINT to the driver (a terminal's Ctrl-C reaches the whole
    process group): the driver stops them itself, after the finished parts are safe.
    A watchdog thread ends the worker when the driver is gone (killed with SIGKILL: the
    pool's queues would otherwise keep idle workers waiting for ever). The kernels are
    loaded already: the fork server loaded them (:mod:`hertzsweep.drivers.preload`)."""
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)

    def watch() -> None:
        while True:
            time.sleep(DRIVER_CHECK_SECONDS)
            try:
                os.kill(driver, 0)
            except (ProcessLookupError, PermissionError):  # gone, or its pid reused
                os._exit(1)

    threading.Thread(target=watch, name="hertzsweep-driver-watch", daemon=True).start()


class Engine:
    """Where cases run. ``submit`` returns a handle; ``completed`` waits up to ``timeout``
    seconds and returns the finished ``(handle, CaseOutcome)`` pairs; ``stop`` abandons
    the cases in flight; ``close`` releases the workers."""

    slots: int = 1
    name: str = "engine"

    def submit(self, case: Case, runner: Runner) -> Any:
        raise NotImplementedError

    def completed(self, handles: Iterable[Any], timeout: float) -> list[tuple[Any, CaseOutcome]]:
        raise NotImplementedError

    def stop(self, handles: Iterable[Any]) -> None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError


def _lost(exc: BaseException) -> CaseOutcome:
    """The outcome of a case whose worker failed (it died, or the cluster lost it)."""
    error = error_record(exc, with_traceback=False)
    error["message"] = error["message"] or "the worker running this case was lost"
    return CaseOutcome(error=error)


class LocalPool(Engine):
    """A local pool of worker processes (:class:`concurrent.futures.ProcessPoolExecutor`,
    ``forkserver`` start method with hertzsweep preloaded)."""

    name = "local pool"

    def __init__(self, workers: int | None = None) -> None:
        import multiprocessing
        import threading

        self.slots = max(1, int(workers or os.cpu_count() or 1))
        self._context = multiprocessing.get_context("forkserver")
        self._context.set_forkserver_preload(list(PRELOADED))
        self._executor: Any = None
        self._start_error: BaseException | None = None
        # start the fork server and the workers in the background: they import and load
        # the kernels (about a second) while the driver imports what it needs
        self._starting = threading.Thread(target=self._start, name="hertzsweep-pool-start")
        self._starting.start()

    def _start(self) -> None:
        try:
            self._executor = self._new_executor()
        except BaseException as exc:  # re-raised where the pool is first used
            self._start_error = exc
            return
        with contextlib.suppress(Exception):  # a warm-up only: a broken pool is met,
            for _ in range(self.slots):  # and replaced, by the first case's submit
                self._executor.submit(os.getpid)

    def _started(self):
        """The executor, once the background start is done (its error, if it failed)."""
        self._starting.join()
        if self._start_error is not None:
            raise self._start_error
        return self._executor

    def _new_executor(self):
        from concurrent.futures import ProcessPoolExecutor

        return ProcessPoolExecutor(
            max_workers=self.slots,
            mp_context=self._context,
            initializer=_worker_init,
            initargs=(os.getpid(),),
        )

    def submit(self, case: Case, runner: Runner) -> Any:
        from concurrent.futures.process import BrokenProcessPool

        try:
            return self._started().submit(run_case, runner, case.scene)
        except BrokenProcessPool:  # a worker died earlier: start a fresh pool
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = self._new_executor()
            return self._executor.submit(run_case, runner, case.scene)

    def completed(self, handles: Iterable[Any], timeout: float) -> list[tuple[Any, CaseOutcome]]:
        from concurrent.futures import FIRST_COMPLETED, wait

        done, _ = wait(list(handles), timeout=timeout, return_when=FIRST_COMPLETED)
        out = []
        for future in done:
            try:
                out.append((future, future.result()))
            except Exception as exc:  # BrokenProcessPool: the worker died
                out.append((future, _lost(exc)))
        return out

    def stop(self, handles: Iterable[Any]) -> None:
        """Cancel what has not started and end the workers (SIGTERM): their cases were
        not written, so nothing partial is left."""
        for future in handles:
            future.cancel()
        self._starting.join()
        if self._executor is None:  # its start failed: nothing runs
            return
        terminate = getattr(self._executor, "terminate_workers", None)  # Python >= 3.14
        if terminate is not None:
            terminate()
        else:
            processes = list((getattr(self._executor, "_processes", None) or {}).values())
            for process in processes:
                if process.is_alive():
                    process.terminate()
            for process in processes:
                process.join(timeout=5.0)
        self._executor.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        self._starting.join()
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)


CONNECT_SECONDS = 10.0  # a scheduler on a local network answers in milliseconds; 10 s
# covers a loaded or distant one and bounds what a wrong address costs


def connect(address: str, seconds: float = CONNECT_SECONDS):
    """A ``distributed.Client`` of the scheduler at ``address``, or one HertzsweepError
    within about ``seconds``, whatever the address: a closed TCP port fails at once (a
    plain socket connect first), and a port that accepts but never speaks Dask (its
    dashboard, an HTTP server) is abandoned at the deadline, which ``Client(timeout=)``
    alone does not bound. After a failure distributed's finalisers are kept quiet (they
    print ``Exception ignored ...`` blocks otherwise)."""
    import socket
    import sys
    import threading
    from urllib.parse import urlsplit

    def fail(reason: str) -> HertzsweepError:
        sys.unraisablehook = lambda unraisable: None  # the run ends with this error
        return HertzsweepError(f"--scheduler: cannot connect to {address}: {reason}")

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    if parts.scheme == "tcp":
        try:
            host, port = parts.hostname, parts.port
        except ValueError as exc:
            raise fail(str(exc)) from None
        if not host or port is None:
            raise fail("expected tcp://HOST:PORT")
        try:
            socket.create_connection((host, port), timeout=seconds).close()
        except OSError as exc:
            raise fail(exc.strerror or type(exc).__name__) from None
    outcome: dict[str, Any] = {}

    def attempt() -> None:
        from distributed import Client

        try:
            outcome["client"] = Client(address, timeout=seconds, set_as_default=False)
        except Exception as exc:  # distributed raises OSError, TimeoutError, ValueError, ...
            outcome["error"] = exc

    thread = threading.Thread(target=attempt, name="hertzsweep-connect", daemon=True)
    thread.start()
    thread.join(seconds + 1.0)
    if "client" in outcome:
        return outcome["client"]
    if "error" in outcome:
        text = str(outcome["error"]).strip().splitlines()
        raise fail(text[0] if text else type(outcome["error"]).__name__)
    raise fail(f"no Dask scheduler answered within {seconds:g} s")


class DaskCluster(Engine):
    """An existing Dask distributed cluster (``distributed.Client(address)``,
    ``client.submit`` and ``as_completed``). Workers must have hertzsweep installed."""

    name = "Dask cluster"

    def __init__(self, address: str, timeout: float = CONNECT_SECONDS) -> None:
        from distributed import as_completed

        self.client = connect(address, timeout)
        self.slots = max(1, sum(self.client.nthreads().values()))
        self._finished = as_completed(loop=self.client.loop)
        self.address = address

    def submit(self, case: Case, runner: Runner) -> Any:
        key = f"hertzsweep-case-{case.hash[:16]}-{os.urandom(4).hex()}"
        future = self.client.submit(run_case, runner, case.scene, key=key, pure=False)
        self._finished.add(future)
        return future

    def completed(self, handles: Iterable[Any], timeout: float) -> list[tuple[Any, CaseOutcome]]:
        deadline = time.monotonic() + timeout
        batch = self._finished.next_batch(block=False)
        while not batch and time.monotonic() < deadline:
            time.sleep(min(0.05, timeout))
            batch = self._finished.next_batch(block=False)
        out = []
        for future in batch:
            try:
                out.append((future, future.result()))
            except Exception as exc:  # KilledWorker, CancelledError, ...
                out.append((future, _lost(exc)))
        return out

    def stop(self, handles: Iterable[Any]) -> None:
        """Cancel the cases in flight (a task already running finishes in its worker
        and its result is dropped)."""
        handles = list(handles)
        if handles:
            self.client.cancel(handles, force=True)
        self._finished.clear()

    def close(self) -> None:
        self.client.close()


# --------------------------------------------------------------------------- the driver
@dataclass
class StudyRun:
    """What a run did: cases computed, taken from earlier results, failed; and whether it
    was stopped (the signal number) before the end."""

    cases: list[Case]
    computed: list[Case] = field(default_factory=list)
    resumed: list[Case] = field(default_factory=list)
    failed: list[tuple[Case, dict[str, str]]] = field(default_factory=list)
    stopped_by: int = 0
    seconds: float = 0.0


def run_study(
    cases: Sequence[Case],
    engine: Engine,
    runner: Runner,
    on_case: Callable[[Case, CaseOutcome], CaseOutcome],
    skip: Sequence[Case] = (),
    progress: Callable[[int], None] | None = None,
    stop_requested: Callable[[], int] | None = None,
) -> StudyRun:
    """Run the cases on the engine, handing each to ``on_case`` as it finishes.

    Parameters
    ----------
    cases : the study's cases (:func:`expand`).
    engine : where they run (:class:`LocalPool`, :class:`DaskCluster`).
    runner : the driver function of the study's kind, one case's scene -> its result; a
        module-level function (it is sent to the workers).
    on_case : called in this process with each finished case and its outcome; keeps it
        (writes it) and returns the outcome as kept: with an error when the result could
        not be kept.
    skip : cases already done (kept by an earlier run): not run, counted as resumed.
    progress : called with 1 for each case that finishes (computed or failed).
    stop_requested : returns a signal number (non-zero) when the run must stop: no more
        cases are submitted, the ones in flight are abandoned (:meth:`Engine.stop`), the
        ones handed to ``on_case`` stay.
    """
    t0 = time.perf_counter()
    run = StudyRun(cases=list(cases), resumed=list(skip))
    done = {case.hash for case in run.resumed}
    queue: deque[Case] = deque(case for case in cases if case.hash not in done)
    stop_requested = stop_requested or (lambda: 0)
    in_flight: dict[Any, Case] = {}
    limit = max(1, QUEUE_PER_SLOT * engine.slots)
    while (queue or in_flight) and not stop_requested():
        while queue and len(in_flight) < limit:
            case = queue.popleft()
            in_flight[engine.submit(case, runner)] = case
        for handle, outcome in engine.completed(list(in_flight), POLL_SECONDS):
            case = in_flight.pop(handle)
            kept = on_case(case, outcome)
            if kept.error is None:
                run.computed.append(case)
            else:
                run.failed.append((case, kept.error))
            if progress is not None:
                progress(1)
    run.stopped_by = stop_requested()
    if run.stopped_by:
        engine.stop(list(in_flight))
    run.seconds = time.perf_counter() - t0
    return run


def case_unit(cases: Sequence[Case]) -> str:
    """What a study's progress and messages count: ``"case"``, or ``"sub-case"`` when its
    cases run as sub-cases (``split_realisations`` > 1)."""
    return "case" if len(whole_cases(cases)) == len(cases) else "sub-case"


def cases_summary(run: StudyRun) -> str:
    """``N cases: C computed, R resumed, F failed in S s``; ``N cases as M sub-cases:
    ...`` when the cases run as sub-cases (the counts are then the sub-cases')."""
    count, wholes = len(run.cases), len(whole_cases(run.cases))
    count = f"{count} cases" if wholes == count else f"{wholes} cases as {count} sub-cases"
    return (
        f"{count}: {len(run.computed)} computed, {len(run.resumed)} resumed, "
        f"{len(run.failed)} failed in {run.seconds:.1f} s"
    )


__all__ = [
    "Case",
    "CaseOutcome",
    "DaskCluster",
    "Engine",
    "GridAxis",
    "LocalPool",
    "Study",
    "StudyRun",
    "canonical_json",
    "case_hash",
    "case_unit",
    "cases_summary",
    "dimension_name",
    "error_record",
    "expand",
    "json_default",
    "load_study",
    "realisation_groups",
    "run_case",
    "run_study",
    "sub_cases",
    "whole_cases",
]
