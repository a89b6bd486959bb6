"""Compiled kernels (numba only; nothing here imports from the layers above).

``laws`` (damping laws as data), ``scheme`` (the one step of the central-difference
scheme, status codes), ``integrate`` (whole periods of one or many trajectories, and the
instruments), ``tangent`` (the one-period map with its exact Jacobian).

The compiled kernels are cached by numba, which checks only the source file of the
function it loads: a kernel in ``integrate.py`` built with an older ``scheme.py`` would be
loaded after ``scheme.py`` changed, silently. So the caches live in a folder named after
a hash of every source with compiled code (:data:`COMPILED_SOURCES`), and a change to any
of them compiles afresh (``NUMBA_CACHE_DIR``, when set, holds that folder).
"""

import hashlib
import os
from pathlib import Path

from numba import config

HERE = Path(__file__).resolve().parent
COMPILED_SOURCES = (*sorted(HERE.glob("*.py")), HERE.parent / "drivers" / "bench.py")


def cache_folder(base: str) -> str:
    """The numba cache folder, inside ``base``, of this version of the compiled sources."""
    digest = hashlib.sha256()
    for source in COMPILED_SOURCES:
        digest.update(source.read_bytes() if source.is_file() else b"")
    return os.path.join(base, f"hertzsweep-{digest.hexdigest()[:16]}")


CACHE_FOLDER = cache_folder(config.CACHE_DIR or str(HERE / "__pycache__"))


def _use_cache_folder() -> None:
    try:
        os.makedirs(CACHE_FOLDER, exist_ok=True)
    except OSError:  # not writable: numba's own cache places (or none) are used
        return
    if os.access(CACHE_FOLDER, os.W_OK):
        config.CACHE_DIR = CACHE_FOLDER


_use_cache_folder()
