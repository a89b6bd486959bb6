"""hertzsweep: simulated stepped-sine vibration tests of a preloaded Hertzian contact.

``import hertzsweep as hs`` gives the public API, :data:`__all__`: scenes
(:func:`load_scene`, :class:`Scene`), runs that return the :class:`xarray.Dataset` each
command writes (:func:`sweep`, :func:`trace`, :func:`branch`, ...), reading, comparing and
drawing datasets, and the typed exceptions. The names are imported on first use (PEP 562),
so ``import hertzsweep`` loads neither numpy nor xarray, numba or matplotlib. Every other
module is internal.

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

_API = (  # the public names of hertzsweep.api
    "Comparison",
    "Scene",
    "accuracy",
    "branch",
    "compare",
    "example_path",
    "example_scene",
    "export",
    "fit",
    "import_measurements",
    "load_scene",
    "open_dataset",
    "plot",
    "random",
    "rig",
    "save",
    "study",
    "summary",
    "sweep",
    "trace",
)
_ERRORS = (  # the public exceptions of hertzsweep.errors
    "ConfigError",
    "ConvergenceError",
    "Failed",
    "HertzsweepError",
    "IntegrationError",
    "Interrupted",
    "MeasurementError",
    "StabilityError",
    "Stopped",
)
__all__ = ["__version__", *_API, *_ERRORS]


def __getattr__(name: str) -> object:
    """The public names, imported from their modules on first use."""
    if name in _API:
        from . import api

        return getattr(api, name)
    if name in _ERRORS:
        from . import errors

        return getattr(errors, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
