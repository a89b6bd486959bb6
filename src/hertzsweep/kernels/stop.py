"""A request to stop, polled by the compiled loops once per period.

SIGINT and SIGTERM must end a run within a second even inside a dwell of millions of
steps, and Python runs its signal handlers only between bytecodes, never inside a compiled
loop. So the loops (run with the GIL released) read :data:`REQUEST` at the end of every
period and return the status :data:`~.scheme.STOPPED` once it is set; the command line's
signal watcher (:mod:`hertzsweep.cli.signals`) sets it from another thread as soon as a
signal arrives. The read is an atomic load, which the optimiser may not hoist out of the
loop as it could a plain load of memory the loop never writes.
"""

from __future__ import annotations

import numpy as np
from numba import types
from numba.extending import intrinsic

REQUEST = np.zeros(1, dtype=np.int64)
"""The signal number that asked the run to stop; 0 while none has."""


@intrinsic
def requested(typingctx, flag):
    """``flag[0]`` of an int64 array, read from memory at every call."""
    if not (isinstance(flag, types.Array) and flag.dtype == types.int64):
        return None

    def codegen(context, builder, signature, args):
        array = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.load_atomic(array.data, "acquire", 8)

    return types.int64(flag), codegen


def request(signal_number: int) -> None:
    """Ask every compiled loop running or to come to stop (from any thread)."""
    REQUEST[0] = signal_number


def clear() -> None:
    """Withdraw the request (a new run starts)."""
    REQUEST[0] = 0
