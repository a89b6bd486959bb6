"""The choices, defaults, units and formats the commands use, from the engine's own tables, each
imported only when a command asks for it (``from hertzsweep.api.choices import
TRACE_BRANCHES`` loads the trace driver, nothing else): the command line's options are
built from these and cannot drift from what the engine accepts.
"""

from __future__ import annotations

import importlib

_SOURCES = {  # name -> (module, name there)
    "EXAMPLES": ("hertzsweep.core.examples", "EXAMPLES"),
    "IMPORT_PRESETS": ("hertzsweep.io.import_options", "PRESETS"),
    "KINDS": ("hertzsweep.core.kinds", "KINDS"),
    "RIG_UNITS": ("hertzsweep.core.rig", "UNITS"),
    "STABILITY": ("hertzsweep.core.model", "STABILITY"),
    "format_size": ("hertzsweep.core.checks", "format_size"),
    "FIT_FREE_KEYS": ("hertzsweep.drivers.fit", "FREE_KEYS"),
    "FIT_METHODS": ("hertzsweep.drivers.fit", "METHODS"),
    "TRACE_BRANCHES": ("hertzsweep.drivers.trace", "BRANCHES"),
    "TRACE_DEFAULT_PERIODS": ("hertzsweep.drivers.trace", "DEFAULT_PERIODS"),
}


def __getattr__(name: str) -> object:
    if name not in _SOURCES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, attribute = _SOURCES[name]
    return getattr(importlib.import_module(module), attribute)


__all__ = list(_SOURCES)
