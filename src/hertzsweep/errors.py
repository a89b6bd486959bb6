"""The one module of exceptions.

Every error a user can cause is a :class:`HertzsweepError` (a ``ValueError``).
Only the command line turns them into a one-line message and exit status 2.
"""

from __future__ import annotations


class HertzsweepError(ValueError):
    """Base class of the errors a user can cause (bad file, key, value or setting)."""


class ConfigError(HertzsweepError):
    """A configuration file, key or value is wrong.

    Parameters
    ----------
    source : str
        The file (or ``--set``) the value came from.
    key : str
        The dotted key, e.g. ``"damping.ratio"``; empty when the file itself is at fault.
    reason : str
        What is wrong, and what is allowed.
    """

    def __init__(self, source: str, key: str, reason: str) -> None:
        self.source = source
        self.key = key
        self.reason = reason
        where = f"{source}: {key}: " if key else f"{source}: "
        super().__init__(where + reason)


class StabilityError(HertzsweepError):
    """The time step is beyond the stability limit of the explicit scheme."""


class IntegrationError(HertzsweepError):
    """The state became non-finite during a run (no NaN is ever written as a result)."""


class ConvergenceError(HertzsweepError):
    """A Newton iteration or a continuation could not converge."""


class Interrupted(KeyboardInterrupt):
    """A run was stopped by SIGINT or SIGTERM; ``partial`` holds what it finished."""

    def __init__(self, partial: object = None, signal_number: int = 2) -> None:
        super().__init__("interrupted")
        self.partial = partial
        self.signal_number = signal_number
