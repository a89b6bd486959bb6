"""The one module of exceptions.

Every error a user can cause is a :class:`HertzsweepError` (a ``ValueError``). Only the
command line (:func:`hertzsweep.cli.main`) turns an exception into a one-line message and
an exit status:

- :class:`HertzsweepError`: 2;
- :class:`Failed`: 1 (e.g. a study kept its other cases);
- :class:`Stopped`, :class:`Interrupted`: 128 + the signal number.

A layer that catches an error to say where it happened adds that with
:meth:`HertzsweepError.with_context` and re-raises the same exception: its type and its
fields stay.
"""

from __future__ import annotations

from typing import Any, Self


class HertzsweepError(ValueError):
    """Base class of the errors a user can cause (bad file, key, value or setting)."""

    def with_context(self, prefix: str) -> Self:
        """Prefix the message with where the error happened, in place.

        Parameters
        ----------
        prefix : str
            E.g. ``"scene.toml: up sweep"``; the message becomes ``"PREFIX: message"``.

        Returns
        -------
        HertzsweepError
            The same exception (same type, same fields, same traceback), to re-raise::

                except HertzsweepError as exc:
                    raise exc.with_context(f"{scene.source}: trace at w = {w:g}") from None
        """
        self.args = (f"{prefix}: {self}",)
        return self


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

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle by the fields (the constructor does not take the message), keeping a
        message given context by :meth:`with_context`."""
        return (type(self), (self.source, self.key, self.reason), {"args": self.args})


class MeasurementError(HertzsweepError):
    """A file of measurements (CSV) is wrong.

    Parameters
    ----------
    source : str
        The file.
    line : int
        The line of the file (1 is the first), 0 when the file itself is at fault.
    column : str
        The column's name; empty when the whole line or file is at fault.
    reason : str
        What is wrong, and what is allowed.
    """

    def __init__(self, source: str, line: int, column: str, reason: str) -> None:
        self.source = source
        self.line = line
        self.column = column
        self.reason = reason
        where = (
            f"{source}: " + (f"line {line}: " if line else "") + (f"{column}: " if column else "")
        )
        super().__init__(where + reason)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickle by the fields, keeping a message given context by :meth:`with_context`."""
        return (
            type(self),
            (self.source, self.line, self.column, self.reason),
            {"args": self.args},
        )


class StabilityError(HertzsweepError):
    """The time step is beyond the stability limit of the explicit scheme."""


class IntegrationError(HertzsweepError):
    """The state became non-finite during a run (no NaN is ever written as a result)."""


class ConvergenceError(HertzsweepError):
    """A Newton iteration or a continuation could not converge."""


class Failed(Exception):
    """The command ran to its end and reports a failure: some cases of a study failed (the
    others were kept and written), a result lies outside its tolerance. Exit status 1."""


class Stopped(Exception):
    """A run stopped on request (SIGINT or SIGTERM) after keeping what it finished.

    Parameters
    ----------
    message : str
        What was kept, and how to go on.
    signal_number : int
        The signal that stopped it (the exit status is 128 + this).
    """

    def __init__(self, message: str, signal_number: int) -> None:
        super().__init__(message)
        self.signal_number = signal_number


class Interrupted(KeyboardInterrupt):
    """A run was stopped by SIGINT or SIGTERM; ``partial`` holds what it finished."""

    def __init__(self, partial: object = None, signal_number: int = 2) -> None:
        super().__init__("interrupted")
        self.partial = partial
        self.signal_number = signal_number
