"""Progress meters, injected: the core takes a callable ``progress(n)`` or None and never
imports tqdm; the CLI builds a tqdm bar (on stderr, off with --quiet or without a TTY).

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
) -> Iterator[Callable[[int], None] | None]:
    """A tqdm bar's ``update`` for ``total`` units (``initial`` of them already done), or
    None when disabled or not a TTY. The bar shows the units done of the total, the
    elapsed time (redrawn every ``tick`` seconds) and the time left."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from tqdm import tqdm

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
