"""Parameter studies: a base scene and a grid of config values; every combination a case.

A study file (TOML)::

    kind = "sweep"                       # or "branch"
    scene = "fig15-scene.toml"           # relative to the study file; or inline scene tables
    [grid]
    "damping.exponent" = [0, 0.5, 1, 1.5]
    "excitation.sigma" = [0.002, 0.005, 0.01, 0.02, 0.04, 0.08]

Inline scene tables (``rig = "..."`` or ``[rig]``, ``[damping]``, ``[sweep]``, ...) give the
whole base scene when there is no ``scene`` key, and override single keys of the named
scene when there is one. ``split_sigma = true`` makes every sigma of the grid its own case
(finer parallelism); by default the sigma values of the grid are all given to each case,
whose trajectories then run together in one compiled loop (:mod:`hertzsweep.batch`).

A case is identified by the sha256 of its resolved scene's canonical JSON
(``Scene.attributes()`` and the kind): its result is written atomically to
``OUT.parts/<hash>.nc`` as soon as it finishes, a failure to ``OUT.parts/<hash>.error.json``
(the config and the error), so a study stopped at any point keeps every finished case and
``resume`` recomputes only the rest. Cases run on an :class:`Engine`: a local pool of worker
processes (:class:`LocalPool`) or an existing Dask cluster (:class:`DaskCluster`); both run
the same function, :func:`run_case`, so the results are identical.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import os
import signal
import time
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..core.config import CLASSES, Scene, apply_override, load_raw_scene, scene_from_dict
from ..core.rig import derive
from ..errors import ConfigError, HertzsweepError

KINDS = ("sweep", "branch")
SIGMA_KEY = "excitation.sigma"
STUDY_KEYS = ("kind", "scene", "grid", "split_sigma")
POLL_SECONDS = 0.2  # how often the driver looks at finished cases and stop requests
QUEUE_PER_SLOT = 2  # cases in flight per worker slot: keeps workers busy, stops fast


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
    kind : ``"sweep"`` or ``"branch"``.
    base : the base scene as a raw mapping (rig inlined), the grid not yet applied.
    grid : the grid keys in file order.
    split_sigma : every sigma of the grid its own case (default: all sigma in each case).
    """

    source: str
    kind: str
    base: dict[str, Any]
    grid: tuple[GridAxis, ...]
    split_sigma: bool = False

    @property
    def case_axes(self) -> tuple[GridAxis, ...]:
        """The axes the cases vary along (the grid but the folded sigma axis)."""
        return tuple(a for a in self.grid if self.split_sigma or a.key != SIGMA_KEY)

    @property
    def sigma_axis(self) -> GridAxis | None:
        return next((a for a in self.grid if a.key == SIGMA_KEY), None)


@dataclass(frozen=True)
class Case:
    """One combination of the grid.

    Attributes
    ----------
    index : position along each of the study's :attr:`Study.case_axes`.
    values : ``{dotted key: value}`` along those axes.
    scene : the resolved scene.
    hash : sha256 of the scene's canonical JSON and the kind (:func:`case_hash`).
    """

    index: tuple[int, ...]
    values: dict[str, Any]
    scene: Scene
    hash: str

    @property
    def label(self) -> str:
        """``damping.exponent=0.5, ...`` (``base`` for the only case of an empty grid)."""
        return grid_label(self.values) or "base"


def grid_label(values: dict[str, Any]) -> str:
    """``key=value, ...`` of a case's grid values (empty for an empty grid)."""
    return ", ".join(f"{k}={v}" for k, v in values.items())


def dimension_name(key: str) -> str:
    """SPEC: a grid key's dimension is the key with "." replaced by "_", except
    ``excitation.sigma``, which is ``sigma``."""
    return "sigma" if key == SIGMA_KEY else key.replace(".", "_")


def _scalar(value: Any) -> bool:
    return isinstance(value, bool | int | float | str)


def load_study(path: str | os.PathLike) -> Study:
    """Read and check a study file: every grid value is validated on the base scene.

    Raises
    ------
    ConfigError
        Naming the study file and the key: unknown top-level key, bad ``kind``, a grid key
        that is not a config key, a value that is not a list of distinct numbers or
        strings, or a value the config rejects.
    """
    path = Path(path)
    source = str(path)
    raw = load_raw_scene(path)  # reads the file and inlines `rig = "..."` relative to it
    for key in raw:
        if key not in STUDY_KEYS and key not in CLASSES:
            known = ", ".join((*STUDY_KEYS, *CLASSES))
            raise ConfigError(source, key, f"unknown key (known: {known})")
    kind = raw.pop("kind", "sweep")
    if kind not in KINDS:
        raise ConfigError(source, "kind", f"expected one of 'sweep', 'branch', got {kind!r}")
    split_sigma = raw.pop("split_sigma", False)
    if not isinstance(split_sigma, bool):
        raise ConfigError(source, "split_sigma", f"expected true or false, got {split_sigma!r}")
    grid_raw = raw.pop("grid", {})
    if not isinstance(grid_raw, dict):
        raise ConfigError(source, "grid", f"expected a table of key = [values], got {grid_raw!r}")
    scene_ref = raw.pop("scene", None)
    if scene_ref is None:
        base = raw
    else:
        if not isinstance(scene_ref, str):
            raise ConfigError(source, "scene", f"expected a file name, got {scene_ref!r}")
        scene_path = Path(scene_ref) if Path(scene_ref).is_absolute() else path.parent / scene_ref
        if not scene_path.exists():
            raise ConfigError(source, "scene", f"scene file {str(scene_path)!r} does not exist")
        base = load_raw_scene(scene_path)
        for table, entries in raw.items():
            if table == "rig" or not isinstance(entries, dict):
                base[table] = entries
                continue
            for name, value in entries.items():
                apply_override(base, f"{table}.{name}", value, source=source)
    scene_from_dict(copy.deepcopy(base), source=source)  # the base itself must be valid
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
    return Study(source=source, kind=kind, base=base, grid=tuple(grid), split_sigma=split_sigma)


def _json_default(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {value!r}")


def canonical_json(scene: Scene, kind: str) -> str:
    """The resolved configuration as canonical JSON (sorted keys, no spaces): what
    identifies a case. The scene's source file is not part of it."""
    payload = {"kind": kind, "scene": scene.attributes()}
    return json.dumps(payload, sort_keys=True, separators=(",", ":"), default=_json_default)


def case_hash(scene: Scene, kind: str) -> str:
    """sha256 (hex) of :func:`canonical_json`."""
    return hashlib.sha256(canonical_json(scene, kind).encode()).hexdigest()


def expand(study: Study) -> list[Case]:
    """Every case of the grid, in C order of :attr:`Study.case_axes`.

    Raises
    ------
    ConfigError
        A combination the config rejects (e.g. ``sweep.start`` above ``sweep.stop``).
    """
    axes = study.case_axes
    sigma = study.sigma_axis
    cases = []
    for index in itertools.product(*(range(len(a.values)) for a in axes)):
        values = {a.key: a.values[i] for a, i in zip(axes, index, strict=True)}
        raw = copy.deepcopy(study.base)
        if sigma is not None and not study.split_sigma:
            apply_override(raw, SIGMA_KEY, list(sigma.values), source=study.source)
        for key, value in values.items():
            apply_override(raw, key, [value] if key == SIGMA_KEY else value, source=study.source)
        label = grid_label(values)
        scene = scene_from_dict(raw, source=f"{study.source}[{label}]" if label else study.source)
        cases.append(Case(index, values, scene, case_hash(scene, study.kind)))
    return cases


def varying_attributes(cases: Sequence[Case]) -> list[str]:
    """Names of the global attributes (config values and rig constants) that differ
    between cases: the study dataset leaves them out (they are its coordinates)."""

    def flat(case: Case) -> dict[str, str]:
        values = dict(case.scene.attributes())
        values.update(derive(case.scene.rig).as_dict())
        return {k: json.dumps(v, default=_json_default) for k, v in values.items()}

    if not cases:
        return []
    first = flat(cases[0])
    varying = set()
    for case in cases[1:]:
        varying.update(k for k, v in flat(case).items() if first.get(k) != v)
    return sorted(varying)


# --------------------------------------------------------------------------- one case
@dataclass
class CaseOutcome:
    """What a worker returns: the case's dataset, or the error that stopped it."""

    dataset: Any = None
    error: dict[str, str] | None = None
    seconds: float = 0.0


def run_case(scene: Scene, kind: str, history: str | None = None) -> CaseOutcome:
    """Run one case (in a worker process, local or Dask): a sweep with every trajectory
    batched (:func:`hertzsweep.batch.run_sweep_batched`), or a branch
    (``hertzsweep.continuation.run_branch``). Never raises for the case's own errors: they
    come back as ``CaseOutcome.error`` (type, message, traceback)."""
    t0 = time.perf_counter()
    try:
        if kind == "sweep":
            from ..output.dataset import sweep_dataset
            from .batch import run_sweep_batched

            dataset = sweep_dataset(run_sweep_batched(scene), scene, history)
        else:
            from ..output.dataset import branch_dataset
            from .continuation import run_branch

            dataset = branch_dataset(run_branch(scene), scene, history)
    except Exception as exc:  # a failed case is recorded, the others go on
        error = {"type": type(exc).__name__, "message": str(exc),
                 "traceback": traceback.format_exc()}  # fmt: skip
        return CaseOutcome(error=error, seconds=time.perf_counter() - t0)
    return CaseOutcome(dataset=dataset, seconds=time.perf_counter() - t0)


# --------------------------------------------------------------------------- engines
DRIVER_CHECK_SECONDS = 1.0  # how often a local worker checks that its driver still lives


def _worker_init(driver: int) -> None:
    """Local workers leave SIGINT to the driver (a terminal's Ctrl-C reaches the whole
    process group): the driver stops them itself, after the finished parts are safe.
    A watchdog thread ends the worker when the driver is gone (killed with SIGKILL: the
    pool's queues would otherwise keep idle workers waiting for ever)."""
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

    def submit(self, case: Case, kind: str, history: str | None) -> Any:
        raise NotImplementedError

    def completed(self, handles: Iterable[Any], timeout: float) -> list[tuple[Any, CaseOutcome]]:
        raise NotImplementedError

    def stop(self, handles: Iterable[Any]) -> None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError


def _lost(exc: BaseException) -> CaseOutcome:
    """The outcome of a case whose worker failed (it died, or the cluster lost it)."""
    message = str(exc) or "the worker running this case was lost"
    return CaseOutcome(error={"type": type(exc).__name__, "message": message, "traceback": ""})


class LocalPool(Engine):
    """A local pool of worker processes (:class:`concurrent.futures.ProcessPoolExecutor`,
    ``forkserver`` start method with hertzsweep preloaded)."""

    name = "local pool"

    def __init__(self, workers: int | None = None) -> None:
        import multiprocessing

        self.slots = max(1, int(workers or os.cpu_count() or 1))
        self._context = multiprocessing.get_context("forkserver")
        self._context.set_forkserver_preload([__name__, "hertzsweep.batch", "hertzsweep.dataset"])
        self._executor = self._new_executor()

    def _new_executor(self):
        from concurrent.futures import ProcessPoolExecutor

        return ProcessPoolExecutor(
            max_workers=self.slots,
            mp_context=self._context,
            initializer=_worker_init,
            initargs=(os.getpid(),),
        )

    def submit(self, case: Case, kind: str, history: str | None) -> Any:
        from concurrent.futures.process import BrokenProcessPool

        try:
            return self._executor.submit(run_case, case.scene, kind, history)
        except BrokenProcessPool:  # a worker died earlier: start a fresh pool
            self._executor.shutdown(wait=False, cancel_futures=True)
            self._executor = self._new_executor()
            return self._executor.submit(run_case, case.scene, kind, history)

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
        terminate = getattr(self._executor, "terminate_workers", None)  # Python >= 3.14
        if terminate is not None:
            terminate()
        else:
            processes = list(getattr(self._executor, "_processes", {}).values())
            for process in processes:
                if process.is_alive():
                    process.terminate()
            for process in processes:
                process.join(timeout=5.0)
        self._executor.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        self._executor.shutdown(wait=True, cancel_futures=True)


class DaskCluster(Engine):
    """An existing Dask distributed cluster (``distributed.Client(address)``,
    ``client.submit`` and ``as_completed``). Workers must have hertzsweep installed."""

    name = "Dask cluster"

    def __init__(self, address: str, timeout: float = 10.0) -> None:
        from distributed import Client, as_completed

        try:
            self.client = Client(address, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise HertzsweepError(f"--scheduler: cannot connect to {address}: {exc}") from None
        self.slots = max(1, sum(self.client.nthreads().values()))
        self._finished = as_completed(loop=self.client.loop)
        self.address = address

    def submit(self, case: Case, kind: str, history: str | None) -> Any:
        key = f"hertzsweep-case-{case.hash[:16]}-{os.urandom(4).hex()}"
        future = self.client.submit(run_case, case.scene, kind, history, key=key, pure=False)
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


# --------------------------------------------------------------------------- parts
def parts_folder(output: str | os.PathLike) -> Path:
    """``OUT.parts/``: one file per finished (or failed) case."""
    return Path(f"{output}.parts")


def part_path(folder: Path, case: Case) -> Path:
    return folder / f"{case.hash}.nc"


def error_path(folder: Path, case: Case) -> Path:
    return folder / f"{case.hash}.error.json"


def read_part(path: Path, expected_hash: str | None = None):
    """The dataset of a part file, or None when it is absent, unreadable or not the
    expected case."""
    from ..output.dataset import open_dataset

    if not path.exists():
        return None
    try:
        ds = open_dataset(path)
    except Exception:  # a file that does not open is no part
        return None
    if expected_hash is not None and ds.attrs.get("study_case_hash") != expected_hash:
        return None
    return ds


def write_part(folder: Path, study: Study, case: Case, dataset: Any) -> Path:
    """Write a finished case atomically, with its grid values and hash as attributes."""
    from ..output.dataset import write_atomic

    dataset = dataset.copy()
    dataset.attrs.update(
        study_case_hash=case.hash,
        study_case=json.dumps(case.values, default=_json_default),
        study_kind=study.kind,
        study_file=study.source,
    )
    path = write_atomic(dataset, part_path(folder, case))
    error_path(folder, case).unlink(missing_ok=True)
    return path


def write_error(folder: Path, study: Study, case: Case, error: dict[str, str]) -> Path:
    """Record a failed case: its grid values, its whole resolved config and the error
    (an older part of the same case is removed, so the output marks it failed)."""
    record = {
        "hash": case.hash,
        "study": study.source,
        "kind": study.kind,
        "grid": case.values,
        "config": case.scene.attributes(),
        "error": error,
    }
    from ..output.dataset import atomic_path

    path = error_path(folder, case)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(record, indent=2, default=_json_default))
    part_path(folder, case).unlink(missing_ok=True)
    return path


def resumable(cases: Sequence[Case], output: str | os.PathLike) -> list[Case]:
    """The cases whose part exists and is readable (what ``--resume`` skips)."""
    folder = parts_folder(output)
    return [case for case in cases if read_part(part_path(folder, case), case.hash) is not None]


# --------------------------------------------------------------------------- the driver
@dataclass
class StudyRun:
    """What a run did: cases computed, taken from earlier parts, failed; and whether it
    was stopped (the signal number) before the end."""

    cases: list[Case]
    computed: list[Case] = field(default_factory=list)
    resumed: list[Case] = field(default_factory=list)
    failed: list[tuple[Case, dict[str, str]]] = field(default_factory=list)
    stopped_by: int = 0
    seconds: float = 0.0

    def failure_lines(self, folder: Path) -> list[str]:
        """One line per failed case: its grid values, the error, the record's file."""
        lines = []
        for case, error in self.failed:
            message = error["message"].splitlines()[0] if error["message"] else ""
            lines.append(f"{case.label}: {error['type']}: {message} "
                         f"(config and traceback in {error_path(folder, case)})")  # fmt: skip
        return lines


def run_study(
    study: Study,
    cases: Sequence[Case],
    output: str | os.PathLike,
    engine: Engine,
    resume: bool = False,
    history: str | None = None,
    progress: Callable[[int], None] | None = None,
    stop_requested: Callable[[], int] | None = None,
    resumed: Sequence[Case] | None = None,
) -> StudyRun:
    """Run the cases on the engine; write each part as it finishes.

    Parameters
    ----------
    resume : skip the cases whose part exists and is readable (:func:`resumable`, or
        ``resumed`` when the caller has already looked).
    progress : called with 1 for each case that finishes (computed or failed).
    stop_requested : returns a signal number (non-zero) when the run must stop: no more
        cases are submitted, the ones in flight are abandoned (:meth:`Engine.stop`), the
        finished parts stay.
    """
    t0 = time.perf_counter()
    folder = parts_folder(output)
    folder.mkdir(parents=True, exist_ok=True)
    run = StudyRun(cases=list(cases))
    if resume:
        run.resumed = list(resumed) if resumed is not None else resumable(cases, output)
    skip = {case.hash for case in run.resumed}
    queue: deque[Case] = deque(case for case in cases if case.hash not in skip)
    stop_requested = stop_requested or (lambda: 0)
    in_flight: dict[Any, Case] = {}
    limit = max(1, QUEUE_PER_SLOT * engine.slots)
    while (queue or in_flight) and not stop_requested():
        while queue and len(in_flight) < limit:
            case = queue.popleft()
            in_flight[engine.submit(case, study.kind, history)] = case
        for handle, outcome in engine.completed(list(in_flight), POLL_SECONDS):
            case = in_flight.pop(handle)
            if outcome.error is None:
                write_part(folder, study, case, outcome.dataset)
                run.computed.append(case)
            else:
                write_error(folder, study, case, outcome.error)
                run.failed.append((case, outcome.error))
            if progress is not None:
                progress(1)
    run.stopped_by = stop_requested()
    if run.stopped_by:
        engine.stop(list(in_flight))
    run.seconds = time.perf_counter() - t0
    return run


def combine(
    study: Study,
    cases: Sequence[Case],
    output: str | os.PathLike,
    history: str | None = None,
    failures: Sequence[str] = (),
):
    """ONE dataset of every case's part (NaN / -1 where a case has no part), or None
    when no case has one. See :func:`hertzsweep.dataset.study_dataset`."""
    from ..output.dataset import study_dataset

    folder = parts_folder(output)
    parts = {case.index: read_part(part_path(folder, case), case.hash) for case in cases}
    if all(ds is None for ds in parts.values()):
        return None
    scene = next(c.scene for c in cases if parts[c.index] is not None)
    return study_dataset(
        study_kind=study.kind,
        grid=[(a.key, a.dim, a.values) for a in study.grid],
        case_dims=[a.dim for a in study.case_axes],
        parts=parts,
        case_ids={case.index: case.hash for case in cases},
        scene=scene,
        drop_attributes=varying_attributes(cases),
        history=history,
        extra={
            "study_file": study.source,
            "study_grid": ", ".join(a.key for a in study.grid),
            "study_split_sigma": int(study.split_sigma),
            "study_cases": len(cases),
            "study_failed": len(failures),
            "study_failures": "\n".join(failures),
        },
    )


def cases_summary(run: StudyRun) -> str:
    """``N cases: C computed, R resumed, F failed in S s``."""
    return (
        f"{len(run.cases)} cases: {len(run.computed)} computed, {len(run.resumed)} resumed, "
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
    "case_hash",
    "canonical_json",
    "combine",
    "dimension_name",
    "expand",
    "load_study",
    "parts_folder",
    "read_part",
    "resumable",
    "run_case",
    "run_study",
]
