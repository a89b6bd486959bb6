"""Measurement files in the formats rigs use, found by their content: hertzsweep's own CSV
(:mod:`hertzsweep.io.measured`), Universal File Format dataset 58 and 58b
(:mod:`hertzsweep.io.uff`) and lock-in tables, CSV or JSON rows
(:mod:`hertzsweep.io.lockin_table`), read with the options that turn a file's numbers
into the peak harmonics of N/F_s in the SPEC's convention
(:class:`~hertzsweep.io.import_options.ImportOptions`).

The conversions (the reference's "Measurement formats" page gives them with their
formulas):

- a lock-in reads ``R`` (RMS unless ``peak``) and ``theta`` of a transducer's voltage, or
  ``X = R cos(theta)``, ``Y = R sin(theta)``; the force is the voltage over the
  ``sensitivity`` [V/N]; ``A_k = sqrt(2) R / sensitivity / static_load`` (without
  ``sensitivity`` the values are taken as N/F_s already);
- the instrument's phase is the response's lead on its reference,
  ``V = sqrt(2) R sin(w t + theta)``, so ``phi_k = -theta`` (``phase_convention =
  "lock-in"``); ``"spec"`` takes the column as phi_k already;
- the level: ``sigma``, or ``force_amplitude / static_load``.
"""

from __future__ import annotations

import os
from dataclasses import replace
from typing import Any

from ..errors import MeasurementError
from .import_options import SIGNATURES, ImportOptions


def detect(head: bytes, options: ImportOptions) -> tuple[str, str | None]:
    """What a measurement file holds, from its first bytes (not its name), and the preset
    its header matches (or None):

    - ``"uff"``: a ``-1`` delimiter line opens it (UFF 58 and 58b);
    - ``"lockin"``: JSON rows; a CSV when a column map is given (``columns`` or a
      ``preset``); a CSV whose header has none of hertzsweep's own value columns
      (``amplitude``, ``jump_frequency``) but the columns of an instrument's file
      (:data:`SIGNATURES`: its preset is taken), or ``frequency`` with ``x`` and ``y`` (or ``r`` and
      ``phase``);
    - ``"csv"``: hertzsweep's own CSV (its reader says what is wrong with one that is not).
    """
    text = head.decode("utf-8", "replace").lstrip("\ufeff")
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    if lines and lines[0] == "-1":
        return "uff", None
    if lines and lines[0].startswith(("[", "{")):
        return "lockin", None
    if options.columns or options.preset:
        return "lockin", None
    header = next((line for line in lines if not line.startswith("#")), "")
    cells = {
        cell.strip().strip('"') for cell in header.replace(";", ",").replace("\t", ",").split(",")
    }
    if cells & {"amplitude", "jump_frequency", "jump_frequency_ratio"}:
        return "csv", None
    for name, signature in SIGNATURES.items():
        if set(signature) <= cells:
            return "lockin", name
    if "frequency" in cells and ({"x", "y"} <= cells or {"r", "phase"} <= cells):
        return "lockin", None  # the quantities' own names: no map needed
    return "csv", None


HEAD_BYTES = 4096  # the first bytes that tell a file's kind (a UFF delimiter, a header)
OWN_CSV_OPTIONS = ("columns", "preset", "sensitivity", "sigma", "force_amplitude")  # that
# hertzsweep's CSV refuses: it holds N/F_s and its levels (a static load is just not used)


def read_any(path: str | os.PathLike, options: ImportOptions | None = None) -> Any:
    """The measurements of a file of any kind :func:`detect` tells (CSV of hertzsweep's
    own layout, UFF 58/58b, a lock-in table), read with ``options``.

    Raises
    ------
    MeasurementError
        The file cannot be read, or breaks a rule of its kind: one line naming the file,
        the line (or the UFF set) and the column (or key); an option that hertzsweep's own
        CSV does not take (it holds N/F_s and its levels already).
    """
    from ..core.config import read_bytes
    from ..errors import ConfigError
    from .measured import MAX_MEASUREMENT_BYTES, read_measurements

    source = str(path)
    options = (options or ImportOptions()).resolved(source)
    try:
        head = read_bytes(path, MAX_MEASUREMENT_BYTES)[:HEAD_BYTES]
    except ConfigError as exc:
        raise MeasurementError(source, 0, "", exc.reason) from None
    kind, preset = detect(head, options)
    if preset is not None:
        options = replace(options, preset=preset).resolved(source)
    if kind == "csv":
        defaults = ImportOptions()
        for name in OWN_CSV_OPTIONS:
            if getattr(options, name) != getattr(defaults, name):
                option = "--" + name.replace("_", "-")
                reason = "hertzsweep's own CSV holds N/F_s and its levels: no option applies"
                raise MeasurementError(source, 0, option, reason)
        return read_measurements(path)
    if kind == "uff":
        from .uff import read_uff

        return read_uff(path, options)
    from .lockin_table import read_lockin_table

    return read_lockin_table(path, options)
