"""SIGINT/SIGTERM: every compiled loop stops within a period of the request (a run ends
143 with what it finished kept, a second signal ignored: test_cli.py
test_sigterm_keeps_finished_work)."""

from __future__ import annotations

import signal
import threading
import time

import numpy as np
import pytest

from hertzsweep.drivers.oscillator import Oscillator, drive
from hertzsweep.drivers.shooting import PREDICT_RESIDUAL, PeriodMap, newton_settings, transient
from hertzsweep.errors import Interrupted
from hertzsweep.kernels import integrate, scheme, stop, tangent
from hertzsweep.kernels.laws import make_law

from .conftest import make_scene

N = 256
H = scheme.step_size(0.95, N)
LONG = 2_000_000  # periods: 5e8 steps, seconds of work for any kernel on any machine
SIGNAL_AFTER = 0.3  # [s] the loop is surely running by then (warm kernels start in us)
PROMPT = 1.0  # [s] the bound on stopping after a signal


def _law():
    return make_law("contact", 0.01, 1.5)


def _drive(levels):
    return drive(make_scene(solver={"steps_per_period": N}), levels)


def _advance(periods):
    return integrate.advance(0.0, 0.0, H, _law(), _drive(0.01), periods)[2]


def _approach(periods):  # tolerance 0: never close, so only a stop ends it early
    return tangent.approach(0.0, 0.0, H, _law(), _drive(0.01), 100, periods, 0.0)[3]


def _advance_batch(periods):
    q = np.zeros(4)
    return integrate.advance_batch(q, q.copy(), np.full(4, H), _law(), _drive([0.01] * 4), periods)[
        0
    ]


def _measure(periods):
    q = np.zeros(4)
    readout = integrate.new_readout(2, 4)
    law, levels = _law(), _drive([0.01] * 4)
    return integrate.measure(q, q.copy(), np.full(4, H), law, levels, periods, readout)[0]


def _measure_one(periods):
    readout = integrate.new_readout(2, 1)
    q = np.zeros(1)
    return integrate.measure_one(
        q, q.copy(), np.full(1, H), _law(), _drive(0.01), periods, readout
    )[0]


def _shooting_walk(periods):
    """A walk of many dwells at a huge N (each Newton period is long)."""
    scene = make_scene(solver={"steps_per_period": 2**20 if periods == LONG else 64})
    oscillator = Oscillator(scene, 0.01)
    steps = np.full(1000 if periods == LONG else 1, oscillator.step(0.95))
    period = PeriodMap(oscillator)
    settings = newton_settings(period, monotone=True, predict=PREDICT_RESIDUAL)
    settling = transient(period, 2000)
    readout = integrate.new_readout(2, steps.size)
    x = np.array([0.0, 0.0, steps[0]])
    law, levels = oscillator.law, oscillator.drive
    stop_at, _, _ = tangent.shooting_walk(x, steps, law, levels, settings, readout, 0, settling)
    return scheme.STOPPED if stop_at < steps.size else scheme.OK


KERNELS = {
    "advance": _advance,
    "approach": _approach,
    "advance_batch": _advance_batch,
    "measure": _measure,
    "measure_one": _measure_one,
    "shooting_walk": _shooting_walk,
}


@pytest.mark.parametrize("name", list(KERNELS))
def test_every_compiled_loop_stops_within_a_period_of_the_request(name):
    """The loop runs in a thread; the main thread requests a stop after 0.3 s. A kernel
    that does not poll the request, or that holds the GIL (so the request cannot even be
    set), runs its seconds of work to the end and fails the 1 s bound."""
    run = KERNELS[name]
    stop.clear()
    run(1)  # compiled (or loaded) before the clock starts
    outcome = {}

    def target():
        outcome["status"] = run(LONG)
        outcome["end"] = time.perf_counter()

    thread = threading.Thread(target=target)
    thread.start()
    time.sleep(SIGNAL_AFTER)
    asked = time.perf_counter()
    stop.request(signal.SIGTERM)
    thread.join(timeout=60)
    stop.clear()
    assert not thread.is_alive()
    assert outcome["status"] == scheme.STOPPED
    assert outcome["end"] - asked < PROMPT


def test_stopped_status_is_the_signal_that_asked():
    stop.request(signal.SIGTERM)
    try:
        with pytest.raises(Interrupted) as caught:
            scheme.check_status(scheme.STOPPED, 0.01, 0.9, 256)
    finally:
        stop.clear()
    assert caught.value.signal_number == signal.SIGTERM
