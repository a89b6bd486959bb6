"""The options of a measurement file's import (:class:`ImportOptions`): how its numbers
become the peak harmonics of N/F_s in the SPEC's convention, and the presets of the
instruments whose files hertzsweep knows (:data:`PRESETS`). The conversions are given in
:mod:`hertzsweep.io.formats`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from ..errors import MeasurementError

PHASE_CONVENTIONS = ("lock-in", "spec")  # the instrument's lead, or the SPEC's lag phi_k
LOCKIN_COLUMNS = ("frequency", "x", "y", "r", "phase", "harmonic", "direction", "sigma")
PRESETS: dict[str, dict[str, Any]] = {  # name -> the options of an instrument's own file
    # Zurich Instruments LabOne sweeper CSV: grid, x, y, r, phase (rad), frequency, ...
    "labone-sweeper": {
        "columns": {"frequency": "frequency", "x": "x", "y": "y"},
        "rms": True,
        "phase_convention": "lock-in",
        "phase_unit": "rad",
    },
    # SR830 / SR86x, as a user saves them: freq, X, Y, R, theta (degrees)
    "sr8xx": {
        "columns": {"frequency": "freq", "x": "X", "y": "Y"},
        "rms": True,
        "phase_convention": "lock-in",
        "phase_unit": "deg",
    },
}


SIGNATURES = {  # preset -> the header columns that tell its instrument's file
    "labone-sweeper": ("grid", "frequency", "x", "y"),  # LabOne's sweeper always has grid
    "sr8xx": ("freq", "X", "Y"),
}


@dataclass(frozen=True)
class ImportOptions:
    """How to read a measurement file's numbers (every field optional; a file that holds
    a value itself needs no option for it).

    Attributes
    ----------
    columns : dict
        Lock-in tables: the file's column of each of :data:`LOCKIN_COLUMNS`, e.g.
        ``{"frequency": "freq", "x": "X", "y": "Y"}`` (or ``r`` and ``phase``).
    preset : str, optional
        A key of :data:`PRESETS`: its columns and conventions (the options given win).
    rms : bool
        Lock-in values are RMS (the default for a lock-in's X, Y, R); False: peak.
    phase_convention : str
        One of :data:`PHASE_CONVENTIONS`.
    phase_unit : str
        ``"deg"`` or ``"rad"``.
    sensitivity : float, optional
        [V/N] the force transducer's: values in volts become newtons.
    static_load : float, optional
        [N] F_s: newtons become N/F_s, and a force amplitude sigma.
    sigma : float, optional
        [1] the level F/F_s of a file that holds one sweep and no level.
    force_amplitude : float, optional
        [N] the same level as a force amplitude (with ``static_load``).
    direction : str, optional
        ``"up"`` or ``"down"`` for a file of one sweep without a direction column (default:
        by the order of its frequencies).
    moving_mass : float, optional
        [kg] the rig's moving mass, to convert a UFF accelerance, mobility or receptance
        to N/F (``m z'' = F_s + F - N``).
    """

    columns: dict[str, str] = field(default_factory=dict)
    preset: str | None = None
    rms: bool = True
    phase_convention: str = "lock-in"
    phase_unit: str = "deg"
    sensitivity: float | None = None
    static_load: float | None = None
    sigma: float | None = None
    force_amplitude: float | None = None
    direction: str | None = None
    moving_mass: float | None = None

    def resolved(self, source: str) -> ImportOptions:
        """The options with their preset applied (the options given win over it) and
        checked.

        Raises
        ------
        MeasurementError
            An unknown preset, column, convention or unit; a sensitivity, static load,
            level or mass that is not a positive finite number.
        """
        options = self
        if self.preset is not None:
            if self.preset not in PRESETS:
                known = ", ".join(PRESETS)
                reason = f"unknown preset {self.preset!r} (known: {known})"
                raise MeasurementError(source, 0, "--preset", reason)
            defaults, preset = ImportOptions(), PRESETS[self.preset]
            changes = {
                key: value
                for key, value in preset.items()
                if key != "columns" and getattr(self, key) == getattr(defaults, key)
            }
            changes["columns"] = {**_other_pair(preset["columns"], self.columns), **self.columns}
            options = replace(self, **changes)
        options.check(source)
        return options

    def check(self, source: str) -> None:
        """Refuse a value no file can be read with (see :meth:`resolved`)."""
        import math

        taken: dict[str, str] = {}
        for name, column in self.columns.items():
            if name not in LOCKIN_COLUMNS:
                known = ", ".join(LOCKIN_COLUMNS)
                raise MeasurementError(
                    source, 0, "--columns", f"unknown quantity {name!r} (known: {known})"
                )
            if not isinstance(column, str) or not column.strip():
                reason = f"{name}: expected the name of a column of the file, got {column!r}"
                raise MeasurementError(source, 0, "--columns", reason)
            if column in taken:
                reason = f"{taken[column]} and {name} both name the column {column!r}"
                raise MeasurementError(source, 0, "--columns", reason)
            taken[column] = name
        if self.phase_convention not in PHASE_CONVENTIONS:
            known = ", ".join(PHASE_CONVENTIONS)
            raise MeasurementError(
                source,
                0,
                "--phase-convention",
                f"expected one of {known}, got {self.phase_convention!r}",
            )
        if self.phase_unit not in ("deg", "rad"):
            raise MeasurementError(
                source, 0, "--phase-unit", f"expected deg or rad, got {self.phase_unit!r}"
            )
        if self.direction not in (None, "up", "down"):
            raise MeasurementError(
                source, 0, "--direction", f"expected up or down, got {self.direction!r}"
            )
        for name in ("sensitivity", "static_load", "sigma", "force_amplitude", "moving_mass"):
            value = getattr(self, name)
            if value is not None and not (
                isinstance(value, int | float)
                and not isinstance(value, bool)
                and math.isfinite(value)
                and value > 0
            ):
                option = "--" + name.replace("_", "-")
                raise MeasurementError(
                    source, 0, option, f"must be a positive number, got {value!r}"
                )
        if self.sigma is not None and self.force_amplitude is not None:
            raise MeasurementError(
                source, 0, "--sigma", "give --sigma or --force-amplitude, not both"
            )

    def level(self, source: str) -> float | None:
        """The level sigma the options give (None: the file must hold it).

        Raises
        ------
        MeasurementError
            A force amplitude without the static load.
        """
        if self.sigma is not None:
            return float(self.sigma)
        if self.force_amplitude is None:
            return None
        if self.static_load is None:
            raise MeasurementError(
                source, 0, "--force-amplitude", "needs --static-load (N) to give sigma"
            )
        return float(self.force_amplitude) / float(self.static_load)


def _other_pair(preset: dict[str, str], given: dict[str, str]) -> dict[str, str]:
    """A preset's columns without its x and y when the options give r or phase (or
    without its r and phase when they give x or y): a file is read through one pair."""
    for pair, other in ((("r", "phase"), ("x", "y")), (("x", "y"), ("r", "phase"))):
        if any(name in given for name in pair):
            return {name: column for name, column in preset.items() if name not in other}
    return dict(preset)
