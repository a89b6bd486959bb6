"""Universal File Format dataset 58 (ASCII) and 58b (binary), through ``pyuff``: sweeps,
measurements and fits out (:func:`export_uff`), measured FRFs in (:func:`read_uff`).

pyuff is imported inside the functions only: ``import hertzsweep`` and the commands that
do not read or write UFF never load it.

The file :func:`export_uff` writes
----------------------------------
A dataset 151 (header: the dataset's title, ``hertzsweep VERSION``) and a dataset 164
(units: SI, every factor 1), then one dataset 58 per (direction, sigma, harmonic k) of a
``sweep`` (``amplitude``, ``phase``), ``measured`` (``amplitude``, ``phase``) or ``fit``
dataset (its fitted model, ``model_amplitude``, ``model_phase``: harmonic 1; the data it
was fitted to are the ``measured`` dataset's). Each set holds the complex ratio of the k-th
harmonic of the transmitted force N to the excitation force F (amplitude sigma F_s)::

    N_k / F_1 = A_k exp(-i phi_k) / sigma

in the convention ``x(t) = Re(X exp(+i w t))``: the SPEC's ``A_k sin(k w tau - phi_k)``
lags by phi_k, which is ``-phi_k`` in the argument. Record by record:

- record 6: ``func_type`` 4 (frequency response function) for k = 1; 0 (general) for
  k >= 2, since a modal-analysis code would fit the resonance of any FRF it is given, and
  H2 has none of its own. ``func_id`` = k; ``ver_num`` the direction (1 up, 2 down);
  ``load_case_id`` 0 (single-point excitation); response: node 1 ``contact`` +Z (the
  lower contact's force); reference: node 2 ``excitation`` +Z;
- record 7: complex double ordinates, uneven abscissa (``abscissa_spacing`` 0: the
  frequencies are stored one by one, since points left out make any grid uneven);
  ``z_axis_value`` the level sigma;
- records 8-11: abscissa 18 (frequency) in Hz, the excitation frequency for every order
  k; ordinate 9 (reaction force: N, the force the contact transmits) over ordinate
  denominator 13 (excitation force: F), both in N; z axis 1 (general, dimensionless)
  labelled ``sigma`` in ``F/F_s``: UFF has no field for a force level, and the z axis is
  the one record that describes each function's setting by one number;
- ``id1`` what the set is and the convention (``hertzsweep sweep: N1/F1 = A_1 exp(-i
  phi_1)/sigma, e^(+i w t)``); ``id2`` the harmonic, direction and sigma to full
  precision (``z_axis_value`` keeps 6 digits); ``id3`` the dataset's title; ``id4`` when
  the file was written; ``id5`` ``hertzsweep VERSION``.

Points with no reading (NaN: not measured) and, in a sweep, points not settled or not
periodic (``settled == 0`` or ``periodic == 0``) are left out (pyuff would write NaN as 0)
and counted (:class:`ExportReport`); so is a point alone in its set, which pyuff cannot
write (it takes an abscissa step from the first two points). Orders that are not whole
(``[lockin] harmonics = [0.5, ...]``) are not written: ``func_id`` holds whole numbers.

What each format keeps: 58b stores every value as an IEEE double (a round trip is exact to
the last bit of the ratio's arithmetic); ASCII 58 writes the ordinates as ``E20.11`` (12
significant digits) but the abscissa as ``E13.5`` (6 significant digits: the record's own
format, a frequency to 5e-6 of itself) and ``z_axis_value`` as ``E13.5``.

What :func:`read_uff` reads
---------------------------
Every dataset 58: ``func_type`` 4 is harmonic 1, ``func_type`` 0 with ``func_id`` = k >= 2
is harmonic k; another ``func_type`` is refused. Datasets 151 are skipped, a dataset 164
sets the units of the sets after it (to SI: divide by its factors), other kinds of set
(geometry, ...) are skipped. For each set:

- the level: ``z_axis_value`` when the z axis is labelled ``sigma`` (our own files: the
  full-precision value of ``id2``), else the options' (``--sigma``, or
  ``--force-amplitude`` over ``--static-load``);
- the direction: in a file hertzsweep wrote (``id1`` begins ``hertzsweep``) ``ver_num``;
  in another, the options' ``--direction``, else ``ver_num`` 1 or 2, else the order of the
  set's frequencies (increasing: up, decreasing: down);
- the frequencies: positive, finite and strictly monotonic;
- the ordinate: a force over a force (9 or 13 over 0, 9 or 13) is N/F as it is; a motion
  of the moving mass over the excitation force is converted with the moving mass m
  (``--moving-mass``), which obeys ``m z'' = F_s + F - N``: the k-th harmonic of
  ``N/F_1`` is ``delta_k1 - m a_k`` with the accelerance ``a_k = z''_k / F_1``. In the
  ``exp(+i W t)`` convention (W = k omega, omega = 2 pi f in rad/s) ``z'' = i W z' = -W^2
  z``, so an accelerance A (12), a mobility V (11) and a receptance X (8) give::

      N_1/F_1 = 1 - m A = 1 - i omega m V = 1 + m omega^2 X

  (the mobility's sign is the convention's: ``exp(-i W t)`` would flip it);
- then ``A_k = |H| sigma`` and ``phi_k = -arg(H)`` in degrees in [0, 360).

A bad file raises :class:`~hertzsweep.errors.MeasurementError` naming the file, the
dataset (counted from 1 in the file's order, headers included) and the key, in one line;
so does a file pyuff cannot parse.
"""

from __future__ import annotations

import math
import os
import re
import stat
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import __version__
from ..core.kinds import EXPORT_KINDS, KINDS
from ..core.lockin import order_label
from ..drivers.fit import SweepMeasurements
from ..errors import HertzsweepError, MeasurementError
from ..output.paths import atomic_path, sync_path
from .import_options import ImportOptions

if TYPE_CHECKING:  # xarray is imported by whoever made the dataset
    import xarray as xr

DIRECTION_CODES = {"up": 1, "down": 2}  # ver_num of each sweep direction
H1_FUNCTION = 4  # func_type of harmonic 1: a frequency response function
ORDER_FUNCTION = 0  # func_type of harmonics k >= 2: general (not an FRF a modal code fits)
FREQUENCY = 18  # specific data type of the abscissa: frequency [Hz]
REACTION_FORCE = 9  # specific data type of N, the force the contact transmits
EXCITATION_FORCE = 13  # specific data type of F, the shaker's force
GENERAL = 1  # specific data type of the z axis: general (sigma, dimensionless)
FORCES = (REACTION_FORCE, EXCITATION_FORCE)  # ordinates that are forces (N/F as it is)
DISPLACEMENT, VELOCITY, ACCELERATION = 8, 11, 12  # ordinates of the moving mass's motion
MOTIONS = {DISPLACEMENT: "receptance", VELOCITY: "mobility", ACCELERATION: "accelerance"}
DENOMINATORS = (0, *FORCES)  # denominator codes read as the excitation force (0: not given)
RESPONSE_NODE, REFERENCE_NODE = 1, 2  # nodes: the lower contact (N), the excitation (F)
PLUS_Z = 3  # direction code of both: +Z translation, the axis of the preload
SI_UNITS = {  # dataset 164 of SI: code 1, factors 1 (temperature: kelvin, offset 273.15)
    "units_code": 1,
    "units_description": "SI units",
    "temp_mode": 1,
    "length": 1.0,
    "force": 1.0,
    "temp": 1.0,
    "temp_offset": 273.15,
}
LEVEL_LABEL = "sigma"  # z-axis label of a set whose z_axis_value is the level F/F_s
LEVEL_UNITS = "F/F_s"  # its units label
OUR_MARK = "hertzsweep"  # id1 of a set hertzsweep wrote begins with this
ID_WIDTH = 80  # characters of an id line (records 1-5: Format(80A1))
ENTITY_WIDTH = 10  # characters of an entity name in record 6 (10A1)
LABEL_WIDTH = 20  # characters of an axis or units label in records 8-11 (20A1)
ASCII_ABSCISSA = "%13.5e"  # how ASCII 58 writes a frequency (E13.5: 6 significant digits)
LEVEL_AGREEMENT = 1e-5  # relative: id2's sigma is taken when it matches z_axis_value,
# written as E13.5 (rounded to 5e-6 of itself)
MAX_UFF_BYTES = 1 << 30  # a rig's FRF file is kilobytes to megabytes (hundreds of channels:
# some hundred MB); 1 GiB refuses a wrong file (a disk image) before pyuff reads it whole
GRAVITY_UNIT_LABELS = ("g", "g/n", "g/lbf")  # accelerance units in g: refused, not
# guessed (the numbers may or may not be in g whatever the label says)


# --------------------------------------------------------------------------- export
@dataclass(frozen=True)
class ExportReport:
    """What :func:`export_uff` wrote.

    Attributes
    ----------
    path : str
        The file written.
    binary : bool
        58b (True) or ASCII 58.
    sets : int
        Datasets 58 written (one per direction, sigma and harmonic with points).
    points : int
        Points written, over all sets.
    left_out : int
        Points left out: not measured (NaN), or not settled or not periodic.
    alone : int
        Points left out because each was the only one of its set.
    total : int
        Points the dataset holds (whole harmonics only).
    skipped_orders : tuple of float
        Orders not written, not being whole numbers.
    """

    path: str
    binary: bool
    sets: int
    points: int
    left_out: int
    alone: int
    total: int
    skipped_orders: tuple[float, ...] = ()

    def line(self) -> str:
        """One line for the user, e.g. ``"wrote 8 UFF 58b sets of 241 points; left out 3 of
        244 points (not settled or not measured)"``."""
        kind = "58b" if self.binary else "58"
        text = f"wrote {self.sets} UFF {kind} sets of {self.points} points"
        text += f"; left out {self.left_out} of {self.total} points (not settled or not measured)"
        if self.alone:
            text += f" and {self.alone} alone in a set (pyuff writes no set of one point)"
        if self.skipped_orders:
            orders = ", ".join(order_label(k) for k in self.skipped_orders)
            text += f"; orders {orders} not written (func_id holds whole orders)"
        return text


@dataclass(frozen=True)
class _Set:
    """One function to write: a (direction, sigma, harmonic) and its points."""

    direction: str
    sigma: float
    harmonic: int
    frequency: np.ndarray  # [Hz], increasing
    ratio: np.ndarray  # N_k / F_1, complex


def export_uff(ds: xr.Dataset, path: str | os.PathLike, binary: bool = True) -> ExportReport:
    """Write a ``sweep``, ``measured`` or ``fit`` dataset as UFF 58b (or ASCII 58).

    Parameters
    ----------
    ds : xarray.Dataset
        Of kind ``sweep``, ``measured`` (of sweeps, frequencies in Hz) or ``fit`` (of
        sweeps).
    path : path
        The file: complete or absent (written to a temporary name, then renamed).
    binary : bool
        58b (every value an IEEE double) or ASCII 58 (frequencies to 6 digits).

    Returns
    -------
    ExportReport
        Sets and points written and left out (module notes).

    Raises
    ------
    HertzsweepError
        Another kind of dataset, measurements without frequencies in Hz, nothing left to
        write, or (ASCII) frequencies too close for its 6 digits.
    OSError
        The file could not be written (naming ``path``).
    """
    kind, sets, counts = _functions(ds)
    if not sets:
        raise HertzsweepError(
            f"nothing to export: each of the {counts['total']} points is not settled or not "
            "measured, or alone in its set"
        )
    if not binary:
        for item in sets:
            _check_ascii_abscissa(item)
    title = _text(str(ds.attrs.get("title", f"hertzsweep {kind} dataset")))
    written = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    dsets = [_header(title), _si_units()]
    dsets += [_dataset_58(item, kind, title, written, binary) for item in sets]
    with atomic_path(path) as tmp:
        _write(tmp, dsets)
        sync_path(tmp)
    return ExportReport(
        path=os.fspath(path),
        binary=bool(binary),
        sets=len(sets),
        points=sum(item.frequency.size for item in sets),
        left_out=counts["left_out"],
        alone=counts["alone"],
        total=counts["total"],
        skipped_orders=counts["skipped"],
    )


def _functions(ds: xr.Dataset) -> tuple[str, list[_Set], dict[str, Any]]:
    """The dataset's kind, its functions to write and the counts of points."""
    kind = ds.attrs.get("hertzsweep_kind")
    if kind not in EXPORT_KINDS:
        raise HertzsweepError(
            f"UFF export: expected a sweep, measured or fit dataset, got "
            f"{kind or 'a non-hertzsweep'} dataset"
        )
    amplitude_name, phase_name = KINDS[kind].exports
    if amplitude_name not in ds or "direction" not in ds.dims or "sigma" not in ds.dims:
        what = "jump frequencies" if ds.attrs.get("measured_kind") == "jumps" else "no sweeps"
        raise HertzsweepError(f"UFF export: the {kind} dataset holds {what}, no sweep to write")
    if "frequency" not in ds.coords:
        raise HertzsweepError(
            f"UFF export: the {kind} dataset has frequency ratios only; UFF needs frequencies "
            "in Hz (measure or import them in Hz)"
        )
    axis = "frequency_ratio" if "frequency_ratio" in ds[amplitude_name].dims else "frequency"
    amplitude, phase = ds[amplitude_name], ds[phase_name]
    if "harmonic" not in amplitude.dims:  # a fit: harmonic 1 only
        amplitude = amplitude.expand_dims(harmonic=[1])
        phase = phase.expand_dims(harmonic=[1])
    order = ("direction", "sigma", axis, "harmonic")
    a = np.asarray(amplitude.transpose(*order).values, dtype=float)
    phi = np.asarray(phase.transpose(*order).values, dtype=float)
    keep = np.isfinite(a) & np.isfinite(phi)
    for flag in ("settled", "periodic"):
        if kind == "sweep" and flag in ds:
            good = np.asarray(ds[flag].transpose(*order[:3]).values) == 1
            keep &= good[..., np.newaxis]
    frequency = np.asarray(ds["frequency"].values, dtype=float)
    rank = np.argsort(frequency, kind="stable")
    harmonics = np.asarray(amplitude["harmonic"].values, dtype=float)
    whole = [j for j, k in enumerate(harmonics) if k >= 1 and float(k).is_integer()]
    skipped = tuple(float(k) for j, k in enumerate(harmonics) if j not in whole)
    directions = [str(d) for d in np.asarray(ds["direction"].values)]
    sigmas = np.asarray(ds["sigma"].values, dtype=float)
    sets: list[_Set] = []
    alone = 0
    for i, direction in enumerate(directions):
        for s, sigma in enumerate(sigmas):
            for j in whole:
                rows = rank[keep[i, s, rank, j]]
                if rows.size == 1:
                    alone += 1
                    continue
                if rows.size == 0:
                    continue
                ratio = a[i, s, rows, j] * np.exp(-1j * np.radians(phi[i, s, rows, j])) / sigma
                sets.append(
                    _Set(direction, float(sigma), int(harmonics[j]), frequency[rows], ratio)
                )
    total = len(directions) * sigmas.size * frequency.size * len(whole)
    written = sum(item.frequency.size for item in sets)
    counts = {
        "total": total,
        "left_out": total - written - alone,
        "alone": alone,
        "skipped": skipped,
    }
    return kind, sets, counts


def _check_ascii_abscissa(item: _Set) -> None:
    """ASCII 58 writes frequencies to 6 digits: they must stay increasing."""
    rounded = np.array([float(ASCII_ABSCISSA % f) for f in item.frequency])
    close = np.flatnonzero(np.diff(rounded) <= 0)
    if close.size:
        f = item.frequency[close[0] : close[0] + 2]
        raise HertzsweepError(
            f"UFF export: {f[0]:.9g} and {f[1]:.9g} Hz ({item.direction}, sigma "
            f"{item.sigma:g}) are one frequency to the 6 digits ASCII 58 keeps: write 58b"
        )


def _text(text: str, width: int = ID_WIDTH) -> str:
    """A text of a UFF record: printable ASCII on one line, at most ``width`` characters
    (the records are fixed-width columns)."""
    ascii_text = text.encode("ascii", "replace").decode("ascii")
    flat = " ".join(ascii_text.split())
    return flat[:width] or "NONE"


def _header(title: str) -> dict[str, Any]:
    """Dataset 151: what made the file (pyuff fills in the dates)."""
    import pyuff

    program = _text(f"hertzsweep {__version__}")
    return pyuff.prepare_151(
        model_name=title,
        description="harmonics of the transmitted force over the excitation force",
        db_app=program,
        program=program,
    )


def _si_units() -> dict[str, Any]:
    """Dataset 164: SI units."""
    import pyuff

    return pyuff.prepare_164(**SI_UNITS)


def _dataset_58(item: _Set, kind: str, title: str, written: str, binary: bool) -> dict:
    """Dataset 58 of one function (module notes)."""
    import pyuff

    k = item.harmonic
    what = f"{OUR_MARK} {'fit model' if kind == 'fit' else kind}"
    dset = pyuff.prepare_58(
        binary=1 if binary else 0,
        id1=_text(f"{what}: N{k}/F1 = A_{k} exp(-i phi_{k})/sigma, e^(+i w t)"),
        id2=_text(
            f"{LEVEL_LABEL}={item.sigma!r} {LEVEL_UNITS}; harmonic {k}; {item.direction} sweep; "
            "A_k peak, phi_k lag deg"
        ),
        id3=title,
        id4=_text(f"written {written}"),
        id5=_text(f"hertzsweep {__version__}"),
        func_type=H1_FUNCTION if k == 1 else ORDER_FUNCTION,
        ver_num=DIRECTION_CODES[item.direction],
        load_case_id=0,
        rsp_ent_name=_text("contact", ENTITY_WIDTH),
        rsp_node=RESPONSE_NODE,
        rsp_dir=PLUS_Z,
        ref_ent_name=_text("excitation", ENTITY_WIDTH),
        ref_node=REFERENCE_NODE,
        ref_dir=PLUS_Z,
        abscissa_spacing=0,
        z_axis_value=float(item.sigma),
        abscissa_spec_data_type=FREQUENCY,
        abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=REACTION_FORCE,
        ordinate_axis_units_lab="N",
        orddenom_spec_data_type=EXCITATION_FORCE,
        orddenom_axis_units_lab="N",
        z_axis_spec_data_type=GENERAL,
        z_axis_len_unit_exp=0,
        z_axis_force_unit_exp=0,
        z_axis_temp_unit_exp=0,
        z_axis_axis_units_lab=LEVEL_UNITS,
        data=np.asarray(item.ratio, dtype=complex),
        x=np.asarray(item.frequency, dtype=float),
    )
    dset.update(  # fields prepare_58 does not take, which pyuff's writer does
        func_id=k,
        abscissa_axis_lab="frequency",
        ordinate_axis_lab=_text(f"N{k}", LABEL_WIDTH),
        orddenom_axis_lab="F1",
        z_axis_axis_lab=LEVEL_LABEL,
    )
    return dset


def _write(tmp: os.PathLike, dsets: list[dict]) -> None:
    """pyuff writes the sets to ``tmp``; its failures (which it re-raises as bare
    ``Exception``) become an ``OSError`` that :func:`atomic_path` names the output by.

    The header 151 goes first, in pyuff's "overwrite" mode: a binary 58 written first in
    that mode would be truncated (pyuff 2.5 reopens the file for the binary part)."""
    import pyuff

    try:
        pyuff.UFF(os.fspath(tmp)).write_sets(dsets, mode="overwrite")
    except OSError:
        raise
    except Exception as exc:  # pyuff raises bare Exception for every failure
        raise OSError(f"pyuff could not write the universal file ({_one_line(exc)})") from None


def _one_line(exc: BaseException) -> str:
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


# --------------------------------------------------------------------------- import
def read_uff(path: str | os.PathLike, options: ImportOptions) -> SweepMeasurements:
    """The measurements of a UFF 58 or 58b file (module notes).

    Parameters
    ----------
    path : path
        The file.
    options : ImportOptions
        The level (``sigma`` or ``force_amplitude`` with ``static_load``) where the file
        holds none, the direction of a set of another program's file, the moving mass of
        an accelerance, mobility or receptance.

    Returns
    -------
    SweepMeasurements
        Frequencies in Hz, the peak A_k of N/F_s and phi_k [degree] in [0, 360).

    Raises
    ------
    MeasurementError
        One line naming the file, the dataset and the key: a file pyuff cannot parse, a
        set of another ``func_type``, no level, frequencies not monotonic, a motion
        without the moving mass, non-finite data, units not SI that cannot be converted.
    """
    import pyuff

    source = os.fspath(path)
    options = options.resolved(source)
    _check_file(source)
    try:
        uff = pyuff.UFF(source)
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exception for every failure
        raise MeasurementError(
            source, 0, "", f"not a universal file pyuff can read ({_one_line(exc)})"
        ) from None
    if not types:
        raise MeasurementError(
            source, 0, "dataset 1: type", "not a universal file: no set between '    -1' lines"
        )
    rows: list[tuple[str, float, np.ndarray, int, np.ndarray]] = []
    seen: dict[tuple[str, float, int], tuple[int, set[float]]] = {}
    units = (1.0, 1.0)  # length and force factors of the sets that follow (SI)
    for index, set_type in enumerate(types, start=1):
        if set_type == 0:
            raise MeasurementError(
                source, 0, f"dataset {index}: type", "not a universal file set (no set number)"
            )
        if set_type not in (58, 164):
            continue
        try:
            dset = uff.read_sets(index - 1)
        except Exception as exc:  # pyuff raises bare Exception for every failure
            raise MeasurementError(
                source, 0, f"dataset {index}: records", f"pyuff cannot read it ({_one_line(exc)})"
            ) from None
        if set_type == 164:
            units = _units(source, index, dset)
            continue
        row = _function(source, index, dset, options, units)
        _check_repeats(source, index, row, seen)
        rows.append(row)
    if not rows:
        raise MeasurementError(source, 0, "", "no dataset 58 (function of frequency) to read")
    direction = np.concatenate([np.full(r[2].size, r[0]) for r in rows])
    sigma = np.concatenate([np.full(r[2].size, r[1]) for r in rows])
    frequency = np.concatenate([r[2] for r in rows])
    harmonic = np.concatenate([np.full(r[2].size, r[3], dtype=np.int64) for r in rows])
    ratio = np.concatenate([r[4] for r in rows])
    amplitude = np.abs(ratio) * sigma
    phase = np.degrees(-np.angle(ratio)) % 360.0
    phase = np.where(phase >= 360.0, 0.0, phase)  # -0.0 % 360 can round to 360
    return SweepMeasurements(
        direction=direction,
        sigma=sigma,
        frequency=frequency,
        harmonic=harmonic,
        amplitude=amplitude,
        phase=phase,
        in_hertz=True,
        source=source,
    )


def _check_file(source: str) -> None:
    """A regular file of a sane size (never a FIFO or a device pyuff would hang on)."""
    try:
        info = os.stat(source)
    except OSError as exc:
        raise MeasurementError(source, 0, "", exc.strerror or "cannot read it") from None
    if not stat.S_ISREG(info.st_mode):
        raise MeasurementError(source, 0, "", "not a regular file")
    if info.st_size > MAX_UFF_BYTES:
        raise MeasurementError(
            source, 0, "", f"{info.st_size} bytes: larger than {MAX_UFF_BYTES} for a UFF file"
        )


def _units(source: str, index: int, dset: dict) -> tuple[float, float]:
    """The length and force factors of a dataset 164 (file units = SI x factor)."""
    factors = []
    for key in ("length", "force"):
        value = dset.get(key)
        if not isinstance(value, float) or not math.isfinite(value) or value <= 0:
            raise MeasurementError(
                source, 0, f"dataset {index}: {key}", f"expected a positive factor, got {value!r}"
            )
        factors.append(value)
    return factors[0], factors[1]


def _function(
    source: str,
    index: int,
    dset: dict,
    options: ImportOptions,
    units: tuple[float, float],
) -> tuple[str, float, np.ndarray, int, np.ndarray]:
    """One dataset 58: (direction, sigma, frequency [Hz], harmonic, N_k/F_1)."""

    def error(key: str, reason: str) -> MeasurementError:
        return MeasurementError(source, 0, f"dataset {index}: {key}", reason)

    ours = str(dset.get("id1", "")).startswith(OUR_MARK)
    harmonic = _harmonic(dset, error)
    frequency = np.asarray(dset.get("x"), dtype=float)
    data = np.asarray(dset.get("data"), dtype=complex)
    if frequency.size == 0 or data.size != frequency.size:
        raise error("num_pts", f"{frequency.size} frequencies for {data.size} values")
    if not np.all(np.isfinite(frequency)) or np.any(frequency <= 0):
        bad = frequency[~(np.isfinite(frequency) & (frequency > 0))][0]
        raise error("x", f"expected positive frequencies [Hz], got {bad!r}")
    if not np.all(np.isfinite(data)):
        point = int(np.flatnonzero(~np.isfinite(data))[0])
        raise error("data", f"not a number at point {point + 1} ({frequency[point]:g} Hz)")
    order = _order(frequency, error)
    sigma = _level(source, dset, options, ours, error)
    direction = _direction(dset, options, ours, order, error)
    ratio = _ratio(dset, options, units, harmonic, frequency, data, error)
    return direction, sigma, frequency, harmonic, ratio


def _harmonic(dset: dict, error) -> int:
    func_type = dset.get("func_type")
    if func_type == H1_FUNCTION:
        return 1
    if func_type == ORDER_FUNCTION:
        k = dset.get("func_id")
        if not isinstance(k, int) or k < 2:
            raise error("func_id", f"a func_type 0 set holds harmonic k >= 2 in func_id, got {k!r}")
        return k
    raise error(
        "func_type",
        f"expected 4 (harmonic 1, an FRF) or 0 (harmonic func_id), got {func_type!r}",
    )


def _order(frequency: np.ndarray, error) -> str:
    """``"up"`` (increasing) or ``"down"`` (decreasing); anything else is refused."""
    step = np.diff(frequency)
    if np.all(step > 0):
        return "up"
    if np.all(step < 0):
        return "down"
    bad = int(np.flatnonzero(step <= 0)[0] if step[0] > 0 else np.flatnonzero(step >= 0)[0])
    raise error(
        "x",
        f"frequencies not increasing: {frequency[bad + 1]:.9g} Hz after "
        f"{frequency[bad]:.9g} Hz (point {bad + 2})",
    )


def _level(source: str, dset: dict, options: ImportOptions, ours: bool, error) -> float:
    """sigma of the set: its z axis when labelled so, else the options'."""
    if str(dset.get("z_axis_axis_lab", "")).strip().lower() == LEVEL_LABEL:
        z = dset.get("z_axis_value")
        if not isinstance(z, float) or not math.isfinite(z) or z <= 0:
            raise error("z_axis_value", f"expected a positive level sigma, got {z!r}")
        found = re.search(rf"\b{LEVEL_LABEL}=(\S+)", str(dset.get("id2", "")))
        if ours and found:
            try:
                precise = float(found.group(1))
            except ValueError:
                precise = math.nan
            if abs(precise - z) <= LEVEL_AGREEMENT * z:
                return precise
        return z
    level = options.level(source)
    if level is None:
        raise error("z_axis_value", "no level: give --sigma or --force-amplitude")
    return level


def _direction(dset: dict, options: ImportOptions, ours: bool, order: str, error) -> str:
    names = {code: name for name, code in DIRECTION_CODES.items()}
    ver_num = dset.get("ver_num")
    if ours:
        if ver_num not in names:
            raise error("ver_num", f"expected 1 (up) or 2 (down), got {ver_num!r}")
        return names[ver_num]
    if options.direction is not None:
        return options.direction
    return names.get(ver_num, order)


def _ratio(
    dset: dict,
    options: ImportOptions,
    units: tuple[float, float],
    harmonic: int,
    frequency: np.ndarray,
    data: np.ndarray,
    error,
) -> np.ndarray:
    """N_k / F_1 from the set's ordinate (module notes)."""
    denominator = dset.get("orddenom_spec_data_type", 0)
    if denominator not in DENOMINATORS:
        raise error(
            "orddenom_spec_data_type",
            f"expected the excitation force (13, or 9), got {denominator!r}",
        )
    ordinate = dset.get("ordinate_spec_data_type")
    if ordinate in FORCES:
        return data
    if ordinate not in MOTIONS:
        raise error(
            "ordinate_spec_data_type",
            f"expected a force (9, 13), an acceleration (12), velocity (11) or displacement "
            f"(8), got {ordinate!r}",
        )
    label = str(dset.get("ordinate_axis_units_lab", "")).strip().lower().replace(" ", "")
    if ordinate == ACCELERATION and label in GRAVITY_UNIT_LABELS:
        raise error(
            "ordinate_axis_units_lab",
            f"an accelerance in {label!r}: write it in m/s^2 per N (not converted here)",
        )
    if options.moving_mass is None:
        raise error(
            "ordinate_spec_data_type",
            f"{MOTIONS[ordinate]} ({ordinate}) needs the moving mass: give --moving-mass or --rig",
        )
    length, force = units
    motion = data * (force / length)  # to SI per newton: a number in the file's units is
    # the SI number times the factor (1 m = 1000 mm), so times the force's over the length's
    w = 2.0 * np.pi * frequency * harmonic  # [rad/s] of the k-th harmonic
    # Signs, checked in exp(+i W t): z' = i W z and z'' = i W z' = -W^2 z; the k-th harmonic
    # of m z'' = F_s + F - N is m z''_k = delta_k1 F_1 - N_k, so N_k/F_1 = delta_k1 - m A with
    # A = i W V = -W^2 X: 1 - m A, 1 - i W m V, 1 + m W^2 X (exp(-i W t) flips i W V only)
    accelerance = {
        ACCELERATION: motion,
        VELOCITY: 1j * w * motion,
        DISPLACEMENT: -(w**2) * motion,
    }[ordinate]
    return (1.0 if harmonic == 1 else 0.0) - options.moving_mass * accelerance


def _check_repeats(
    source: str,
    index: int,
    row: tuple[str, float, np.ndarray, int, np.ndarray],
    seen: dict[tuple[str, float, int], tuple[int, set[float]]],
) -> None:
    """Two sets may share a (direction, sigma, harmonic) but not a frequency."""
    direction, sigma, frequency, harmonic, _ = row
    key = (direction, sigma, harmonic)
    if key not in seen:
        seen[key] = (index, set(frequency.tolist()))
        return
    first, frequencies = seen[key]
    repeated = [f for f in frequency.tolist() if f in frequencies]
    if repeated:
        raise MeasurementError(
            source,
            0,
            f"dataset {index}: x",
            f"repeats dataset {first} at {repeated[0]:.9g} Hz ({direction}, sigma {sigma:g}, "
            f"harmonic {harmonic}): one response per file",
        )
    frequencies.update(frequency.tolist())


__all__ = ["ExportReport", "export_uff", "read_uff"]
