"""Imported by a study's fork server (:data:`hertzsweep.drivers.study.PRELOADED`): its
import loads the compiled kernels of a sweep case from numba's cache
(:func:`hertzsweep.drivers.warm.load_kernels`), once, so that every worker forked from
that server starts with them loaded instead of loading them itself."""

from __future__ import annotations

from .warm import load_kernels

load_kernels()
