"""``study --scheduler``: every address form ends within a bounded time in one line, exit
2; and a study survives losing a Dask worker."""

from __future__ import annotations

import os
import signal
import socket
import threading
import time

import numpy as np
import pytest

from hertzsweep.drivers.study import connect
from hertzsweep.errors import HertzsweepError
from hertzsweep.output.dataset import open_dataset

from .conftest import run_cli
from .test_study import slow_study, start, write_study

GRID = {"excitation.sigma": [0.004, 0.006]}


@pytest.mark.parametrize(
    ("address", "reason"),
    [
        ("tcp://127.0.0.1:1", "Connection refused"),  # a closed port: refused at once
        ("tcp://localhost:99999", "Port out of range"),
        ("tcp://:5", "expected tcp://HOST:PORT"),
        ("foo://bar", "unknown address scheme"),
        (":::", "Port could not be cast to integer"),
    ],
)
def test_bad_scheduler_address_is_one_line_at_once(tmp_path, capsys, address, reason):
    """None of these needs the connect deadline: 5 s is far above their 0.1 s."""
    path = write_study(tmp_path / "s.toml", GRID)
    began = time.monotonic()
    code, _, err = run_cli(["study", path, "-o", tmp_path / "o.nc", "--scheduler", address], capsys)
    assert time.monotonic() - began < 5.0
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert lines[0].startswith(f"hertzsweep: error: --scheduler: cannot connect to {address}: ")
    assert reason in lines[0]
    assert not (tmp_path / "o.nc").exists()


def test_a_port_that_accepts_but_never_speaks_dask_is_abandoned_at_the_deadline():
    """A listener that accepts and stays silent (a dashboard, an HTTP server): distributed's
    own timeout does not end the handshake; the connect gives up at its deadline (1 s
    here, plus the 1 s grace of the join: 4 s bounds it with room for a loaded runner)."""
    server = socket.create_server(("127.0.0.1", 0))
    held = []
    threading.Thread(target=lambda: held.append(server.accept()), daemon=True).start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    began = time.monotonic()
    with pytest.raises(HertzsweepError, match="no Dask scheduler answered within 1 s"):
        connect(address, seconds=1.0)
    assert time.monotonic() - began < 4.0
    server.close()


def _busy_worker_pid(cluster, deadline=60.0):
    """The process of a Dask worker running a case, once one is."""
    end = time.monotonic() + deadline
    while time.monotonic() < end:
        for state in cluster.scheduler.workers.values():
            if state.processing:
                for nanny in cluster.workers.values():
                    if nanny.worker_address == state.address:
                        return nanny.process.pid
        time.sleep(0.01)
    raise AssertionError("no case started")


def test_study_survives_losing_a_dask_worker(tmp_path):
    """Kill a Dask worker (SIGKILL) while it runs a case: the nanny restarts it, the
    scheduler reruns the case, and the study ends with all 6 cases computed, exit 0."""
    distributed = pytest.importorskip("distributed")
    path, out = slow_study(tmp_path), tmp_path / "out.nc"
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        proc = start(path, out, "--scheduler", cluster.scheduler_address)
        os.kill(_busy_worker_pid(cluster), signal.SIGKILL)
        stdout, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "6 cases: 6 computed, 0 resumed, 0 failed" in stdout, stdout[-300:]
    ds = open_dataset(out)
    assert ds.case_failed.shape == (6, 2) and int(ds.case_failed.sum()) == 0  # n x sigma
    assert np.isfinite(ds.amplitude.isel(harmonic=0)).all()
