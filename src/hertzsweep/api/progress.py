"""Progress meters, injected: the engine takes a callable ``progress(n)`` or None and never
imports tqdm. The command line shows a tqdm bar on stderr (off with --quiet or without a
TTY); the Python API shows the same bar when asked (``progress=True``), as tqdm's notebook
widget in Jupyter (:mod:`tqdm.auto` picks it), whether or not stderr is a terminal.

A bar is redrawn every :data:`TICK_SECONDS` by a thread of its own, so its elapsed time
keeps running while the units are long: a study's cases take seconds to minutes each, and
a bar redrawn only when one finishes would sit with a frozen clock in between.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

SMOOTHING = 0.3  # tqdm's default: the rate (and ETA) weighs recent units this much
TICK_SECONDS = 1.0  # how often an open bar is redrawn between updates: a clock in seconds
BAR_FORMAT = (  # "study:  25%|##        | 1/4 cases [00:12 elapsed, 00:36 left]"
    "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} UNITS "
    "[{elapsed} elapsed, {remaining} left{postfix}]"
)


@contextmanager
def progress_bar(
    total: int,
    desc: str,
    enabled: bool = True,
    unit: str = "dwell",
    initial: int = 0,
    smoothing: float = SMOOTHING,
    tick: float = TICK_SECONDS,
    terminal_only: bool = True,
) -> Iterator[Callable[[int], None] | None]:
    """A tqdm bar's ``update`` for ``total`` units (``initial`` of them already done), or
    None when disabled (or, with ``terminal_only``, when stderr is not a TTY). The bar
    shows the units done of the total, the elapsed time (redrawn every ``tick`` seconds)
    and the time left; in Jupyter, without ``terminal_only``, it is tqdm's notebook bar."""
    if not enabled or (terminal_only and not sys.stderr.isatty()):
        yield None
        return
    if terminal_only:
        from tqdm import tqdm
    else:
        from tqdm.auto import tqdm

    with tqdm(
        total=total,
        initial=initial,
        desc=desc,
        unit=unit,
        leave=False,
        smoothing=smoothing,
        bar_format=BAR_FORMAT.replace("UNITS", unit if unit == "%" else f"{unit}s"),
    ) as bar:
        stop = threading.Event()
        ticker = threading.Thread(
            target=_redraw, args=(bar, stop, tick), name="hertzsweep-progress", daemon=True
        )
        ticker.start()
        try:
            yield bar.update
        finally:
            stop.set()
            ticker.join()


def _redraw(bar: Any, stop: threading.Event, seconds: float) -> None:
    """Redraw the bar every ``seconds`` until ``stop`` is set (tqdm's own lock keeps the
    redraws and the updates apart)."""
    while not stop.wait(seconds):
        bar.refresh()
