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
import sys
import tempfile
from pathlib import Path

from numba import config

HERE = Path(__file__).resolve().parent
COMPILED_SOURCES = (*sorted(HERE.glob("*.py")), HERE.parent / "drivers" / "bench.py")
NUMBA_CACHE_DIR = config.CACHE_DIR  # as the environment set it (numba's config is changed)


def cache_folder(base: str) -> str:
    """The numba cache folder, inside ``base``, of this version of the compiled sources."""
    digest = hashlib.sha256()
    for source in COMPILED_SOURCES:
        digest.update(source.read_bytes() if source.is_file() else b"")
    return os.path.join(base, f"hertzsweep-{digest.hexdigest()[:16]}")


def cache_bases() -> list[str]:
    """Where the cache folder may go, in order: ``NUMBA_CACHE_DIR`` if set, else beside
    the sources; then the user's cache folder; then the temporary folder (a read-only
    install, or no writable home, still caches)."""
    user = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return [
        NUMBA_CACHE_DIR or str(HERE / "__pycache__"),
        os.path.join(user, "hertzsweep"),
        os.path.join(tempfile.gettempdir(), f"hertzsweep-cache-{os.getuid()}"),
    ]


def _writable(folder: str) -> bool:
    """Whether a file can be created in ``folder`` (made if missing): tried for real,
    since permission bits say nothing of a read-only mount or of root."""
    try:
        os.makedirs(folder, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def _choose_cache() -> str:
    """Point numba at the first writable cache folder and return it; "" (and one warning
    line) when there is none, and the kernels then compile in every process, uncached."""
    for base in cache_bases():
        folder = cache_folder(base)
        if _writable(folder):
            config.CACHE_DIR = folder
            return folder
    sys.stderr.write(
        "hertzsweep: warning: no writable folder for the compiled kernels' cache "
        f"(tried {', '.join(cache_bases())}): they compile in every run\n"
    )
    return ""


CACHE_FOLDER = _choose_cache()
CACHE = bool(CACHE_FOLDER)
"""Whether the kernels are cached on disk (every ``njit`` here takes ``cache=CACHE``)."""
