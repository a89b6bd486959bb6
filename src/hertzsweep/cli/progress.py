"""Progress meters, injected: the core takes a callable ``progress(n)`` or None and never
imports tqdm; the CLI builds a tqdm bar (on stderr, off with --quiet or without a TTY)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

SMOOTHING = 0.3  # tqdm's default: the rate (and ETA) weighs recent units this much


@contextmanager
def progress_bar(
    total: int,
    desc: str,
    enabled: bool = True,
    unit: str = "dwell",
    initial: int = 0,
    smoothing: float = SMOOTHING,
) -> Iterator[Callable[[int], None] | None]:
    """A tqdm bar's ``update`` for ``total`` units (``initial`` of them already done), or
    None when disabled or not a TTY."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from tqdm import tqdm

    with tqdm(
        total=total,
        initial=initial,
        desc=desc,
        unit=unit,
        file=sys.stderr,
        leave=False,
        smoothing=smoothing,
    ) as bar:
        yield bar.update
