"""Kernel invariants, over every kernel path and every damping law.

Paths: one trajectory (``integrate.advance``), many in lockstep (``advance_batch``), the
instruments (``measure``, one trajectory or many), the tangent-linear map
(``tangent.period_map``). Laws: viscous, contact n = 0, 1/2, 1, 3/2 (selects, no pow) and a
general exponent (pow). Each is a distinct compiled specialisation, so each is checked.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hertzsweep.drivers.oscillator import Oscillator, State, drive
from hertzsweep.kernels import integrate, scheme, tangent
from hertzsweep.kernels.laws import Contact, ContactPower, Viscous, make_law

from .conftest import make_scene

LAWS = [("viscous", 1.5), ("contact", 0.0), ("contact", 0.5), ("contact", 1.0),
        ("contact", 1.5), ("contact", 1.3)]  # fmt: skip
IDS = [f"{law}-{n}" for law, n in LAWS]
ZETA = 0.01
N = 128


def law_record(law, exponent):
    return make_law(law, ZETA, exponent)


def inputs(sigma):
    scene = make_scene(lockin={"harmonics": [1, 2, 3]}, solver={"steps_per_period": N})
    return drive(scene, sigma)


def test_law_records_are_the_three_types():
    assert type(make_law("viscous", 0.01, 1.5)) is Viscous
    assert [type(make_law("contact", 0.01, n)) for n in (0, 0.5, 1, 1.5)] == [Contact] * 4
    assert type(make_law("contact", 0.01, 1.3)) is ContactPower


@pytest.mark.parametrize(("law", "exponent"), LAWS, ids=IDS)
def test_batched_equals_single_bit_for_bit(law, exponent):
    """T trajectories at their own step and level against each alone: the same bits
    (sigma 7.8 % loses contact, 0.5 % does not). T is one more than a block of the
    instruments' working array and three more (a full block and a partial one)."""
    record = law_record(law, exponent)
    count = integrate.LANES + 3
    sigma = np.resize([0.005, 0.03, 0.078], count) * np.linspace(1.0, 1.1, count)
    h = np.resize([scheme.step_size(w, N) for w in (0.6, 0.9, 0.97)], count)
    q_prev, q = np.full(count, 0.01), np.full(count, -0.02)
    status, bad = integrate.advance_batch(q_prev, q, h, record, inputs(sigma), 40)
    assert (status, bad) == (scheme.OK, -1)
    for t in range(count):
        alone = integrate.advance(0.01, -0.02, h[t], record, inputs(sigma[t]), 40)
        assert alone == (q_prev[t], q[t], scheme.OK)
    # the instruments: all together against each alone (its own loop, in registers),
    # every 7th step recorded
    stride, periods = 7, 3
    samples = -(-periods * N // stride)

    def readout(trajectories):
        return integrate.new_readout(3, trajectories, np.zeros((samples, 4, trajectories)), stride)

    together = readout(count)
    qp_all, q_all = q_prev.copy(), q.copy()
    integrate.measure(qp_all, q_all, h, record, inputs(sigma), periods, together)
    for t in range(count):
        alone = readout(1)
        qp1, q1 = q_prev[t : t + 1].copy(), q[t : t + 1].copy()
        integrate.measure_one(qp1, q1, h[t : t + 1], record, inputs(sigma[t]), periods, alone)
        assert (qp1[0], q1[0]) == (qp_all[t], q_all[t])
        for name in ("coefficients", "sums", "counts", "record"):
            assert np.array_equal(getattr(alone, name)[..., 0], getattr(together, name)[..., t])
    assert together.counts[0].max() > 0  # some trajectories lose contact: flights tallied


@pytest.mark.parametrize(("law", "exponent"), LAWS, ids=IDS)
def test_tangent_trajectory_is_advance_bit_for_bit(law, exponent):
    record = law_record(law, exponent)
    h = scheme.step_size(0.6, N)
    q_prev, q, status = integrate.advance(0.0, 0.0, h, record, inputs(0.078), 5)
    derivative = np.zeros((2, 3))
    end = tangent.period_map(q_prev, q, h, record, inputs(0.078), derivative)
    assert end == integrate.advance(q_prev, q, h, record, inputs(0.078), 1)
    assert status == scheme.OK


@pytest.mark.parametrize(("law", "exponent"), LAWS, ids=IDS)
def test_momentum_balance(law, exponent):
    """The scheme is ``N/F_s = 1 + f_n - (q[n+1] - 2 q[n] + q[n-1]) / h^2`` at every step,
    so over whole periods ``sum (N/F_s - 1) = sum f_n - (dq_end - dq_start) / h^2``: the
    impulse of the transmitted force closes against the input's and the change of
    momentum, also through impacts (sigma = 50 % at w = 0.9 is in flight
    most of each period). Rounding: about 1e-16 of q per step, divided by h^2 = 7e-3 and summed
    over 3 x 128 steps: 1e-11 at most, against an impulse of order 100."""
    record = law_record(law, exponent)
    h = scheme.step_size(0.9, N)
    q_prev, q, _ = integrate.advance(-1.0, -1.0, h, record, inputs(0.5), 200)
    qp, qq = np.array([q_prev]), np.array([q])
    readout = integrate.new_readout(3, 1)
    assert integrate.measure(qp, qq, np.array([h]), record, inputs(0.5), 3, readout)[0] == 0
    sin_table = scheme.period_tables(N)[0]
    impulse = readout.sums[0, 0]
    momentum = ((qq[0] - qp[0]) - (q - q_prev)) / (h * h)
    expected = 3 * 0.5 * sin_table.sum() - momentum
    assert readout.counts[0, 0] > N  # steps out of contact: impacts inside the window
    assert abs(impulse - expected) <= 1e-10 * max(1.0, abs(impulse))


@pytest.mark.parametrize(("law", "exponent"), LAWS, ids=IDS)
def test_order_two_where_the_force_is_smooth(law, exponent):
    """H1 at sigma = 1 % (no loss of contact), w = 0.9, from the same start, N = 64,
    128, 256: observed order log2(|A64 - A128| / |A128 - A256|) = 2 +- 0.2."""
    scene = make_scene(
        damping={"ratio": 0.05, "law": law, "exponent": exponent},
        excitation={"sigma": [0.01]},
    )
    values = []
    for n in (64, 128, 256):
        oscillator = Oscillator(
            make_scene(
                damping={"ratio": 0.05, "law": law, "exponent": exponent},
                excitation={"sigma": [0.01]},
                solver={"steps_per_period": n},
            ),
            0.01,
        )
        state = oscillator.advance(oscillator.from_velocity(0.0, 0.0, 0.9), 0.9, 200)
        _, reading = oscillator.measure(state, 0.9, 4)
        values.append(reading.amplitude[0])
    order = np.log2(abs(values[0] - values[1]) / abs(values[1] - values[2]))
    assert scene.damping.law == law
    assert order == pytest.approx(2.0, abs=0.2)


@pytest.mark.parametrize(("law", "exponent"), LAWS, ids=IDS)
def test_non_finite_state_is_a_status(law, exponent):
    record = law_record(law, exponent)
    h = scheme.step_size(0.9, N)
    assert integrate.advance(np.nan, 0.0, h, record, inputs(0.01), 2)[2] == scheme.NON_FINITE
    q_prev, q = np.array([0.0, np.nan]), np.array([0.0, 0.0])
    status = integrate.advance_batch(q_prev, q, np.full(2, h), record, inputs([0.01] * 2), 2)
    assert status == (scheme.NON_FINITE, 1)
    readout = integrate.new_readout(3, 1)
    status = integrate.measure(
        np.array([np.inf]), np.array([0.0]), np.array([h]), record, inputs(0.01), 2, readout
    )
    assert status == (scheme.NON_FINITE, 0)
    derivative = np.zeros((2, 3))
    assert tangent.period_map(np.nan, 0.0, h, record, inputs(0.01), derivative)[2] in (
        scheme.NON_FINITE,
        scheme.UNSTABLE,  # a NaN compression compares false to the limit: caught at the end
    )


def test_status_table_gives_one_error_per_code():
    from hertzsweep.errors import IntegrationError, StabilityError

    with pytest.raises(StabilityError, match="steps_per_period: 64 is beyond"):
        scheme.check_status(scheme.UNSTABLE, 0.01, 0.9, 64)
    with pytest.raises(IntegrationError, match="non-finite at sigma = 0.01, w = 0.9"):
        scheme.check_status(scheme.NON_FINITE, 0.01, 0.9, 64)
    scheme.check_status(scheme.OK, 0.01, 0.9, 64)


def test_state_conversion_round_trip():
    """The kernels carry d = 1 + 2q/3; the boundary converts back within one ulp of d."""
    oscillator = Oscillator(make_scene(), 0.01)
    state = State(0.123456789, -0.2, scheme.step_size(0.9, 256))
    end = oscillator.advance(state, 0.9, 0)
    assert end == state


def test_kernel_caches_follow_every_compiled_source(tmp_path, monkeypatch):
    """numba checks only the loaded function's own file; the cache folder is named after
    all compiled sources, so a change to scheme.py cannot leave integrate.py's cached
    kernels in use."""
    import shutil

    from numba import config

    import hertzsweep.kernels as kernels

    assert (
        config.CACHE_DIR == kernels.CACHE_FOLDER == kernels.cache_folder(kernels.cache_bases()[0])
    )
    copies = []
    for source in kernels.COMPILED_SOURCES:
        copies.append(tmp_path / f"{len(copies)}-{source.name}")
        shutil.copy(source, copies[-1])
    monkeypatch.setattr(kernels, "COMPILED_SOURCES", tuple(copies))
    before = kernels.cache_folder(str(tmp_path))
    scheme_copy = next(c for c in copies if c.name.endswith("scheme.py"))
    scheme_copy.write_text(scheme_copy.read_text() + "\n# changed\n")
    assert kernels.cache_folder(str(tmp_path)) != before


UNWRITABLE = "/proc/hertzsweep-nowhere"  # no one, root included, can create it


def _import_kernels_with(code: str, **env: str):
    import os
    import subprocess
    import sys

    environment = {**os.environ, **env}
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=environment, timeout=300
    )


COMPILE_ONE = (
    "from hertzsweep.kernels import integrate; from hertzsweep.kernels.laws import make_law; "
    "print(integrate.start_from(0.5, 0.0, 0.01, make_law('viscous', 0.01, 1.5)))"
)


def test_unwritable_numba_cache_falls_back_to_a_writable_folder(tmp_path):
    """NUMBA_CACHE_DIR and the source tree unwritable: the user's cache folder is used,
    silently, and a kernel compiles and runs (a crash at import before)."""
    done = _import_kernels_with(
        COMPILE_ONE, NUMBA_CACHE_DIR=UNWRITABLE, XDG_CACHE_HOME=str(tmp_path)
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    assert (tmp_path / "hertzsweep").is_dir()
    # start_from of q = 0.5 at rest: q_prev = 0.5 - h^2/2 * (restoring - 1), finite
    assert float(done.stdout) < 0.5


def test_no_writable_cache_folder_at_all_is_one_warning_line(tmp_path):
    """A read-only install (emulated: a copy of the package whose ``__pycache__`` folders
    are files, which no one, root included, can create files in) and nowhere else to
    write: the kernels compile uncached, with one warning line, instead of every command
    crashing at import with numba's "no locator available"."""
    import shutil

    import hertzsweep

    package = tmp_path / "site" / "hertzsweep"
    shutil.copytree(
        Path(hertzsweep.__file__).parent, package, ignore=shutil.ignore_patterns("__pycache__")
    )
    for folder in [package, *[p for p in package.rglob("*") if p.is_dir()]]:
        (folder / "__pycache__").write_text("")
    code = f"import tempfile; tempfile.tempdir = {UNWRITABLE!r}; " + COMPILE_ONE
    done = _import_kernels_with(
        code,
        PYTHONPATH=str(package.parent),
        NUMBA_CACHE_DIR=UNWRITABLE,
        XDG_CACHE_HOME=UNWRITABLE,
        HOME=UNWRITABLE,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hertzsweep: warning: no writable folder")
    assert float(done.stdout) < 0.5


def test_the_install_warm_up_covers_every_law_type():
    """`make install` compiles the kernels ahead (hertzsweep.drivers.warm): one setting
    per law type, or a law would still compile on its first run."""
    from hertzsweep.drivers.warm import LAW_SETTINGS
    from hertzsweep.kernels.laws import LAWS, make_law

    covered = [type(make_law(law, 0.01, exponent)) for law, exponent in LAW_SETTINGS]
    assert sorted(covered, key=LAWS.index) == list(LAWS)
