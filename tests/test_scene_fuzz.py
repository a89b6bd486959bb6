"""Random scenes through ``validate`` and a tiny ``sweep``: every scene either runs (exit 0,
every value written finite but those documented as NaN) or is refused with one line on
stderr and exit status 2; never a traceback, another exception, a crash or a hang.

The scenes are the tiny scene of :mod:`tests.test_bad_inputs` (3 frequencies, one sigma,
one direction, 12 periods of 64 steps a dwell) with one to four keys changed. A key that
sets the cost of a run (the grid, the dwell, the steps per period) takes a value from a
small valid set or one that must be refused (wrong type, out of range, or beyond any
sensible size: the issue's 1e9 and 1e12 periods, 2**63 - 1 steps, 1e-13 and 1e300 grid
values), never a valid but expensive one, so every accepted scene runs in milliseconds.
The other keys take any value: numbers across magnitudes (0, negatives, huge, tiny, NaN,
infinity), strings, booleans, lists, tables; unknown keys and tables are drawn too.

The property runs in-process (``run_cli``) for speed, inside one forked child of the test
process, so that a crash (a segfault) or a hang ends the child, not pytest, and fails the
test naming the scene it was running.
"""

from __future__ import annotations

import itertools
import os
import resource
import signal
import time
import traceback
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, Phase, example, given, settings
from hypothesis import strategies as st

from hertzsweep.core.config import SCHEMA

from .conftest import run_cli
from .test_bad_inputs import DROP, nonfinite, scene

NAN, INF = float("nan"), float("inf")
# 80 examples: about 5 s of sweeps (a few ms each once the kernels are loaded, the first
# of each damping law and of shooting about 1 s) plus the explicit examples below, well
# within the 20 s the suite allows this file on the 2-core reference machine.
MAX_EXAMPLES = 80
# The forked child's whole run: about 20x the 4-7 s it takes, so that only a hang (a scene
# that should have been refused, running for minutes) reaches it.
CHILD_SECONDS = 120.0
# Address space added to the test process's own for the child: an allocation that a
# refused scene must not make (a 10**12-period record) fails at once instead of swapping.
EXTRA_MEMORY = 4 << 30

# The base: cheap and valid; "auto" settling is capped at 20 periods.
BASE = {"sweep.max_settle_periods": 20}

# --------------------------------------------------------------------------- values
# keys whose value sets the cost of a run: only small valid values or ones to refuse
COST_KEYS = {
    "sweep.start",
    "sweep.stop",
    "sweep.step",
    "sweep.settle_periods",
    "sweep.measure_periods",
    "sweep.max_settle_periods",
    "solver.steps_per_period",
    "solver.max_steps",
    "lockin.harmonics",
    "excitation.sigma",
    "sweep.directions",
}
VALID: dict[str, list[Any]] = {  # cheap valid values of every key
    "rig.geometry": ["double-sphere-plane", "sphere-plane"],
    "rig.ball_radius": [12.7e-3, 5e-3, 0.05],
    "rig.youngs_modulus": [210e9, 70e9, 1e6],
    "rig.poisson_ratio": [0.29, 0.0, -0.5, 0.49],
    "rig.mass": [11.4, 0.5, 100.0],
    "rig.static_load": [110.0, 5.0, 2000.0],
    "rig.ball_mass": [0.07, 0.001],
    "rig.ball_density": [7810.0, 2700.0],
    "rig.natural_frequency": [233.4, 50.0, 5000.0],
    "damping.ratio": [0.0, 1e-4, 0.0045, 0.05, 0.5],
    "damping.law": ["viscous", "contact"],
    "damping.exponent": [0, 0.5, 1, 1.5, 3.0],
    "excitation.sigma": [0.01, [0.006, 0.01], 0.1, [0.5], 1e-6, [0.01, 0.02, 0.03]],
    "sweep.start": [0.9, 0.96, 1.0],
    "sweep.stop": [0.96, 1.0, 1.02],
    "sweep.step": [0.005, 0.01, 0.05],
    "sweep.directions": [["up"], ["down"], ["up", "down"], "down"],
    "sweep.settle_periods": [0, 1, 10, 30, "auto"],
    "sweep.measure_periods": [1, 2, 5],
    "sweep.tolerance": [1e-6, 1e-3, 0.1],
    "sweep.max_settle_periods": [1, 10, 50],
    "sweep.jump_threshold": [0.1, 0.3, 0.9],
    "sweep.steady_state": ["settle", "shooting"],
    "solver.method": ["central-difference"],
    "solver.steps_per_period": [16, 32, 64, 128, 256],
    "solver.max_steps": [10**6, 10**11],
    "lockin.harmonics": [1, [1, 2], [1, 3, 5], [2], [1, 7]],
}
KNOWN_KEYS = [f"{table}.{key}" for table, keys in SCHEMA.items() for key in keys]
UNKNOWN_KEYS = ["damping.bogus", "sweep.Step", "rig.radius", "lockin.harmonic", "bogus.key"]
TABLES = list(SCHEMA)  # a whole table replaced by a value (a table of random keys, or not)
WORDS = [
    "auto",
    "up",
    "down",
    "viscous",
    "contact",
    "settle",
    "shooting",
    "sphere-plane",
    "central-difference",
    "",
    "1e-3",
    "nan",
]

SPECIAL_NUMBERS = [0, -0.0, -1, 1, 0.5, 1e-300, 1e-13, 1e-5, 1e5, 1e12, 1e300, NAN, INF, -INF]
SPECIAL_NUMBERS += [2**63 - 1, -(2**63), 10**9]
# Numbers for the cost keys: small (valid or not), or what must be refused for its size.
COST_NUMBERS = st.one_of(
    st.integers(-10, 300),
    st.sampled_from([0.0, -1.0, 1.5, 1e-300, 1e-13, 1e-9, 1e300, NAN, INF, -INF, 0.2]),
    st.sampled_from([10**9, 10**12, 2**63 - 1, -(2**63)]),
)
# Numbers for the budget (solver.max_steps): no huge ones, which would let a scene run
# for hours on purpose.
BUDGET_NUMBERS = st.one_of(
    st.integers(-10, 300),
    st.sampled_from([0.0, -1.0, 1.5, 1e-300, NAN, INF, -INF]),
)
NUMBERS = st.one_of(
    st.sampled_from(SPECIAL_NUMBERS),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2**63), 2**63 - 1),
)
TEXT = st.one_of(st.sampled_from(WORDS), st.text(max_size=8))


def wild(numbers: st.SearchStrategy) -> st.SearchStrategy:
    """Any value of a TOML file: numbers, strings, booleans, lists and tables of them."""
    scalars = st.one_of(numbers, TEXT, st.booleans())
    return st.one_of(
        scalars,
        st.lists(scalars, max_size=3),
        st.lists(st.lists(numbers, max_size=2), min_size=1, max_size=2),
        st.dictionaries(st.sampled_from(["a", "ratio", "step"]), scalars, max_size=2),
    )


def value_for(key: str) -> st.SearchStrategy:
    """A valid value 3 times in 4 (so that about half the scenes run), else any value."""
    numbers = NUMBERS
    if key in COST_KEYS:
        numbers = BUDGET_NUMBERS if key == "solver.max_steps" else COST_NUMBERS
    other = wild(numbers)
    if key in VALID:
        valid = st.sampled_from(VALID[key])
        return st.one_of(valid, valid, valid, other)
    return other


# known keys 4 times as often as unknown keys and tables replaced by a value
KEYS = st.sampled_from(KNOWN_KEYS * 4 + UNKNOWN_KEYS + TABLES + ["bogus"])
DROPPABLE = [k for k in KNOWN_KEYS if k not in COST_KEYS]  # a default is cheap
CHANGES = st.lists(
    st.one_of(
        KEYS.flatmap(lambda key: st.tuples(st.just(key), value_for(key))),
        st.tuples(st.sampled_from(DROPPABLE), st.just(DROP)),
    ),
    min_size=1,
    max_size=4,
)

# The known-bad values (and a few of each class): each must be refused, or run
# honestly (sigma = 2 with zeta = 1e-5 is within the stability limit).
N256 = ("solver.steps_per_period", 256)
KNOWN_BAD = [
    [("lockin.harmonics", [1000])],
    [N256, ("lockin.harmonics", [1, 300])],
    [N256, ("lockin.harmonics", [1, 200])],
    [("sweep.step", 1e-9)],
    [("solver.steps_per_period", 10**9)],
    [("solver.steps_per_period", 2**63 - 1)],
    [("sweep.start", 1e-13)],
    [("sweep.stop", 1e300)],
    [("sweep.settle_periods", 10**12)],
    [("sweep.measure_periods", 10**12)],
    [("rig.youngs_modulus", 1e-300)],
    [("rig.ball_radius", 1e300)],
    [("excitation.sigma", 2.0), ("damping.ratio", 1e-5)],
    [("damping.ratio", NAN)],
    [("rig.mass", INF)],
    [("sweep.directions", [])],
    [("damping.exponent", 1e300), ("damping.law", "contact")],
    [("sweep.steady_state", "shooting"), ("damping.ratio", 0.0)],
    [("damping.bogus", 1)],
    [("bogus", {"a": 1})],
    [("rig", 3)],
    [("lockin", [1])],
]


# --------------------------------------------------------------------------- the property
def one_line(code: int, err: str) -> bool:
    lines = err.splitlines()
    return code == 2 and len(lines) == 1 and lines[0].startswith("hertzsweep: error: ")


def check_scene(folder: Path, capsys, changes: list[tuple[str, Any]]) -> None:
    """validate, then sweep: exit 0 and finite numbers, or exit 2 and one line; a scene
    that validate refuses, the sweep refuses too."""
    folder.mkdir()
    path = folder / "scene.toml"
    path.write_text(scene({**BASE, **dict(changes)}))
    code, _, err = run_cli(["validate", path], capsys)
    valid = code == 0
    assert (valid and err == "") or one_line(code, err), (code, err)
    out = folder / "out.nc"
    code, _, err = run_cli(["sweep", path, "-o", out, "-q"], capsys)
    if not valid:
        assert one_line(code, err) and not out.exists(), ("validate refused it", code, err)
        return
    assert code == 0 or one_line(code, err), (code, err)
    if code == 0:
        assert "Traceback" not in err, err
        assert nonfinite(out) == [], nonfinite(out)
    else:
        assert not out.exists()


def in_child(body, folder: Path, seconds: float) -> None:
    """Run ``body(progress)`` in a forked child; fail with the scene it was on if the child
    crashes, hangs beyond ``seconds`` or raises."""
    progress, result = folder / "progress.txt", folder / "result.txt"
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        try:
            _, hard = resource.getrlimit(resource.RLIMIT_AS)
            with open("/proc/self/status") as fh:
                size = next(int(line.split()[1]) << 10 for line in fh if line.startswith("VmSize"))
            resource.setrlimit(resource.RLIMIT_AS, (size + EXTRA_MEMORY, hard))
            body(progress)
            result.write_text("ok")
        except BaseException:
            result.write_text("".join(traceback.format_exc()))
        finally:
            os._exit(0)
    deadline = time.monotonic() + seconds
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > deadline:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            last = progress.read_text() if progress.exists() else "?"
            raise AssertionError(f"hang: no end within {seconds:g} s; running {last}")
        time.sleep(0.05)
    if os.WIFSIGNALED(status):
        last = progress.read_text() if progress.exists() else "?"
        name = signal.Signals(os.WTERMSIG(status)).name
        raise AssertionError(f"crash: {name} while running {last}")
    text = result.read_text() if result.exists() else "no result"
    assert text == "ok", text


def test_random_scenes_run_finite_or_end_in_one_line(tmp_path, capsys):
    # 80 random scenes plus the 22 known-bad ones, derandomized (the same scenes on every
    # run and in CI), no example database, no deadline (the first sweep of each damping
    # law loads its kernels: 1 s); CHILD_SECONDS bounds the whole.
    numbers = itertools.count()

    def body(progress: Path) -> None:
        @settings(
            max_examples=MAX_EXAMPLES,
            deadline=None,
            derandomize=True,
            database=None,
            phases=(Phase.explicit, Phase.generate, Phase.shrink),
            suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
        )
        @given(changes=CHANGES)
        def random_scene(changes):
            progress.write_text(repr(changes))
            check_scene(tmp_path / f"scene-{next(numbers)}", capsys, changes)

        for changes in KNOWN_BAD:
            random_scene = example(changes=changes)(random_scene)
        random_scene()

    in_child(body, tmp_path, CHILD_SECONDS)
