"""SIGINT and SIGTERM: a run stops within a second, keeps what it finished, and a second
signal does not lose it.

- The first signal raises :class:`~hertzsweep.errors.Interrupted` in the main thread (as
  Python does, between bytecodes) and, through a watcher thread woken by the interpreter's
  wake-up file descriptor, asks the compiled loops to stop (:mod:`hertzsweep.kernels.stop`):
  they run with the GIL released and poll that request once a period, so a dwell of any
  length ends within a period of the signal.
- Signals after the first are noted and otherwise ignored: the command is already ending,
  writing what it finished (``OUT.partial.nc``); an exception raised in the middle of that
  write would lose it. The exit status is 128 + the first signal's number.

The watcher sets the request only if the kernels are loaded (a command that never
imports them has no compiled loop to stop), so installing it costs no import.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

from ..errors import Interrupted

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_state = {"installed": False, "first": 0}


def install() -> None:
    """Handle SIGINT and SIGTERM as above (from the main thread; once per process, then
    only the run's state is reset)."""
    _state["first"] = 0
    kernels = sys.modules.get("hertzsweep.kernels.stop")
    if kernels is not None:
        kernels.clear()
    if threading.current_thread() is not threading.main_thread():
        return  # signal handlers can only be set from the main thread
    for number in STOP_SIGNALS:
        signal.signal(number, _on_signal)
    if not _state["installed"]:
        _start_watcher()
        _state["installed"] = True


def _on_signal(number: int, frame: object) -> None:
    if _state["first"]:
        return  # already stopping: keep writing what was finished
    _state["first"] = number
    _request_stop(number)
    raise Interrupted(None, number)


def _request_stop(number: int) -> None:
    kernels = sys.modules.get("hertzsweep.kernels.stop")
    if kernels is not None:
        kernels.request(number)


def _start_watcher() -> None:
    """A daemon thread reading the signal numbers the interpreter writes to its wake-up
    file descriptor the moment a signal arrives (even while the main thread is inside a
    compiled loop, where the Python handler cannot run yet)."""
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    try:
        signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)
    except ValueError:  # not the main thread of the main interpreter
        os.close(read_end)
        os.close(write_end)
        return

    def watch() -> None:
        while True:
            try:
                data = os.read(read_end, 64)
            except OSError:
                return
            if not data:
                return
            for number in data:
                if number in STOP_SIGNALS:
                    _request_stop(number)

    threading.Thread(target=watch, name="hertzsweep-signals", daemon=True).start()
