"""Progress meters, injected: the core takes a callable ``progress(n)`` or None and never
imports tqdm; the CLI builds a tqdm bar (on stderr, off with --quiet or without a TTY)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager


@contextmanager
def progress_bar(
    total: int, desc: str, enabled: bool = True, unit: str = "dwell"
) -> Iterator[Callable[[int], None] | None]:
    """A tqdm bar's ``update`` for ``total`` units, or None when disabled or not a TTY."""
    if not enabled or not sys.stderr.isatty():
        yield None
        return
    from tqdm import tqdm

    with tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, leave=False) as bar:
        yield bar.update
