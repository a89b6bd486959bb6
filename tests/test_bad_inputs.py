"""Issue #11's acceptance suite: every error a user can cause ends with exactly one line on
stderr, ``hertzsweep: error: ...`` naming the file (or ``--set``, or the option) and the
key or path, and exit status 2. Never a traceback, a crash, a hang, NaN written as a
result, a bad input accepted, or a file written, left or changed.

:data:`CASES` is the one table: a case names its class, the command line, the files it
needs, and the substrings its one line must hold. Every case runs as its own ``hertzsweep``
process (a crash must not take the test runner with it) with a timeout (a hang is a
failure) and a memory limit (reading an endless file must not exhaust the machine), in
its own folder, whose every file is compared before and after: a refused command writes
nothing and leaves nothing, and its inputs and special files stay as they were.

One test runs the whole table on a small thread pool and reports every failing case,
grouped by class, in one assertion message.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import io
import itertools
import json
import os
import signal
import socket
import stat
import subprocess
import sys
import threading
import time
from collections import defaultdict
from collections.abc import Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .conftest import PAPER_RIG, run_cli
from .tomlwriter import toml_document

# --------------------------------------------------------------------------- limits
# A refused command ends in well under a second (the start-up of the interpreter and the
# compiled kernels' cache: 0.2 s for validate, 1.5 s for sweep, 2.5 s for study on the
# 2-core reference machine); 10 s leaves a factor 4 for a loaded machine and still ends a
# hung case quickly.
TIMEOUT = 10.0
# The bound for a study whose --scheduler cannot be reached: 15 s, start-up included.
SCHEDULER_SECONDS = 15.0
# Address space of each hertzsweep process: a sweep of the tiny scene peaks at 0.25 GB
# resident (about 1 GB of address space with the compiler loaded); 2 GiB lets every
# legitimate run through and turns an unbounded read (/dev/zero) into an error within a
# second instead of exhausting the machine's memory.
MEMORY_LIMIT = 2 << 30
# An "oversized" scene: a sparse file (no disk used) far beyond any plausible scene (the
# repository's largest is 2 kB) and beyond MEMORY_LIMIT, so that reading it whole fails.
OVERSIZED_BYTES = 4 << 30
# A command's helper processes (a process pool's fork server, its resource tracker, a
# worker still loading the kernels) end on their own once the command has ended: within a
# second on an idle machine, a few on a loaded one; those still there after 10 s (as long
# as a case may run) were left behind.
GRACE_SECONDS = 10.0
# The issue asks for more than 150 bad inputs.
MINIMUM_CASES = 150
# Cases run in parallel: those that compute on one thread more than there are cores (a case
# also waits: for its fork, its exit, its files), those that mostly wait on threads of
# their own, so that their waits cost no core.
CPU_WORKERS = (os.cpu_count() or 2) + 1
# A study starts and stops a pool of worker processes even when it refuses its file
# (1.2 s, half of it waiting): two at a time, beside the others.
STUDY_WORKERS = 2
# Threads for the cases that wait (a FIFO, the network): their waits overlap; 8 keeps the
# CPU they do use (a Dask client's start-up) from crowding the others.
IDLE_WORKERS = 8
# The commands that load the compiled kernels (a cold cache compiles them: about a minute)
KERNEL_COMMANDS = {"sweep", "trace", "branch", "accuracy", "study", "fit"}

PRELUDE = (  # `python -c PRELUDE ARGS...` is `hertzsweep ARGS...` under MEMORY_LIMIT
    "import resource, sys\n"
    f"resource.setrlimit(resource.RLIMIT_AS, ({MEMORY_LIMIT}, {MEMORY_LIMIT}))\n"
    "from hertzsweep.cli import main\n"
    "main()\n"
)
IS_ROOT = os.geteuid() == 0

# --------------------------------------------------------------------------- scenes
# A valid scene that runs in milliseconds: 3 frequencies, one sigma, one direction, short
# dwells. Every bad value is one change to it, so the error can only be about that value.
TINY = {
    "rig": dict(PAPER_RIG),
    "damping": {"ratio": 0.0045, "law": "viscous"},
    "excitation": {"sigma": [0.01]},
    "sweep": {
        "start": 0.96,
        "stop": 0.97,
        "step": 0.005,
        "directions": ["up"],
        "settle_periods": 10,
        "measure_periods": 2,
    },
    "solver": {"steps_per_period": 64},
    "lockin": {"harmonics": [1, 2]},
}


class _Drop:
    def __repr__(self) -> str:
        return "DROP"


DROP = _Drop()  # as a value in scene(): remove the key


def scene(changes: Mapping[str, Any] | None = None, rig: Any = None, **top: Any) -> str:
    """The tiny scene's TOML with ``{"table.key": value}`` changes (DROP removes a key,
    a table name alone replaces the table); ``rig`` replaces the inline [rig] table (a
    file name, or any value); ``top`` adds top-level keys."""
    raw: dict[str, Any] = copy.deepcopy(TINY)
    for dotted, value in (changes or {}).items():
        table, _, key = dotted.partition(".")
        if not key:
            raw[table] = value
            continue
        if not isinstance(raw.get(table), dict):  # absent, or replaced by a value before
            raw[table] = {}
        if value is DROP:
            raw[table].pop(key, None)
        else:
            raw[table][key] = value
    if rig is not None:
        raw["rig"] = rig
    raw = {**top, **raw}
    return toml_document(raw)


def rig_file(changes: Mapping[str, Any] | None = None, **tables: Any) -> str:
    """A rig file holding the paper's rig, with changes; extra tables if given."""
    rig = dict(PAPER_RIG)
    for key, value in (changes or {}).items():
        if value is DROP:
            rig.pop(key, None)
        else:
            rig[key] = value
    return toml_document({"rig": rig, **tables})


STUDY = 'kind = "sweep"\nscene = "scene.toml"\n\n[grid]\n"damping.ratio" = [0.004, 0.005]\n'
CSV = "direction,sigma,jump_frequency_ratio\nup,0.01,0.984\n"
GARBAGE = bytes(range(256)) * 8  # binary: every byte value, invalid UTF-8 from 0x80 on


# --------------------------------------------------------------------------- the table
@dataclass(frozen=True)
class Case:
    """One bad input.

    Attributes
    ----------
    group : the issue's class of bad input.
    id : ``group/name``, unique; also names the case's folder.
    argv : the arguments of ``hertzsweep``; ``{dir}`` stands for the case's folder
        (the working directory, so relative names are short and the message can be
        checked for them).
    files : name -> text or bytes, written into the folder first.
    expect : substrings the one stderr line must hold, each a string or a tuple of
        alternatives: the file (or ``--set``, or the option) and the key or path.
    special : (kind, name) special files to make: ``fifo``, ``dir``, ``null`` (a private
        character device equal to /dev/null), ``sparse`` (OVERSIZED_BYTES of zeros),
        ``loop`` (a symlink to itself), ``link`` (a symlink to a file not there),
        ``locked`` (a folder without write permission), ``unreadable`` (mode 000),
        ``netcdf`` (a valid netCDF file that hertzsweep did not write).
    outside : paths outside the folder that must keep their file type, with no temporary
        file left beside them.
    idle : the case mostly waits (a FIFO, the network): run apart from the CPU-bound ones.
    fresh : run in a new interpreter rather than forked from the fork server.
    may_succeed : extreme rather than wrong: exit 0 with an honest result (``out.nc``
        written, every value finite but those documented as NaN) passes too.
    timeout : seconds before the process counts as hung and is killed.
    """

    group: str
    id: str
    argv: tuple[str | bytes, ...]
    files: Mapping[str, str | bytes] = field(default_factory=dict)
    expect: tuple[str | tuple[str, ...], ...] = ()
    special: tuple[tuple[str, str], ...] = ()
    outside: tuple[str, ...] = ()
    idle: bool = False
    fresh: bool = False
    may_succeed: bool = False
    timeout: float = TIMEOUT


CASES: list[Case] = []


def case(group: str, id: str, *argv: str | bytes, **kwargs: Any) -> None:
    CASES.append(Case(group, f"{group}/{id}", tuple(argv), **kwargs))


def validate(group: str, id: str, text: str | bytes, *expect, extra=(), **kwargs) -> None:
    """``hertzsweep validate scene.toml`` on a scene of that text."""
    files = {"scene.toml": text, **kwargs.pop("files", {})}
    case(group, id, "validate", "scene.toml", *extra, files=files, expect=expect, **kwargs)


RUN = {  # each simulating command on scene.toml, writing out.nc
    "sweep": ("sweep", "scene.toml", "-o", "out.nc", "-q"),
    "trace": ("trace", "scene.toml", "-w", "0.965", "-o", "out.nc", "-q"),
    "branch": ("branch", "scene.toml", "-o", "out.nc", "-q"),
    "accuracy": ("accuracy", "scene.toml", "-o", "out.nc", "-q", "--quick"),
}


def run(group: str, id: str, command: str, text: str, *expect, extra=(), **kwargs) -> None:
    """A simulating command on a scene of that text."""
    files = {"scene.toml": text, **kwargs.pop("files", {})}
    case(group, id, *RUN[command], *extra, files=files, expect=expect, **kwargs)


# ---- values: a bad value of every kind for every key of every table --------------------
NAN, INF = float("nan"), float("inf")
GENERIC = {  # kind -> value
    "negative": -1,
    "zero": 0,
    "nan": NAN,
    "inf": INF,
    "string": "bogus",
    "bool": True,
    "list": [1],
    "table": {"a": 1},
    "fraction": 1.5,
}


def kinds(*names: str, **specific: Any) -> dict[str, Any]:
    """The bad values of a key: generic kinds by name, plus key-specific ones."""
    return {**{n: GENERIC[n] for n in names}, **specific}


NUMBER = ("negative", "zero", "nan", "inf", "string", "bool", "list", "table")
ZERO_VALID = ("negative", "nan", "inf", "string", "bool", "list", "table")
WHOLE = (*NUMBER, "fraction")
CHOICE = ("negative", "zero", "nan", "bool", "table")

BAD_VALUES: dict[str, dict[str, Any]] = {
    "rig.geometry": kinds(*CHOICE, string="bogus", empty="", list=["sphere-plane"]),
    "rig.ball_radius": kinds(*NUMBER),
    "rig.youngs_modulus": kinds(*NUMBER),
    "rig.poisson_ratio": kinds(*ZERO_VALID, half=0.5),
    "rig.mass": kinds(*NUMBER),
    "rig.static_load": kinds(*NUMBER),
    "rig.ball_mass": kinds(*NUMBER),
    "rig.ball_density": kinds(*NUMBER),
    "rig.natural_frequency": kinds(*NUMBER),
    "damping.ratio": kinds(*ZERO_VALID),
    "damping.law": kinds(*CHOICE, string="bogus", empty="", list=["viscous"]),
    "damping.exponent": kinds(*ZERO_VALID),
    "excitation.sigma": kinds(
        *NUMBER,
        list=["a"],
        empty_list=[],
        repeated=[0.01, 0.01],
        nested=[[0.01]],
        nan_in_list=[0.01, NAN],
        zero_in_list=[0.01, 0],
    ),
    "sweep.start": kinds(*NUMBER),
    "sweep.stop": kinds(*NUMBER),
    "sweep.step": kinds(*NUMBER),
    "sweep.directions": kinds(
        *CHOICE, string="sideways", empty_list=[], repeated=["up", "up"], list=[1]
    ),
    "sweep.settle_periods": kinds(*ZERO_VALID, "fraction"),
    "sweep.measure_periods": kinds(*WHOLE),
    "sweep.tolerance": kinds(*NUMBER),
    "sweep.max_settle_periods": kinds(*WHOLE),
    "sweep.jump_threshold": kinds(*NUMBER, one=1.0),
    "sweep.steady_state": kinds(*CHOICE, string="bogus", empty="", list=["settle"]),
    "sweep.period_multiple": kinds(*WHOLE, nine=9, large=10**6),
    "sweep.initial_state": kinds(
        "negative",
        "zero",
        "nan",
        "inf",
        "string",
        "bool",
        "table",
        list=[0.1],
        empty_list=[],
        three=[0.1, 0.0, 0.0],
        nested=[[0.1], [0.0]],
        nan_in_list=[0.1, NAN],
        inf_in_list=[INF, 0.0],
        string_in_list=[0.1, "0"],
        bool_in_list=[0.1, True],
    ),
    "solver.method": kinds(*CHOICE, string="bogus", empty="", list=["central-difference"]),
    "solver.steps_per_period": kinds(*WHOLE),
    "solver.max_steps": kinds(*WHOLE),
    "lockin.harmonics": kinds(
        *NUMBER,
        list=[[1]],
        empty_list=[],
        repeated=[1, 1],
        zero_in_list=[0, 1],
        string_in_list=[1, "2"],
        # orders that are not whole must be multiples of 1/2, 1/3 or 1/4 (within 1e-9)
        fifth=0.2,
        fifth_in_list=[0.2, 1],
        three_tenths=[0.3, 1],
        near_third=[0.333, 1],
        negative_half=[-0.5, 1],
        nan_in_list=[0.5, NAN],
        inf_in_list=[0.5, INF],
        repeated_half=[0.5, 0.5, 1],
        repeated_as_float=[1, 1.0],
        repeated_quarter=[0.25, 1, 2.5e-1],
    ),
}
BAD_VALUES["branch.follow_period_doubling"] = kinds(
    "negative", "zero", "nan", "string", "list", "table", one=1, word="yes"
)
for dotted, bad in BAD_VALUES.items():
    for kind, value in bad.items():
        validate("values", f"{dotted}={kind}", scene({dotted: value}), "scene.toml", dotted)
for value in ("0", "9", "1.5"):  # the n-period map's n from the command line
    set_value = ("--set", f"sweep.period_multiple={value}")
    name = f"set:sweep.period_multiple={value}"
    validate("values", name, scene(), "--set", "sweep.period_multiple", extra=set_value)
# a tap's state is the single model's: the ball model refuses it (validate, and a sweep)
BALL_TAP = scene({"model.kind": "ball", "sweep.initial_state": [0.1, 0.0]})
validate("values", "sweep.initial_state=ball-model", BALL_TAP, "scene.toml", "sweep.initial_state")
run("values", "sweep:initial_state=ball-model", "sweep", BALL_TAP, "scene.toml", "model.kind")

# ---- absurd values: in range by type, impossible to compute honestly --------------------
N256 = {"solver.steps_per_period": 256}
ABSURD: dict[str, tuple[dict[str, Any], tuple, tuple[str, ...]]] = {
    # id: (changes, keys one of which the line names, commands that must refuse it too)
    "harmonics-1000": ({"lockin.harmonics": [1000]}, ("lockin.harmonics",), tuple(RUN)),
    "harmonics-1-300-N256": (
        {**N256, "lockin.harmonics": [1, 300]},
        (("lockin.harmonics", "solver.steps_per_period"),),
        ("sweep",),
    ),
    "harmonics-1-200-N256-aliased": (
        {**N256, "lockin.harmonics": [1, 200]},
        (("lockin.harmonics", "solver.steps_per_period"),),
        ("sweep",),
    ),
    "harmonics-1-128-N256-nyquist": (
        {**N256, "lockin.harmonics": [1, 128]},
        (("lockin.harmonics", "solver.steps_per_period"),),
        (),
    ),
    "harmonics-64-N64": ({"lockin.harmonics": [64]}, ("lockin.harmonics",), ("trace",)),
    "step-1e-9": ({"sweep.step": 1e-9}, ("sweep.step",), ("sweep", "branch")),
    "steps-per-period-1e9": (
        {"solver.steps_per_period": 10**9},
        ("solver.steps_per_period",),
        ("sweep",),
    ),
    "steps-per-period-2**63-1": (
        {"solver.steps_per_period": 2**63 - 1},
        ("solver.steps_per_period",),
        ("trace",),
    ),
    "start-1e-13": ({"sweep.start": 1e-13}, ("sweep.start",), ("sweep",)),
    "stop-1e300": ({"sweep.stop": 1e300}, (("sweep.stop", "sweep.step"),), ("sweep",)),
    "settle-1e12": ({"sweep.settle_periods": 10**12}, ("sweep.settle_periods",), ("sweep",)),
    "measure-1e12": ({"sweep.measure_periods": 10**12}, ("sweep.measure_periods",), ("trace",)),
    # orders that are not whole are read over whole response periods (L excitation
    # periods, L the lcm of their denominators): measure_periods a multiple of L
    "half-order-measure-3": (
        {"lockin.harmonics": [0.5, 1], "sweep.measure_periods": 3},
        ("sweep.measure_periods", "3 is not a multiple of 2"),
        tuple(RUN),
    ),
    "third-and-quarter-measure-6": (
        {"lockin.harmonics": [1 / 3, 0.25, 1], "sweep.measure_periods": 6},
        ("sweep.measure_periods", "6 is not a multiple of 12"),
        ("sweep", "trace"),
    ),
    "half-order-measure-1": (
        {"lockin.harmonics": [1.5], "sweep.measure_periods": 1},
        ("sweep.measure_periods", "1 is not a multiple of 2"),
        ("sweep",),
    ),
    "youngs-modulus-1e-300": ({"rig.youngs_modulus": 1e-300}, ("rig.youngs_modulus",), ()),
    "ball-radius-1e300": ({"rig.ball_radius": 1e300}, ("rig.ball_radius",), ()),
    "ball-radius-1e-300": ({"rig.ball_radius": 1e-300}, ("rig.ball_radius",), ()),
    "mass-1e-300": ({"rig.mass": 1e-300}, ("rig.mass",), ()),
    "natural-frequency-1e300": ({"rig.natural_frequency": 1e300}, ("rig.natural_frequency",), ()),
    # sigma = 2 with zeta = 1e-5: within the stability limit it is a violent but
    # computable vibro-impact regime: refused, or run with finite numbers (may_succeed)
    "sigma-2-zeta-1e-5": (
        {"excitation.sigma": [2.0], "damping.ratio": 1e-5},
        (("excitation.sigma", "damping.ratio", "solver.steps_per_period"),),
        ("sweep",),
    ),
    "sigma-1e300": (
        {"excitation.sigma": [1e300]},
        (("excitation.sigma", "solver.steps_per_period"),),
        (),
    ),
}
MAY_SUCCEED = {"sigma-2-zeta-1e-5"}
for name, (changes, keys, commands) in ABSURD.items():
    text = scene(changes)
    honest = name in MAY_SUCCEED
    validate("absurd", f"validate:{name}", text, "scene.toml", *keys, may_succeed=honest)
    for command in commands:
        run("absurd", f"{command}:{name}", command, text, "scene.toml", *keys, may_succeed=honest)
for name in ("youngs-modulus-1e-300", "ball-radius-1e300", "ball-radius-1e-300"):
    changes, keys, _ = ABSURD[name]
    case("absurd", f"rig:{name}", "rig", "scene.toml", files={"scene.toml": scene(changes)},
         expect=("scene.toml", *keys))  # fmt: skip
case("absurd", "trace:periods-1e9", *RUN["trace"], "--periods", "1000000000",
     files={"scene.toml": scene()}, expect=("--periods",))  # fmt: skip
case("values", "trace:half-order-periods-3", *RUN["trace"], "--periods", "3",
     files={"scene.toml": scene({"lockin.harmonics": [0.5, 1]})},
     expect=("--periods", "3 is not a multiple of 2"))  # fmt: skip
validate("absurd", "set:steps-per-period-2**64", scene(), "--set", "solver.steps_per_period",
         extra=("--set", f"solver.steps_per_period={2**64}"))  # fmt: skip

# ---- random excitation: the bad values of a random scene -------------------------------
# The tiny scene driven by band-limited noise (excitation.kind = "random"): 1 level x 2
# realisations x 12 periods of 64 steps, Nyquist w = 32; every bad value is one change to it.
RANDOM_TINY = {
    "excitation.kind": "random",
    "excitation.rms": [0.01],
    "excitation.band": [0.2, 3.0],
    "random.realisations": 2,
    "random.duration_periods": 10,
    "random.transient_periods": 2,
    "random.segment_periods": 5,
}
RANDOM_BAD: dict[str, tuple[str, dict[str, Any], tuple]] = {
    # id: (class, changes, what the line names besides scene.toml)
    "band-at-nyquist": ("values", {"excitation.band": [0.2, 32.0]}, ("excitation.band", "Nyquist")),
    "band-above-the-steps-nyquist": (
        "values",
        {"solver.steps_per_period": 4},  # Nyquist w = 2, below w_high = 3
        ("excitation.band", "Nyquist"),
    ),
    "band-from-zero": ("values", {"excitation.band": [0.0, 3.0]}, ("excitation.band",)),
    "band-negative": ("values", {"excitation.band": [-0.2, 3.0]}, ("excitation.band",)),
    "band-infinite": ("values", {"excitation.band": [0.2, INF]}, ("excitation.band",)),
    "band-empty": ("values", {"excitation.band": [1.0, 1.0]}, ("excitation.band",)),
    "band-reversed": ("values", {"excitation.band": [3.0, 0.2]}, ("excitation.band",)),
    "band-one-number": ("values", {"excitation.band": [0.2]}, ("excitation.band",)),
    "band-without-a-line": (  # narrower than the record's lines 1/12 apart
        "values",
        {"excitation.band": [1.001, 1.002]},
        ("excitation.band", "holds no line"),
    ),
    "rms-zero": ("values", {"excitation.rms": [0.0]}, ("excitation.rms",)),
    "rms-negative": ("values", {"excitation.rms": [-0.01]}, ("excitation.rms",)),
    "rms-zero-in-list": ("values", {"excitation.rms": [0.01, 0.0]}, ("excitation.rms",)),
    "rms-none": ("values", {"excitation.rms": []}, ("excitation.rms",)),
    "realisations-zero": ("values", {"random.realisations": 0}, ("random.realisations",)),
    "realisations-negative": ("values", {"random.realisations": -1}, ("random.realisations",)),
    "transient-longer-than-duration": (
        "values",
        {"random.transient_periods": 11},
        ("random.transient_periods", "random.duration_periods"),
    ),
    "segment-longer-than-record": (
        "values",
        {"random.segment_periods": 11},
        ("random.segment_periods", "random.duration_periods"),
    ),
    # the step budget: 1,536 steps beyond a budget of 1,000; 1.28e11 beyond the default
    # 1e11; a million realisations' Welch buffers beyond the memory budget
    "steps-beyond-max-steps": ("absurd", {"solver.max_steps": 1000}, ("solver.max_steps",)),
    "duration-1e9": (
        "absurd",
        {"random.duration_periods": 10**9},
        ("random.duration_periods", "integration steps"),
    ),
    "realisations-1e6": (
        "absurd",
        {"random.realisations": 10**6},
        ("random.realisations", "memory budget"),
    ),
}
for name, (group, changes, expect) in RANDOM_BAD.items():
    validate(group, f"random:{name}", scene({**RANDOM_TINY, **changes}), "scene.toml", *expect)

# ---- keys and tables ---------------------------------------------------------------------
for table in TINY:
    validate("keys", f"unknown-key:{table}", scene({f"{table}.bogus": 1}), "scene.toml",
             f"{table}.bogus")  # fmt: skip
for table in ("damping", "excitation", "sweep", "solver", "lockin"):
    validate("keys", f"table-is-number:{table}", scene({table: 3}), "scene.toml", table)
    validate("keys", f"table-is-list:{table}", scene({table: [{"a": 1}]}), "scene.toml", table)
for key in ("ball_radius", "youngs_modulus", "poisson_ratio", "mass"):
    validate("keys", f"missing:rig.{key}", scene({f"rig.{key}": DROP}), "scene.toml", f"rig.{key}")
validate("keys", "unknown-table", scene({"bogus": {"a": 1}}), "scene.toml", "bogus")
validate("keys", "unknown-top-level-key", scene(foo=1), "scene.toml", "foo")
validate("keys", "missing-rig", "[damping]\nratio = 0.01\n", "scene.toml", "rig")
validate("keys", "rig-table-empty", scene(rig={}), "scene.toml", "rig.")

# ---- input files -------------------------------------------------------------------------
validate("files", "non-utf8", scene().encode() + b"# \xff\xfe\xfd\n", "scene.toml")
validate("files", "latin1-comment", b"# caf\xe9\n" + scene().encode(), "scene.toml")
validate("files", "binary-garbage", GARBAGE, "scene.toml")
validate("files", "nul-bytes", b"[rig]\x00\nmass = 1\n", "scene.toml")
validate("files", "nul-in-string", scene().encode() + b'x = "\x00"\n', "scene.toml")
validate("files", "empty-file", "", "scene.toml", "rig")
validate("files", "only-comments", "# nothing\n", "scene.toml", "rig")
validate("files", "invalid-toml", "[rig\nmass = \n", "scene.toml")
validate("files", "duplicate-key", scene() + "[damping]\nratio = 1\n", "scene.toml")
validate("files", "utf16", scene().encode("utf-16"), "scene.toml")
case("files", "directory", "validate", "scenes", special=(("dir", "scenes"),), expect=("scenes",))
case("files", "directory-slash", "validate", "scenes/", special=(("dir", "scenes"),),
     expect=("scenes",))  # fmt: skip
case("files", "fifo", "validate", "fifo.toml", special=(("fifo", "fifo.toml"),),
     expect=("fifo.toml",), idle=True)  # fmt: skip
case("files", "sweep:fifo", *RUN["sweep"][:1], "fifo.toml", *RUN["sweep"][2:],
     special=(("fifo", "fifo.toml"),), expect=("fifo.toml",), idle=True)  # fmt: skip
case("files", "rig:fifo", "rig", "fifo.toml", special=(("fifo", "fifo.toml"),),
     expect=("fifo.toml",), idle=True)  # fmt: skip
case("files", "dev-zero", "validate", "/dev/zero", expect=("/dev/zero",))
case("files", "rig:dev-zero", "rig", "/dev/zero", expect=("/dev/zero",))
case("files", "dev-null", "validate", "/dev/null", expect=("/dev/null",))
case("files", "oversized", "validate", "huge.toml", special=(("sparse", "huge.toml"),),
     expect=("huge.toml",))  # fmt: skip
case("files", "missing", "validate", "missing.toml", expect=("missing.toml",))
case("files", "missing-non-utf8-name", "validate", b"missing-\xff.toml", expect=("missing-",))
case("files", "symlink-loop", "validate", "loop.toml", special=(("loop", "loop.toml"),),
     expect=("loop.toml",))  # fmt: skip
if not IS_ROOT:  # root reads any file
    case("files", "unreadable", "validate", "scene.toml", files={"scene.toml": scene()},
         special=(("unreadable", "scene.toml"),), expect=("scene.toml",))  # fmt: skip
validate("files", "rig-cycle", scene(rig="cycle-two.toml"), ("scene.toml", "cycle-two.toml"),
         "rig", files={"cycle-two.toml": 'rig = "scene.toml"\n'})  # fmt: skip
validate("files", "rig-self", scene(rig="scene.toml"), "scene.toml", "rig")
validate("files", "rig-file-other-tables", scene(rig="rigfile.toml"), "rigfile.toml", "damping",
         files={"rigfile.toml": rig_file(damping={"ratio": 0.01})})  # fmt: skip
validate("files", "rig-file-without-rig", scene(rig="rigfile.toml"), "rigfile.toml", "rig",
         files={"rigfile.toml": "[damping]\nratio = 0.01\n"})  # fmt: skip
validate("files", "rig-file-empty", scene(rig="rigfile.toml"), "rigfile.toml", "rig",
         files={"rigfile.toml": ""})  # fmt: skip
validate("files", "rig-file-bad-value", scene(rig="rigfile.toml"), "rigfile.toml", "rig.mass",
         files={"rigfile.toml": rig_file({"mass": -1})})  # fmt: skip
validate("files", "rig-file-unknown-key", scene(rig="rigfile.toml"), "rigfile.toml", "rig.bogus",
         files={"rigfile.toml": rig_file({"bogus": 1})})  # fmt: skip
validate("files", "rig-file-missing-key", scene(rig="rigfile.toml"), "rigfile.toml", "rig.mass",
         files={"rigfile.toml": rig_file({"mass": DROP})})  # fmt: skip
validate("files", "rig-file-non-utf8", scene(rig="rigfile.toml"), "rigfile.toml",
         files={"rigfile.toml": b"[rig]\n# \xff\n"})  # fmt: skip
validate("files", "rig-file-invalid-toml", scene(rig="rigfile.toml"), "rigfile.toml",
         files={"rigfile.toml": "[rig\n"})  # fmt: skip
case("files", "rig:rig-file-bad-value", "rig", "scene.toml",
     files={"scene.toml": scene(rig="rigfile.toml"), "rigfile.toml": rig_file({"mass": -1})},
     expect=("rigfile.toml", "rig.mass"))  # fmt: skip
validate("files", "rig-is-number", scene(rig=3), "scene.toml", "rig")
validate("files", "rig-is-list", scene(rig=["rigfile.toml"]), "scene.toml", "rig")
validate("files", "rig-is-empty-string", scene(rig=""), "scene.toml", "rig")
validate("files", "rig-file-missing", scene(rig="missing-rig.toml"), "missing-rig.toml")
validate("files", "rig-file-directory", scene(rig="rigdir"), "rigdir",
         special=(("dir", "rigdir"),))  # fmt: skip
validate("files", "rig-file-fifo", scene(rig="rigfifo.toml"), "rigfifo.toml",
         special=(("fifo", "rigfifo.toml"),), idle=True)  # fmt: skip
validate("files", "rig-file-dev-zero", scene(rig="/dev/zero"), "/dev/zero")


def study(id: str, text: str | bytes, *expect, files=None, **kwargs) -> None:
    """``hertzsweep study study.toml`` (one local worker) over the tiny scene."""
    files = {"study.toml": text, "scene.toml": scene(), **(files or {})}
    case("files", f"study:{id}", "study", "study.toml", "-o", "out.nc", "-q", "--workers", "1",
         files=files, expect=expect, **kwargs)  # fmt: skip


# A refused study costs a worker pool's start and stop (2.5 s): few cases, one per check.
GRID = '\n[grid]\n"damping.ratio" = [0.004, 0.005]\n'
study("scene-is-itself", 'scene = "study.toml"\n' + GRID, "study.toml", "scene")
study("grid-harmonics-1000", 'scene = "scene.toml"\n[grid]\n"lockin.harmonics" = [1, 1000]\n',
      "study.toml", "lockin.harmonics")  # fmt: skip
study("grid-step-1e-9", 'scene = "scene.toml"\n[grid]\n"sweep.step" = [0.005, 1e-9]\n',
      "study.toml", "sweep.step")  # fmt: skip
study("grid-not-a-list", 'scene = "scene.toml"\n[grid]\n"damping.ratio" = 0.004\n',
      "study.toml", "damping.ratio")  # fmt: skip
study("kind", 'kind = "trace"\nscene = "scene.toml"\n' + GRID, "study.toml", "kind")
study("scene-missing", 'scene = "missing-scene.toml"\n' + GRID, "study.toml", "scene")
study("scene-dev-zero", 'scene = "/dev/zero"\n' + GRID, "/dev/zero")
study("binary-garbage", GARBAGE, "study.toml")
study("scene-bad-value", STUDY, "scene.toml", "sweep.step",
      files={"scene.toml": scene({"sweep.step": -1})})  # fmt: skip
study("override-bad-value", STUDY + "[sweep]\nstep = -1\n", "study.toml", "sweep.step")
case("files", "study:missing", "study", "missing-study.toml", "-o", "out.nc", "--workers", "1",
     expect=("missing-study.toml",))  # fmt: skip


# ---- output paths ------------------------------------------------------------------------
def output(id: str, out: str, *expect, command: str = "sweep", **kwargs) -> None:
    """A valid run of the tiny scene whose -o is bad."""
    files = {"scene.toml": scene(), **kwargs.pop("files", {})}
    argv = [out if a == "out.nc" else a for a in RUN[command]]
    case("outputs", f"{command}:{id}", *argv, files=files, expect=expect, **kwargs)


OUTPUT_OPTION = ("-o", "--output")
output("empty", "", OUTPUT_OPTION)
output("new-folder-slash", "newdir/", "newdir")
output("existing-folder", "outdir", "outdir", special=(("dir", "outdir"),))
output("existing-folder-slash", "outdir/", "outdir", special=(("dir", "outdir"),))
output("dot", ".", (".:", "'.'", *OUTPUT_OPTION))
output("fifo", "out.fifo", "out.fifo", special=(("fifo", "out.fifo"),), idle=True)
if IS_ROOT:  # root may replace /dev/null itself: a private device of the same kind instead
    output("null-device", "null", "null", special=(("null", "null"),))
else:
    output("dev-null", "/dev/null", "/dev/null", outside=("/dev/null",))
output("is-the-scene", "scene.toml", "scene.toml")
output("symlink", "link.nc", "link.nc", special=(("link", "link.nc"),))
output("is-the-scene-dot-slash", "./scene.toml", "scene.toml")
output("is-the-scene-absolute", "{dir}/scene.toml", "scene.toml")
output("is-the-rig-file", "rigfile.toml", "rigfile.toml",
       files={"scene.toml": scene(rig="rigfile.toml"), "rigfile.toml": rig_file()})  # fmt: skip
output("missing-parent", "nodir/out.nc", "nodir")
output("parent-is-a-file", "scene.toml/out.nc", "scene.toml")
output("name-too-long", "x" * 300 + ".nc", "xxxxxxxx")
if IS_ROOT:  # root writes in any folder with write permission missing: a read-only one
    output("unwritable-parent", "/sys/hertzsweep-out.nc", "/sys",
           outside=("/sys/hertzsweep-out.nc",))  # fmt: skip
else:
    output("unwritable-parent", "locked/out.nc", "locked", special=(("locked", "locked"),))
output("is-the-scene", "scene.toml", "scene.toml", command="trace")
output("existing-folder", "outdir", "outdir", command="trace", special=(("dir", "outdir"),))
output("missing-parent", "nodir/out.nc", "nodir", command="branch")
output("is-the-scene", "scene.toml", "scene.toml", command="branch")
case("outputs", "import:is-the-input", "import", "data.csv", "-o", "data.csv",
     files={"data.csv": CSV}, expect=("data.csv",))  # fmt: skip
case("outputs", "import:empty", "import", "data.csv", "-o", "", files={"data.csv": CSV},
     expect=(OUTPUT_OPTION,))  # fmt: skip
case("outputs", "import:missing-parent", "import", "data.csv", "-o", "nodir/out.nc",
     files={"data.csv": CSV}, expect=("nodir",))  # fmt: skip
case("outputs", "study:is-the-study", "study", "study.toml", "-o", "study.toml", "--workers", "1",
     files={"study.toml": STUDY, "scene.toml": scene()}, expect=("study.toml",))  # fmt: skip
case("outputs", "study:is-the-scene", "study", "study.toml", "-o", "scene.toml", "--workers", "1",
     files={"study.toml": STUDY, "scene.toml": scene()}, expect=("scene.toml",))  # fmt: skip

# ---- --set -------------------------------------------------------------------------------
SET = {  # id: (--set text, the key or text the line names)
    "no-equals": ("damping.ratio", "damping.ratio"),
    "no-dot": ("ratio=0.01", "ratio"),
    "unknown-table": ("bogus.key=1", "bogus.key"),
    "unknown-key": ("damping.bogus=1", "damping.bogus"),
    "empty-value": ("damping.ratio=", "damping.ratio"),
    "blank-value": ("damping.ratio=   ", "damping.ratio"),
    "empty-key": ("=0.01", "--set"),
    "empty": ("", "--set"),
    "too-deep": ("damping.ratio.x=1", "damping.ratio.x"),
    "empty-name": ("damping.=1", "damping."),
    "table-only": ("damping=1", "damping"),
    "bad-toml-value": ("damping.ratio=[0.01", "damping.ratio"),
    "nan": ("damping.ratio=nan", "damping.ratio"),
    "inf": ("sweep.stop=inf", "sweep.stop"),
    "string": ("sweep.step=fast", "sweep.step"),
    "table-value": ("sweep.step={a=1}", "sweep.step"),
    "harmonics-1000": ("lockin.harmonics=[1000]", "lockin.harmonics"),
    "step-1e-9": ("sweep.step=1e-9", "sweep.step"),
    "rig-key-of-rig-file": ("rig.mass=-1", "rig.mass"),
    "rig-unknown-key": ("rig.bogus=1", "rig.bogus"),
    "rig-as-value": ("rig.mass=[1]", "rig.mass"),
}
for name, (text, key) in SET.items():
    validate("set", name, scene(rig="rigfile.toml"), "--set", key, extra=("--set", text),
             files={"rigfile.toml": rig_file()})  # fmt: skip
for command in ("sweep", "trace", "branch"):
    run("set", f"{command}:harmonics-1000", command, scene(), "--set", "lockin.harmonics",
        extra=("--set", "lockin.harmonics=[1000]"))  # fmt: skip

# ---- commands: missing files, files of the wrong kind, bad options -----------------------
for command in RUN:
    argv = [("missing.toml" if a == "scene.toml" else a) for a in RUN[command]]
    case("commands", f"{command}:missing-scene", *argv, expect=("missing.toml",))
case("commands", "validate:missing-scene", "validate", "missing.toml", expect=("missing.toml",))
case("commands", "rig:missing", "rig", "missing.toml", expect=("missing.toml",))
case("commands", "rig:binary-garbage", "rig", "scene.toml", files={"scene.toml": GARBAGE},
     expect=("scene.toml",))  # fmt: skip
case("commands", "rig:bad-scene", "rig", "scene.toml",
     files={"scene.toml": scene({"damping.ratio": "high"})},
     expect=("scene.toml", "damping.ratio"))  # fmt: skip
case("commands", "plot:missing", "plot", "missing.nc", "-o", "fig.png", expect=("missing.nc",))
case("commands", "plot:not-netcdf", "plot", "data.nc", "-o", "fig.png",
     files={"data.nc": GARBAGE}, expect=("data.nc",))  # fmt: skip
case("commands", "plot:empty-file", "plot", "data.nc", "-o", "fig.png", files={"data.nc": ""},
     expect=("data.nc",))  # fmt: skip
case("commands", "plot:toml", "plot", "scene.toml", "-o", "fig.png",
     files={"scene.toml": scene()}, expect=("scene.toml",))  # fmt: skip
case("commands", "plot:foreign-netcdf", "plot", "data.nc", "-o", "fig.png",
     special=(("netcdf", "data.nc"),), expect=("data.nc",))  # fmt: skip
case("commands", "plot:unknown-format", "plot", "data.nc", "-o", "fig.xyz",
     files={"data.nc": GARBAGE}, expect=("fig.xyz",))  # fmt: skip
case("commands", "plot:directory", "plot", "data", "-o", "fig.png", special=(("dir", "data"),),
     expect=("data",))  # fmt: skip
case("commands", "plot:dpi-0", "plot", "data.nc", "-o", "fig.png", "--dpi", "0",
     files={"data.nc": GARBAGE}, expect=("--dpi",))  # fmt: skip
case("commands", "compare:missing", "compare", "missing.nc", "ref.nc",
     files={"ref.nc": GARBAGE}, expect=("missing.nc",))  # fmt: skip
case("commands", "compare:missing-reference", "compare", "run.nc", "missing.nc",
     special=(("netcdf", "run.nc"),), expect=("missing.nc",))  # fmt: skip
case("commands", "compare:not-netcdf", "compare", "run.nc", "ref.nc",
     files={"run.nc": GARBAGE, "ref.nc": GARBAGE}, expect=("run.nc",))  # fmt: skip
case("commands", "compare:reference-not-netcdf", "compare", "run.nc", "ref.nc",
     files={"ref.nc": GARBAGE}, special=(("netcdf", "run.nc"),), expect=("ref.nc",))  # fmt: skip
case("commands", "compare:bad-var", "compare", "run.nc", "ref.nc", "--var", "amplitude=abc",
     special=(("netcdf", "run.nc"), ("netcdf", "ref.nc")), expect=("--var",))  # fmt: skip
case("commands", "rerun:missing", "rerun", "missing.nc", "-o", "out.nc", expect=("missing.nc",))
case("commands", "rerun:not-netcdf", "rerun", "data.nc", "-o", "out.nc",
     files={"data.nc": GARBAGE}, expect=("data.nc",))  # fmt: skip
case("commands", "rerun:foreign-netcdf", "rerun", "data.nc", "-o", "out.nc",
     special=(("netcdf", "data.nc"),), expect=("data.nc",))  # fmt: skip
case("commands", "import:missing", "import", "missing.csv", "-o", "out.nc",
     expect=("missing.csv",))  # fmt: skip
case("commands", "import:binary-garbage", "import", "data.csv", "-o", "out.nc",
     files={"data.csv": GARBAGE}, expect=("data.csv",))  # fmt: skip
case("commands", "import:empty", "import", "data.csv", "-o", "out.nc", files={"data.csv": ""},
     expect=("data.csv",))  # fmt: skip
case("commands", "import:header-only", "import", "data.csv", "-o", "out.nc",
     files={"data.csv": CSV.splitlines()[0] + "\n"}, expect=("data.csv",))  # fmt: skip
case("commands", "import:bad-number", "import", "data.csv", "-o", "out.nc",
     files={"data.csv": CSV.replace("0.984", "abc")},
     expect=("data.csv", "jump_frequency_ratio"))  # fmt: skip
case("commands", "import:nan", "import", "data.csv", "-o", "out.nc",
     files={"data.csv": CSV.replace("0.984", "nan")},
     expect=("data.csv", "jump_frequency_ratio"))  # fmt: skip
case("commands", "import:directory", "import", "data", "-o", "out.nc",
     special=(("dir", "data"),), expect=("data",))  # fmt: skip
case("commands", "import:fifo", "import", "data.csv", "-o", "out.nc",
     special=(("fifo", "data.csv"),), expect=("data.csv",), idle=True)  # fmt: skip
LOCKIN = "freq,X,Y\n230,0.01,-0.02\n231,0.012,-0.03\n232,0.011,-0.04\n"  # SR830-style, volts
LOCKIN_MAP = ("--columns", "frequency=freq,x=X,y=Y")
case("commands", "import:lockin-unknown-quantity", "import", "data.csv", "-o", "out.nc",
     "--columns", "frequency=freq,x=X,y=Y,bogus=Z", "--sigma", "0.01",
     files={"data.csv": LOCKIN}, expect=("data.csv", "--columns"))  # fmt: skip
case("commands", "import:lockin-missing-column", "import", "data.csv", "-o", "out.nc",
     "--columns", "frequency=freq,x=X,y=Yq", "--sigma", "0.01",
     files={"data.csv": LOCKIN}, expect=("data.csv", "Yq"))  # fmt: skip
case("commands", "import:lockin-negative-sensitivity", "import", "data.csv", "-o", "out.nc",
     *LOCKIN_MAP, "--sigma", "0.01", "--sensitivity", "-0.0224", "--static-load", "110",
     files={"data.csv": LOCKIN}, expect=("data.csv", "--sensitivity"))  # fmt: skip
case("commands", "import:lockin-not-monotonic", "import", "data.csv", "-o", "out.nc",
     *LOCKIN_MAP, "--sigma", "0.01", "--direction", "up",
     files={"data.csv": LOCKIN.replace("231,", "229,")}, expect=("data.csv", "freq"))  # fmt: skip
case("commands", "import:lockin-not-a-number", "import", "data.csv", "-o", "out.nc",
     *LOCKIN_MAP, "--sigma", "0.01",
     files={"data.csv": LOCKIN.replace("0.012", "abc")}, expect=("data.csv", "X"))  # fmt: skip
case("commands", "import:lockin-no-level", "import", "data.csv", "-o", "out.nc", *LOCKIN_MAP,
     files={"data.csv": LOCKIN}, expect=("data.csv", "--sigma"))  # fmt: skip
case("commands", "import:lockin-sensitivity-without-load", "import", "data.csv", "-o", "out.nc",
     *LOCKIN_MAP, "--sigma", "0.01", "--sensitivity", "0.0224",
     files={"data.csv": LOCKIN}, expect=("data.csv", "--static-load"))  # fmt: skip
case("commands", "import:json-not-rows", "import", "data.json", "-o", "out.nc", *LOCKIN_MAP,
     "--sigma", "0.01", files={"data.json": "[1, 2, 3]"}, expect=("data.json",))  # fmt: skip
case("commands", "import:map-unknown-key", "import", "data.csv", "-o", "out.nc",
     "--map", "map.toml", "--sigma", "0.01",
     files={"data.csv": LOCKIN, "map.toml": "bogus = 1\n"},
     expect=("map.toml", "bogus"))  # fmt: skip
case("commands", "import:map-not-toml", "import", "data.csv", "-o", "out.nc",
     "--map", "map.toml", "--sigma", "0.01",
     files={"data.csv": LOCKIN, "map.toml": "[columns\n"}, expect=("map.toml",))  # fmt: skip
case("commands", "export:missing", "export", "missing.nc", "-o", "out.uff",
     expect=("missing.nc",))  # fmt: skip
case("commands", "export:not-netcdf", "export", "data.nc", "-o", "out.uff",
     files={"data.nc": GARBAGE}, expect=("data.nc",))  # fmt: skip
case("commands", "export:foreign-netcdf", "export", "data.nc", "-o", "out.uff",
     special=(("netcdf", "data.nc"),), expect=("hertzsweep_kind",))  # fmt: skip


def uff_bytes(**fields: Any) -> bytes:
    """A UFF 58 file (ASCII) of one H1 set of three points written by pyuff alone, with
    ``fields`` changed."""
    import tempfile

    import numpy as np
    import pyuff

    dset = pyuff.prepare_58(binary=0, func_type=4, rsp_node=1, rsp_dir=3, ref_node=2,
                            ref_dir=3, abscissa_spacing=0, abscissa_spec_data_type=18,
                            ordinate_spec_data_type=9, orddenom_spec_data_type=13,
                            z_axis_value=0.01, x=np.array([230.0, 231.0, 232.0]),
                            data=np.array([1 + 1j, 2 - 1j, 1.5 + 0.5j]))  # fmt: skip
    dset["z_axis_axis_lab"] = "sigma"
    dset.update(fields)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "data.uff")
        pyuff.UFF(path).write_sets([dset], mode="add")
        with open(path, "rb") as handle:
            return handle.read()


case("commands", "import:uff-func-type", "import", "data.uff", "-o", "out.nc",
     files={"data.uff": uff_bytes(func_type=1)}, expect=("data.uff", "func_type"))  # fmt: skip
case("commands", "import:uff-accelerance-without-mass", "import", "data.uff", "-o", "out.nc",
     files={"data.uff": uff_bytes(ordinate_spec_data_type=12)},
     expect=("data.uff", "ordinate_spec_data_type"))  # fmt: skip
case("commands", "import:uff-not-uff", "import", "data.uff", "-o", "out.nc",
     files={"data.uff": "    -1\n    58\nnot a dataset\n    -1\n"},
     expect=("data.uff",))  # fmt: skip
case("commands", "import:uff-no-level", "import", "data.uff", "-o", "out.nc",
     files={"data.uff": uff_bytes(z_axis_axis_lab="", z_axis_value=0.0)},
     expect=("data.uff", "--sigma"))  # fmt: skip
FIT = ("--scene", "scene.toml", "--free", "damping.ratio", "-o", "fit.nc", "-q")
case("commands", "fit:missing-measurements", "fit", "missing.csv", *FIT,
     files={"scene.toml": scene()}, expect=("missing.csv",))  # fmt: skip
case("commands", "fit:not-netcdf", "fit", "data.nc", *FIT,
     files={"scene.toml": scene(), "data.nc": GARBAGE}, expect=("data.nc",))  # fmt: skip
case("commands", "fit:missing-scene", "fit", "data.csv", *FIT, files={"data.csv": CSV},
     expect=("scene.toml",))  # fmt: skip
case("commands", "fit:bad-scene", "fit", "data.csv", *FIT,
     files={"data.csv": CSV, "scene.toml": scene({"lockin.harmonics": [1000]})},
     expect=("scene.toml", "lockin.harmonics"))  # fmt: skip
case("commands", "fit:unknown-free-key", "fit", "data.csv", *FIT[:3], "damping.bogus", *FIT[4:],
     files={"data.csv": CSV, "scene.toml": scene()}, expect=("damping.bogus",))  # fmt: skip
TRACE_OPTIONS = {  # id: (extra arguments, the option the line names)
    "frequency-0": (("-w", "0"), ("-w", "--frequency")),
    "frequency-negative": (("-w", "-1"), ("-w", "--frequency")),
    "frequency-nan": (("-w", "nan"), ("-w", "--frequency")),
    "frequency-inf": (("-w", "inf"), ("-w", "--frequency")),
    # far beyond the ball's own mode; its step 2 pi / (w N) underflowed the scheme's
    # constants (a ZeroDivisionError traceback): refused above w = 1000
    "frequency-1e300": (("-w", "1e300"), ("-w", "--frequency")),
    "frequency-below-the-stability-limit": (("-w", "1e-3"), ("solver.steps_per_period",)),
    "periods-0": (("--periods", "0"), ("--periods",)),
    "periods-negative": (("--periods", "-1"), ("--periods",)),
    "samples-per-period-0": (("--samples-per-period", "0"), ("--samples-per-period",)),
    "samples-per-period-not-divisor": (("--samples-per-period", "7"), ("--samples-per-period",)),
    "samples-per-period-above-steps": (("--samples-per-period", "128"), ("--samples-per-period",)),
    "branch": (("--branch", "middle"), ("--branch",)),
}
for name, (extra, option) in TRACE_OPTIONS.items():
    run("commands", f"trace:{name}", "trace", scene(), option, extra=extra)
case("commands", "accuracy:steps-garbage", *RUN["accuracy"], "--steps", "a,b",
     files={"scene.toml": scene()}, expect=("--steps",))  # fmt: skip
case("commands", "accuracy:steps-zero", *RUN["accuracy"], "--steps", "0",
     files={"scene.toml": scene()}, expect=("--steps",))  # fmt: skip
case("commands", "accuracy:settle-garbage", *RUN["accuracy"], "--settle", "x",
     files={"scene.toml": scene()}, expect=("--settle",))  # fmt: skip
case("commands", "accuracy:target-negative", *RUN["accuracy"], "--target", "-1",
     files={"scene.toml": scene()}, expect=("--target",))  # fmt: skip
case("commands", "study:workers-0", "study", "study.toml", "-o", "out.nc", "--workers", "0",
     files={"study.toml": STUDY, "scene.toml": scene()}, expect=("--workers",))  # fmt: skip
case("commands", "study:workers-and-scheduler", "study", "study.toml", "-o", "out.nc",
     "--workers", "1", "--scheduler", "tcp://127.0.0.1:1",
     files={"study.toml": STUDY, "scene.toml": scene()}, expect=("--workers",))  # fmt: skip
case("commands", "unknown-command", "bogus", expect=("bogus",))
case("commands", "sweep:unknown-option", *RUN["sweep"], "--bogus", files={"scene.toml": scene()},
     expect=("--bogus",))  # fmt: skip

# ---- dask: a scheduler that cannot be reached ---------------------------------------------
# Every address is on this machine: nothing is sent beyond the loopback. One that answers
# garbage sends bytes that read as a frame of exabytes. A scheduler that never answers (a
# local server that accepts and stays silent) costs the whole connect deadline, 10 s: it
# is tested on the connect itself with a 1 s deadline (test_scheduler.py).
SCHEDULERS = {
    "closed-port": "tcp://127.0.0.1:1",
    "answers-garbage": "{garbage}",
    "garbage": "garbage",
    "no-port": "tcp://127.0.0.1",
    "port-out-of-range": "tcp://127.0.0.1:99999",
    "unknown-protocol": "bogus://127.0.0.1:8786",
    "empty": "",
    "spaces": "   ",
}
for name, address in SCHEDULERS.items():
    shown = "127.0.0.1" if address.startswith("{") else address
    alternatives = ("--scheduler", shown) if address.strip() else ("--scheduler",)
    case("dask", f"scheduler:{name}", "study", "study.toml", "-o", "out.nc", "-q",
         "--scheduler", address, files={"study.toml": STUDY, "scene.toml": scene()},
         expect=(alternatives,), timeout=SCHEDULER_SECONDS)  # fmt: skip


# --------------------------------------------------------------------------- processes
# Starting an interpreter and importing hertzsweep costs 0.2 s (validate) to 1 s (sweep)
# of CPU per process, 100 to 200 s for the table: most cases are therefore forked from a
# fork server, a fresh `python -c FORK_SERVER` that has imported every command's module
# once (under MEMORY_LIMIT), then forks one child per case. The child is a separate process
# (a crash kills only it) in a session of its own, runs `hertzsweep ARGS` exactly as the
# console script does (main() with sys.argv; the streams are the server's, pointed at the
# case's files), and its exit status is reported back. The cases of `fresh` commands (a
# study against a Dask scheduler: its time bound includes the start-up) start a new
# interpreter instead.
FORK_SERVER = f"""
import importlib, json, os, select, signal, sys, time, traceback
import resource
resource.setrlimit(resource.RLIMIT_AS, ({MEMORY_LIMIT}, {MEMORY_LIMIT}))
from hertzsweep.cli import main
from hertzsweep.cli.group import COMMANDS
for module in sorted({{m for m, _ in COMMANDS.values()}}):
    importlib.import_module("hertzsweep.cli." + module)
replies = os.fdopen(os.dup(1), "w")

def child(request):
    try:
        replies.close()
        os.setsid()
        os.chdir(request["cwd"])
        for fd, path, flags in ((0, os.devnull, os.O_RDONLY),
                                (1, request["out"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC),
                                (2, request["err"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC)):
            opened = os.open(path, flags, 0o600)
            os.dup2(opened, fd)
            os.close(opened)
        sys.argv = ["hertzsweep", *request["argv"]]
        main()
    except BaseException:
        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)

def left_behind(pid):
    out = 0
    for entry in os.listdir("/proc"):
        if entry.isdigit() and int(entry) != pid:
            try:
                with open(f"/proc/{{entry}}/stat") as fh:
                    fields = fh.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            out += int(fields[2]) == pid
    return out

running = set()
ended = {{}}  # pid -> when its leader ended (the group may take a moment to follow)
buffer = b""
print("ready", flush=True, file=replies)
while True:
    readable, _, _ = select.select([0], [], [], 0.005 if running else None)
    if readable:
        chunk = os.read(0, 1 << 16)
        if not chunk:
            break
        buffer += chunk
        while b"\\n" in buffer:
            line, buffer = buffer.split(b"\\n", 1)
            request = json.loads(line)
            pid = os.fork()
            if pid == 0:
                child(request)
            running.add(pid)
            print("started", request["id"], pid, flush=True, file=replies)
    now = time.monotonic()
    for pid in list(running):
        if pid not in ended:
            info = os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
            if info is None:
                continue
            ended[pid] = now
            print("ended", pid, flush=True, file=replies)
        left = left_behind(pid)
        if left and now - ended[pid] < {GRACE_SECONDS}:
            continue
        del ended[pid]
        try:
            os.killpg(pid, signal.SIGKILL)  # the leader is unreaped: the group is still its
        except OSError:
            pass
        _, status = os.waitpid(pid, 0)
        running.discard(pid)
        print("exited", pid, os.waitstatus_to_exitcode(status), left, flush=True, file=replies)
"""


class ForkServer:
    """The client of FORK_SERVER: :meth:`run` may be called from several threads."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.stderr = folder / "fork-server.err"
        with open(self.stderr, "wb") as err:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", FORK_SERVER],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=err,
            )
        assert self.proc.stdout.readline() == b"ready\n", self.stderr.read_text()
        self.lock = threading.Lock()
        # number -> futures of (its pid, the leader's end, (exit status, processes left))
        self.jobs: dict[int, tuple[Future, Future, Future]] = {}
        self.numbers: dict[int, int] = {}  # pid -> number
        self.counter = itertools.count(1)
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            word, *fields = line.decode().split()
            with self.lock:
                if word == "started":
                    number, pid = map(int, fields)
                    self.numbers[pid] = number
                    self.jobs[number][0].set_result(pid)
                elif word == "ended":
                    self.jobs[self.numbers[int(fields[0])]][1].set_result(None)
                else:
                    pid, status, left = map(int, fields)
                    self.jobs.pop(self.numbers.pop(pid))[2].set_result((status, left))

    def run(self, argv: list[str | bytes], cwd: Path, timeout: float) -> tuple[Any, ...]:
        """(exit status or None when killed at the timeout, stderr bytes, processes left
        GRACE_SECONDS after the exit)."""
        started, ended, exited = Future(), Future(), Future()
        with self.lock:
            number = next(self.counter)
            self.jobs[number] = (started, ended, exited)
            err = self.folder / f"{number}.err"
            text = [a if isinstance(a, str) else a.decode("utf-8", "surrogateescape") for a in argv]
            request = {"id": number, "argv": text, "cwd": str(cwd), "out": os.devnull}
            request["err"] = str(err)
            self.proc.stdin.write(json.dumps(request).encode() + b"\n")
            self.proc.stdin.flush()
        pid = started.result(timeout=60)
        try:
            ended.result(timeout=timeout)
            hung = False
        except TimeoutError:
            _kill_group(pid)  # unreaped until the server sees it end: the group is still its
            hung = True
        status, left = exited.result(timeout=GRACE_SECONDS + 60)
        return None if hung else status, err.read_bytes(), left

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=60)


def run_fresh(argv: list[str | bytes], cwd: Path, timeout: float) -> tuple[Any, ...]:
    """The same as :meth:`ForkServer.run` in a new interpreter."""
    proc = subprocess.Popen(
        [sys.executable, "-c", PRELUDE, *argv],
        cwd=cwd,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        start_new_session=True,  # its own process group: a timeout ends its children too
    )
    try:
        _, err = proc.communicate(timeout=timeout)  # helpers holding stderr are waited for
        return proc.returncode, err, 0
    except subprocess.TimeoutExpired:
        # unreaped, the leader keeps the group's id: the kill reaches only its processes
        exited = os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT)
        _kill_group(proc.pid)
        _, err = proc.communicate()
        return (proc.returncode, err, 1) if exited is not None else (None, err, 0)


class LoopbackScheduler:
    """A TCP server on 127.0.0.1 that accepts connections and either says nothing or sends
    ``reply`` once; it holds each connection open until :meth:`close`."""

    def __init__(self, reply: bytes = b"") -> None:
        self.reply = reply
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.address = f"tcp://127.0.0.1:{self.listener.getsockname()[1]}"
        self.connections: list[socket.socket] = []
        threading.Thread(target=self._serve, daemon=True).start()

    def _serve(self) -> None:
        while True:
            try:
                connection, _ = self.listener.accept()
            except OSError:  # closed
                return
            self.connections.append(connection)
            if self.reply:
                with contextlib.suppress(OSError):
                    connection.sendall(self.reply)

    def close(self) -> None:
        self.listener.close()
        for connection in self.connections:
            connection.close()


def _kill_group(pid: int) -> None:
    try:
        os.killpg(pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


# --------------------------------------------------------------------------- a case
@dataclass
class Outcome:
    case: Case
    status: int | None  # None: killed at the timeout
    stderr: str
    seconds: float
    problems: list[str]

    def first_line(self) -> str:
        lines = [line for line in self.stderr.splitlines() if line.strip()]
        if not lines:
            return "(stderr empty)"
        text = lines[0]
        if "Traceback" in self.stderr and lines[-1] != lines[0]:
            text += f" ... {lines[-1]}"
        return text if len(text) <= 400 else text[:397] + "..."


def make_special(folder: Path, kind: str, name: str) -> None:
    path = folder / name
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "dir":
        path.mkdir()
    elif kind == "null":
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    elif kind == "sparse":
        with open(path, "wb") as fh:
            fh.truncate(OVERSIZED_BYTES)
    elif kind == "loop":
        path.symlink_to(name)
    elif kind == "link":
        path.symlink_to("elsewhere.nc")
    elif kind == "locked":
        path.mkdir()
        path.chmod(0o500)
    elif kind == "unreadable":
        path.chmod(0)
    elif kind == "netcdf":
        import netCDF4

        with netCDF4.Dataset(path, "w") as nc:
            nc.createDimension("x", 3)
            nc.createVariable("x", "f8", ("x",))[:] = [1.0, 2.0, 3.0]
            nc.title = "a netCDF file hertzsweep did not write"
    else:
        raise ValueError(kind)


def snapshot(folder: Path) -> dict[str, tuple]:
    """Every entry under the folder: its type, and for a regular file its size and
    content hash (special files are never opened: a FIFO would block)."""
    out: dict[str, tuple] = {}
    for root, dirs, names in os.walk(folder):
        for name in dirs + names:
            path = Path(root) / name
            info = path.lstat()
            entry: tuple = (stat.filemode(info.st_mode)[0],)
            if stat.S_ISREG(info.st_mode):
                if info.st_size > 1 << 24 or not os.access(path, os.R_OK):
                    entry += (info.st_size, info.st_mtime_ns)
                else:
                    entry += (info.st_size, hashlib.sha256(path.read_bytes()).hexdigest()[:12])
            out[str(path.relative_to(folder))] = entry
    return out


def outside_state(path: str) -> tuple:
    """The file type of a path outside the folder and the names beside it that contain
    its name (a temporary file left there)."""
    p = Path(path)
    try:
        kind = stat.filemode(p.lstat().st_mode)[0]
    except FileNotFoundError:
        kind = None
    try:
        beside = sorted(n for n in os.listdir(p.parent) if p.name in n and n != p.name)
    except OSError:
        beside = []
    return kind, beside


# Commands that read files and check values, and run no compiled kernel: nothing that can
# crash the interpreter, so their cases run in the test's own process (milliseconds, where
# a forked process pays 0.1 s, and 2 s for plot's first import of matplotlib)
IN_PROCESS_COMMANDS = ("validate", "rig", "plot", "compare", "import", "export")


def in_process(c: Case) -> bool:
    """Whether a case runs in the test's process: a command that runs no kernel, or a
    study refused at its scheduler's address (the connect has its own deadline), with no
    special file."""
    here = c.argv[0] in IN_PROCESS_COMMANDS or c.group == "dask"
    return here and not (c.fresh or c.idle or c.special)


def run_in_process(argv: list[str | bytes], cwd: Path) -> tuple[Any, ...]:
    """(exit status, stderr bytes, 0 processes left) of ``hertzsweep ARGV`` run here, in
    ``cwd`` (one case at a time: the working folder is the process's)."""
    from hertzsweep.cli import main

    here = os.getcwd()
    err, out = io.StringIO(), io.StringIO()
    try:
        os.chdir(cwd)
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            try:
                main([os.fsdecode(a) for a in argv])
                status = 0
            except SystemExit as exc:
                status = exc.code if isinstance(exc.code, int) else 1
    finally:
        os.chdir(here)
    return status, err.getvalue().encode("utf-8", "surrogateescape"), 0


def run_case(
    c: Case,
    root: Path,
    server: ForkServer,
    warmed: Future | None = None,
    servers: Mapping[str, str] | None = None,
) -> Outcome:
    """Make the case's folder and files, run it, and judge it (``servers``: the addresses
    of the loopback schedulers, by their placeholder)."""
    folder = root / c.id.replace("/", "_")
    folder.mkdir()
    for name, content in c.files.items():
        mode = "wb" if isinstance(content, bytes) else "w"
        with open(folder / name, mode) as fh:
            fh.write(content)
    for kind, name in c.special:
        make_special(folder, kind, name)
    before = snapshot(folder)
    outside_before = {p: outside_state(p) for p in c.outside}
    names = {"{dir}": str(folder), **(servers or {})}
    argv = [names.get(a, a) if isinstance(a, str) else a for a in c.argv]
    argv = [a.replace("{dir}", str(folder)) if isinstance(a, str) else a for a in argv]
    if warmed is not None:
        warmed.result()
    start = time.monotonic()
    if c.fresh:
        status, err, left = run_fresh(argv, folder, c.timeout)
    elif in_process(c):
        status, err, left = run_in_process(argv, folder)
    else:
        status, err, left = server.run(argv, folder, c.timeout)
    seconds = time.monotonic() - start
    stderr = err.decode("utf-8", "replace")
    problems = []
    succeeded = c.may_succeed and status == 0
    if succeeded:  # an honest result: no noise, nothing non-finite written
        if "Traceback" in stderr or "Exception ignored" in stderr:
            problems.append("exit 0 with a traceback on stderr")
        if (folder / "out.nc").exists():
            bad = nonfinite(folder / "out.nc")
            if bad:
                problems.append(f"exit 0 but non-finite values written: {', '.join(bad)}")
    elif status is None:
        problems.append(f"hang: still running after {c.timeout:g} s, killed")
    elif status < 0:
        problems.append(f"crash: killed by {signal.Signals(-status).name}")
    elif status != 2:
        problems.append(f"exit status {status}, expected 2")
    if left:
        problems.append(f"left {left} process(es) running after its exit")
    if not succeeded:
        problems += message_problems(c, stderr)
    after = snapshot(folder)
    changed = {k for k in before.keys() | after.keys() if before.get(k) != after.get(k)}
    if succeeded:
        changed.discard("out.nc")
    if changed:
        problems.append(f"files written, left or changed: {', '.join(sorted(changed))}")
    for path, state in outside_before.items():
        if outside_state(path) != state:
            problems.append(f"{path} changed: {state} -> {outside_state(path)}")
    _restore_permissions(folder)
    return Outcome(c, status, stderr, seconds, problems)


# Variables that hold NaN by design: no jump in the swept range (sweep), the padding of
# the flight lists (trace).
DOCUMENTED_NAN = {
    "ball_mode_error",  # where the dwell or record does not repeat every period
    "jump_frequency_ratio",
    "jump_frequency",
    "subharmonic_onset_frequency_ratio",  # no jump onto (or off) a period-2 response
    "subharmonic_end_frequency_ratio",
    "flight_start",
    "flight_end",
    "flight_start_time",
    "flight_duration",
}
RIG_CONSTANTS = (  # global attributes every dataset carries
    "contact_stiffness",
    "static_compression",
    "natural_circular_frequency",
    "natural_frequency",
    "static_load",
    "contact_pressure",
    "contact_radius",
    "ball_mode_frequency",
)


def nonfinite(path: Path) -> list[str]:
    """The float variables and rig-constant attributes of a dataset holding NaN or
    infinity where the manual does not say they may (the ball's mode of a single
    sphere-plane is undefined: NaN)."""
    import netCDF4
    import numpy as np

    out = []
    with netCDF4.Dataset(path) as nc:
        nc.set_auto_mask(False)
        for name, var in nc.variables.items():
            if var.dtype.kind == "f" and name not in DOCUMENTED_NAN:
                if not np.isfinite(var[...]).all():
                    out.append(name)
        single = getattr(nc, "rig_geometry", "") == "sphere-plane"
        for name in RIG_CONSTANTS:
            value = getattr(nc, name, 0.0)
            if not np.isfinite(value).all() and not (single and name == "ball_mode_frequency"):
                out.append(f"attribute {name}")
    return out


def message_problems(c: Case, stderr: str) -> list[str]:
    problems = []
    if "Traceback" in stderr:
        problems.append("traceback on stderr")
    if "Exception ignored" in stderr:
        problems.append("'Exception ignored' on stderr")
    lines = stderr.splitlines()
    if len(lines) != 1 or not lines[0].strip():
        problems.append(f"{len(lines)} stderr lines, expected exactly one")
        return problems
    line = lines[0]
    if not line.startswith("hertzsweep: error: "):
        problems.append("the line does not start with 'hertzsweep: error: '")
    for want in c.expect:
        alternatives = (want,) if isinstance(want, str) else want
        if not any(a in line for a in alternatives):
            problems.append(f"the line does not name {' or '.join(map(repr, alternatives))}")
    return problems


def _restore_permissions(folder: Path) -> None:
    """Let pytest remove the folder; drop the sparse file."""
    for root, dirs, names in os.walk(folder):
        for name in dirs + names:
            path = Path(root) / name
            if path.is_symlink():
                continue
            if path.is_dir():
                path.chmod(0o700)
            elif path.is_file():
                path.chmod(0o600)
                if path.stat().st_size > 1 << 24:
                    path.unlink()


def warm_up(root: Path) -> None:
    """Run each simulating command once on the tiny scene, untimed: the compiled kernels'
    cache is (re)built here, not inside a case's timeout."""
    folder = root / "_warm-up"
    folder.mkdir()
    (folder / "scene.toml").write_text(scene())
    (folder / "study.toml").write_text(STUDY)
    commands = [
        [*RUN["sweep"][:3], "sweep.nc", "-q"],
        [*RUN["trace"][:5], "trace.nc", "-q"],
        [*RUN["branch"][:3], "branch.nc", "-q"],
        ["study", "study.toml", "-o", "study.nc", "-q", "--workers", "1"],
    ]
    with ThreadPoolExecutor(CPU_WORKERS) as pool:
        list(pool.map(lambda argv: _untimed(argv, folder), commands))


def _untimed(argv: list[str], folder: Path) -> None:
    # 600 s: a cold cache compiles every kernel (about a minute); a warm one takes 2 s
    subprocess.run([sys.executable, "-c", PRELUDE, *argv], cwd=folder, capture_output=True,
                   stdin=subprocess.DEVNULL, timeout=600, check=False)  # fmt: skip


def report(outcomes: list[Outcome]) -> str:
    """Failing cases grouped by class: id, exit status, the first stderr line, problems."""
    totals: dict[str, int] = defaultdict(int)
    groups: dict[str, list[Outcome]] = defaultdict(list)
    for o in outcomes:
        totals[o.case.group] += 1
        if o.problems:
            groups[o.case.group].append(o)
    seconds: dict[str, list[float]] = defaultdict(list)
    for o in outcomes:
        seconds[o.case.group].append(o.seconds)
    lines = ["cases per class (process seconds: total, largest):"]
    for group, times in seconds.items():
        lines.append(f"  {group:10s} {len(times):4d}  {sum(times):7.1f} s  {max(times):5.1f} s")
    slowest = sorted(outcomes, key=lambda o: -o.seconds)[:12]
    lines.append("slowest: " + ", ".join(f"{o.case.id} {o.seconds:.1f} s" for o in slowest))
    failing = sum(map(len, groups.values()))
    lines.append(f"\n{failing} of {len(outcomes)} bad inputs mishandled, by class:")
    for group, failed in groups.items():
        lines.append(f"\n== {group}: {len(failed)} of {totals[group]} failing")
        for o in failed:
            status = "killed at the timeout" if o.status is None else f"exit {o.status}"
            lines.append(f"  {o.case.id}  [{status}, {o.seconds:.1f} s]")
            lines.append(f"      stderr: {o.first_line()}")
            lines.append(f"      {'; '.join(o.problems)}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- tests
def test_the_table_has_more_than_150_distinct_cases():
    # the count: more than 150 bad inputs, each with its own id (its folder)
    ids = [c.id for c in CASES]
    assert len(ids) == len(set(ids))
    assert len(CASES) > MINIMUM_CASES, len(CASES)
    assert all(c.expect for c in CASES), [c.id for c in CASES if not c.expect]


def test_the_table_changes_one_thing_of_a_valid_scene(tmp_path, capsys):
    # the control: the tiny scene, its rig as a file and the CSV are valid, so each case's
    # error can only come from the one thing the case changes
    (tmp_path / "scene.toml").write_text(scene())
    (tmp_path / "rigfile.toml").write_text(rig_file())
    (tmp_path / "rigged.toml").write_text(scene(rig="rigfile.toml"))
    for name in ("scene.toml", "rigged.toml"):
        code, _, err = run_cli(["validate", tmp_path / name], capsys)
        assert (code, err) == (0, ""), name
    (tmp_path / "data.csv").write_text(CSV)
    code, _, err = run_cli(["import", tmp_path / "data.csv", "-o", tmp_path / "m.nc"], capsys)
    assert (code, err) == (0, "")


def test_every_bad_input_ends_with_one_line_and_exit_status_2(tmp_path):
    # One test for the whole table, so that every failure is reported at once. The cases
    # run in parallel: CPU_WORKERS threads for those that compute, STUDY_WORKERS for the
    # studies, IDLE_WORKERS for those that mostly wait; the commands that load the
    # compiled kernels wait for the warm-up, the others run beside it. About 35 s on the
    # 2-core reference machine when every case passes; a hung case adds its TIMEOUT.
    streams = tmp_path / "_streams"
    streams.mkdir()
    server = ForkServer(streams)
    # distributed reads an 8-byte frame count, then 8-byte lengths: all ones is 2**64 - 1
    garbage = LoopbackScheduler(b"\xff" * 64)
    addresses = {"{garbage}": garbage.address}
    try:
        with (
            ThreadPoolExecutor(1) as warm_pool,
            ThreadPoolExecutor(CPU_WORKERS) as cpu_pool,
            ThreadPoolExecutor(IDLE_WORKERS) as idle_pool,
            ThreadPoolExecutor(STUDY_WORKERS) as study_pool,
        ):
            warmed = warm_pool.submit(warm_up, tmp_path)
            cases = sorted(CASES, key=lambda c: (not c.idle, c.argv[0] in KERNEL_COMMANDS))
            futures = []
            here = [run_case(c, tmp_path, server) for c in cases if in_process(c)]
            for c in (c for c in cases if not in_process(c)):
                pool = idle_pool if c.idle else study_pool if c.argv[0] == "study" else cpu_pool
                wait = warmed if c.argv[0] in KERNEL_COMMANDS and not c.fresh else None
                futures.append(pool.submit(run_case, c, tmp_path, server, wait, addresses))
            outcomes = here + [f.result() for f in futures]
    finally:
        server.close()
        garbage.close()
    order = {c.id: i for i, c in enumerate(CASES)}
    outcomes.sort(key=lambda o: order[o.case.id])
    text = report(outcomes)
    print(text)
    assert not any(o.problems for o in outcomes), text
