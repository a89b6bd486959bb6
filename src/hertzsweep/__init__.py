"""hertzsweep: simulated stepped-sine vibration tests of a preloaded Hertzian contact.

``__version__`` is the version of the code as installed: setuptools-scm derives it from
git when the package is built or installed (``X.Y.Z`` at a ``vX.Y.Z`` tag, else
``X.Y.devN+gHASH``) and writes it to ``VERSION.txt`` beside this file; ``0+unknown`` when
that file is missing (the source tree used without installing it). The exact commit a
dataset was made with is read from git at run time
(:func:`hertzsweep.output.dataset.provenance`).
"""

import os

UNKNOWN_VERSION = "0+unknown"  # PEP 440, sorts below every release: the code is not known


def _installed_version() -> str:
    """The version written at install time, or :data:`UNKNOWN_VERSION`."""
    try:
        with open(os.path.join(os.path.dirname(__file__), "VERSION.txt")) as file:
            return file.read().strip() or UNKNOWN_VERSION
    except OSError:
        return UNKNOWN_VERSION


__version__ = _installed_version()
