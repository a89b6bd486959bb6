"""Lock-in tables in (CSV with ``,`` or ``;``, JSON rows or columns; volts RMS, a
sensitivity, the instrument's phase sign, presets) and measurement tables out (hertzsweep's
own CSV, a lock-in's CSV): round trips to round-off, the paper's f0 and zeta fitted from a
LabOne-style file, and bad files that end in one line naming file, line and column."""

import json
import math

import numpy as np
import pytest

import hertzsweep as hs
from hertzsweep.errors import HertzsweepError, MeasurementError
from hertzsweep.io import lockin_table
from hertzsweep.io.import_options import ImportOptions
from hertzsweep.io.lockin_table import (
    LOCKIN_HEADER,
    read_lockin_table,
    write_lockin_csv,
    write_measurement_csv,
)
from hertzsweep.io.measured import measured_dataset, read_measurements

from .conftest import CONFIGS

SENSITIVITY = 0.0224  # [V/N] a force transducer's, as the example
STATIC_LOAD = 110.0  # [N] F_s of the paper's rig (configs/rig.toml)
ROUND_OFF = 1e-12  # relative: what a round trip through text and x + i y may lose
F0, ZETA = 233.4, 0.0045  # [Hz], [1]: the paper's linearised rig (section 4.1)
LOW_LEVEL = 0.0003  # [1] sigma = 0.03 %: the paper's linear sweep
SWEEP = {  # two levels, up and down, H1 and H2 (smoke.toml), five frequencies
    "excitation.sigma": [0.006, 0.01],
    "sweep.start": 0.97,
    "sweep.stop": 0.99,
    "sweep.step": 0.005,
    "sweep.settle_periods": 600,  # every dwell settles (200 leaves them all unsettled)
}


@pytest.fixture(scope="module")
def sweep():
    return hs.sweep(hs.load_scene(CONFIGS / "smoke.toml", overrides=SWEEP))


def lag_difference(a, b):
    """a - b [degree] wrapped to [-180, 180)."""
    return (np.asarray(a) - np.asarray(b) + 180.0) % 360.0 - 180.0


def dataset_values(ds, readings):
    """The sweep's amplitude and phase at every reading (direction, sigma, frequency, k)."""
    amplitude, phase = [], []
    for d, s, f, k in zip(
        readings.direction, readings.sigma, readings.frequency, readings.harmonic, strict=True
    ):
        (i,) = np.flatnonzero(ds.frequency.values == f)
        at = ds.isel(frequency_ratio=i).sel(direction=d, sigma=s, harmonic=k)
        amplitude.append(float(at.amplitude))
        phase.append(float(at.phase))
    return np.array(amplitude), np.array(phase)


# --------------------------------------------------------------------------- round trips
def test_a_sweep_through_the_lockin_csv_and_back_to_round_off(sweep, tmp_path):
    path = tmp_path / "lockin.csv"
    report = write_lockin_csv(sweep, path, SENSITIVITY)
    assert report.written == report.total == 40  # 2 directions x 2 levels x 5 x 2 harmonics
    assert report.line() == "wrote all 40 points"
    assert path.read_text().splitlines()[1] == ",".join(LOCKIN_HEADER)
    options = ImportOptions(
        columns={name: name for name in LOCKIN_HEADER},
        sensitivity=SENSITIVITY,
        static_load=STATIC_LOAD,
    )
    back = read_lockin_table(path, options)
    assert back.amplitude.size == 40
    assert set(back.direction) == {"up", "down"} and set(back.harmonic) == {1, 2}
    amplitude, phase = dataset_values(sweep, back)
    error_amplitude = np.max(np.abs(back.amplitude / amplitude - 1.0))
    error_phase = np.max(np.abs(lag_difference(back.phase, phase) / phase))
    assert error_amplitude < ROUND_OFF  # measured 2.2e-16
    assert error_phase < ROUND_OFF  # measured 4e-15 (phases 7.9 to 353 degrees)
    down = (back.direction == "down") & (back.harmonic == 1) & (back.sigma == 0.01)
    assert np.all(np.diff(back.frequency[down]) < 0)  # in the order the down sweep went


def test_a_sweep_through_the_own_csv_and_back_exactly(sweep, tmp_path):
    path = tmp_path / "own.csv"
    report = write_measurement_csv(sweep, path)
    assert report.written == 40
    back = read_measurements(path)
    amplitude, phase = dataset_values(sweep, back)
    np.testing.assert_array_equal(back.amplitude, amplitude)
    np.testing.assert_array_equal(back.phase, phase)
    assert back.in_hertz and set(back.sigma) == {0.006, 0.01}
    again = tmp_path / "again.csv"  # measured dataset -> CSV -> the same readings
    write_measurement_csv(measured_dataset(back), again)
    twice = read_measurements(again)
    for name in ("sigma", "frequency", "harmonic", "amplitude", "phase"):
        key = np.lexsort((twice.harmonic, twice.frequency, twice.sigma, twice.direction))
        first = np.lexsort((back.harmonic, back.frequency, back.sigma, back.direction))
        np.testing.assert_array_equal(getattr(twice, name)[key], getattr(back, name)[first])


def test_points_not_settled_or_not_measured_are_left_out_and_counted(sweep, tmp_path):
    ds = sweep.copy(deep=True)
    ds["settled"][0, 0, 1] = 0  # up, sigma 0.006, the second frequency: both harmonics
    ds["amplitude"][1, 1, 2, 1] = np.nan  # down, sigma 0.01, the third frequency, H2
    path = tmp_path / "own.csv"
    report = write_measurement_csv(ds, path)
    assert (report.written, report.total, report.left_out) == (37, 40, 3)
    assert report.line() == "left out 3 of 40 points (not settled or not measured)"
    assert read_measurements(path).amplitude.size == 37
    lockin = write_lockin_csv(ds, tmp_path / "lockin.csv", SENSITIVITY)
    assert lockin.written == 37


def test_a_dataset_without_static_load_writes_nothing(sweep, tmp_path):
    ds = sweep.copy()
    del ds.attrs["static_load"]
    path = tmp_path / "lockin.csv"
    with pytest.raises(HertzsweepError, match="static_load"):
        write_lockin_csv(ds, path, SENSITIVITY)
    assert not path.exists() and list(tmp_path.iterdir()) == []
    report = write_lockin_csv(ds, path, SENSITIVITY, static_load=STATIC_LOAD)
    assert report.written == 40


# --------------------------------------------------------------------------- presets
KNOWN_FREQUENCY = np.array([220.0, 228.5, 233.0, 240.0])  # [Hz]
KNOWN_AMPLITUDE = np.array([0.011, 0.034, 0.052, 0.017])  # peak A_1 of N/F_s
KNOWN_PHASE = np.array([3.5, 41.0, 95.0, 178.5])  # phi_1 [degree], SPEC convention


def known_volts():
    """The known readings as a lock-in gives them: x + i y [V RMS], R, theta = -phi."""
    volts = KNOWN_AMPLITUDE * STATIC_LOAD * SENSITIVITY / math.sqrt(2.0)
    return volts * np.exp(-1j * np.radians(KNOWN_PHASE))


def assert_known(readings):
    assert np.max(np.abs(readings.amplitude / KNOWN_AMPLITUDE - 1.0)) < ROUND_OFF
    assert np.max(np.abs(lag_difference(readings.phase, KNOWN_PHASE) / KNOWN_PHASE)) < ROUND_OFF
    np.testing.assert_array_equal(readings.frequency, KNOWN_FREQUENCY)
    assert list(readings.direction) == ["up"] * 4 and list(readings.harmonic) == [1] * 4
    np.testing.assert_array_equal(readings.sigma, [0.006] * 4)


def test_a_labone_sweeper_csv_with_its_preset(tmp_path):
    v = known_volts()
    lines = ["grid;bandwidth;frequency;phase;r;x;y"]  # LabOne: ';', phase in radians
    for f, z in zip(KNOWN_FREQUENCY, v, strict=True):
        cells = (f, 10.0, f, np.angle(z), abs(z), z.real, z.imag)
        lines.append(";".join(repr(float(c)) for c in cells))
    path = tmp_path / "labone.csv"
    path.write_text("\n".join(lines) + "\n")
    common = {"sensitivity": SENSITIVITY, "static_load": STATIC_LOAD, "sigma": 0.006}
    assert_known(read_lockin_table(path, ImportOptions(preset="labone-sweeper", **common)))
    polar = ImportOptions(preset="labone-sweeper", columns={"r": "r", "phase": "phase"}, **common)
    assert_known(read_lockin_table(path, polar))  # its r and phase (rad) instead of x, y


def test_an_sr830_csv_with_its_preset_and_a_force_amplitude(tmp_path):
    v = known_volts()
    lines = ["# SR830, saved by hand", "freq,X,Y,R,theta"]  # ',', theta in degrees
    for f, z in zip(KNOWN_FREQUENCY, v, strict=True):
        cells = (f, z.real, z.imag, abs(z), np.degrees(np.angle(z)))
        lines.append(",".join(repr(float(c)) for c in cells))
    path = tmp_path / "sr830.csv"
    path.write_text("\n".join(lines) + "\n")
    common = {"sensitivity": SENSITIVITY, "static_load": STATIC_LOAD}
    level = {"force_amplitude": 0.006 * STATIC_LOAD}  # [N] sigma 0.006 as a force
    assert_known(read_lockin_table(path, ImportOptions(preset="sr8xx", **common, **level)))
    polar = ImportOptions(
        preset="sr8xx", columns={"r": "R", "phase": "theta"}, **common, sigma=0.006
    )
    assert_known(read_lockin_table(path, polar))


def test_json_rows_and_json_columns(tmp_path):
    v = known_volts() * math.sqrt(2.0) / SENSITIVITY / STATIC_LOAD  # peak N/F_s, no volts
    rows = [
        {"f": float(f), "re": float(z.real), "im": float(z.imag), "level": "0.006"}
        for f, z in zip(KNOWN_FREQUENCY, v, strict=True)
    ]
    columns = {"frequency": "f", "x": "re", "y": "im", "sigma": "level"}
    options = ImportOptions(columns=columns, rms=False)
    for name, data in (
        ("rows.json", rows),
        ("columns.json", {key: [row[key] for row in rows] for key in rows[0]}),
    ):
        path = tmp_path / name
        path.write_text(json.dumps(data))
        assert_known(read_lockin_table(path, options))


def test_a_down_sweep_is_told_by_its_order(tmp_path):
    path = tmp_path / "down.csv"
    path.write_text("freq,X,Y\n240,1e-3,-2e-3\n235,2e-3,-1e-3\n230,1e-3,1e-4\n")
    readings = read_lockin_table(path, ImportOptions(preset="sr8xx", sigma=0.01))
    assert list(readings.direction) == ["down"] * 3
    assert readings.amplitude[0] == pytest.approx(math.sqrt(2.0) * math.hypot(1e-3, 2e-3))
    assert readings.phase[0] == pytest.approx(math.degrees(math.atan2(2e-3, 1e-3)))


# --------------------------------------------------------------------------- the fit
def test_a_labone_file_of_the_linear_rig_fits_f0_and_zeta(tmp_path):
    rng = np.random.default_rng(31)
    w = np.sort(rng.uniform(0.9, 1.1, 40))  # a non-uniform grid of 40 frequencies
    transmissibility = (1 + 2j * ZETA * w) / (1 - w**2 + 2j * ZETA * w)  # N1/F1, eq. (8)
    newtons = LOW_LEVEL * STATIC_LOAD * transmissibility  # N1 [N], peak
    volts = newtons * SENSITIVITY / math.sqrt(2.0)  # [V RMS]; theta = -phi: its angle
    lines = ["grid;bandwidth;frequency;phase;r;x;y"]
    for f, z in zip(w * F0, volts, strict=True):
        cells = (f, 10.0, f, np.angle(z), abs(z), z.real, z.imag)
        lines.append(";".join(repr(float(c)) for c in cells))
    path = tmp_path / "labone-linear.csv"
    path.write_text("\n".join(lines) + "\n")
    options = ImportOptions(
        preset="labone-sweeper", sensitivity=SENSITIVITY, static_load=STATIC_LOAD, sigma=LOW_LEVEL
    )
    readings = read_lockin_table(path, options)
    assert list(readings.direction) == ["up"] * 40
    scene = hs.load_scene(CONFIGS / "measured" / "paper-scene.toml")
    fit = hs.fit(measured_dataset(readings), scene, ["rig.natural_frequency", "damping.ratio"])
    f0 = float(fit.estimate.sel(parameter="rig.natural_frequency"))
    zeta = float(fit.estimate.sel(parameter="damping.ratio"))
    assert abs(f0 / F0 - 1.0) < 1e-3  # measured 6e-16
    assert abs(zeta / ZETA - 1.0) < 0.05  # measured 5e-14 (from 0.01, the start of the scene)
    own = tmp_path / "fit.csv"  # the fit's data as hertzsweep's CSV, exactly
    assert write_measurement_csv(fit, own).written == 40
    back = read_measurements(own)
    np.testing.assert_array_equal(np.sort(back.amplitude), np.sort(readings.amplitude))


# --------------------------------------------------------------------------- bad files
SR = "freq,X,Y\n230,1e-3,2e-3\n231,2e-3,1e-3\n"  # a good SR830-style file


def one_line_error(tmp_path, text, options, name="data.csv"):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(MeasurementError) as caught:
        read_lockin_table(path, options)
    exc = caught.value
    assert "\n" not in str(exc) and str(exc).startswith(f"{path}: ")
    return exc


BAD = {  # name -> (text, options, line, column, part of the reason)
    "an unknown column in the map": (
        SR,
        ImportOptions(columns={"frequency": "freq", "x": "X", "y": "Y", "amp": "A"}, sigma=0.01),
        0,
        "--columns",
        "unknown quantity 'amp'",
    ),
    "a mapped column not in the file": (
        "# SR830\n" + SR,
        ImportOptions(columns={"frequency": "freq", "x": "X", "y": "Yq"}, sigma=0.01),
        2,
        "Yq",
        "missing column (the y of --columns)",
    ),
    "a negative sensitivity": (
        SR,
        ImportOptions(preset="sr8xx", sensitivity=-0.0224, static_load=110.0, sigma=0.01),
        0,
        "--sensitivity",
        "must be a positive number",
    ),
    "frequencies not monotonic within one sweep": (
        SR + "230.5,1e-3,1e-3\n",
        ImportOptions(preset="sr8xx", sigma=0.01),
        4,
        "freq",
        "frequencies not increasing within one sweep",
    ),
    "a down sweep that rises": (
        "direction,freq,X,Y\ndown,230,1e-3,2e-3\ndown,231,2e-3,1e-3\n",
        ImportOptions(preset="sr8xx", columns={"direction": "direction"}, sigma=0.01),
        3,
        "freq",
        "frequencies not decreasing within one sweep",
    ),
    "a cell that is not a number": (
        "freq;X;Y\n230;1e-3;2e-3\n231;two;1e-3\n",
        ImportOptions(preset="sr8xx", sigma=0.01),
        3,
        "X",
        "not a number: 'two'",
    ),
    "a cell that is not finite": (
        SR + "232,nan,1e-3\n",
        ImportOptions(preset="sr8xx", sigma=0.01),
        4,
        "X",
        "expected a finite number",
    ),
    "a sensitivity without the static load": (
        SR,
        ImportOptions(preset="sr8xx", sensitivity=0.0224, sigma=0.01),
        0,
        "--static-load",
        "needed with --sensitivity",
    ),
    "no level": (
        SR,
        ImportOptions(preset="sr8xx"),
        0,
        "--sigma",
        "no level: give --sigma or --force-amplitude",
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_a_bad_file_is_one_line_naming_file_line_and_column(tmp_path, case):
    text, options, line, column, reason = BAD[case]
    exc = one_line_error(tmp_path, text, options)
    assert (exc.line, exc.column) == (line, column)
    assert reason in exc.reason


@pytest.mark.parametrize(
    ("text", "column"),
    [("[1, 2]", "row 1"), ('{"freq": [230, 231], "X": [1e-3]}', "X"), ('{"freq": 230}', "freq")],
)
def test_json_that_is_not_a_list_of_objects(tmp_path, text, column):
    options = ImportOptions(preset="sr8xx", sigma=0.01)
    exc = one_line_error(tmp_path, text, options, name="data.json")
    assert (exc.line, exc.column) == (0, column)


def test_a_json_row_names_its_row(tmp_path):
    rows = [{"freq": 230, "X": 1e-3, "Y": 2e-3}, {"freq": 231, "X": None, "Y": 1e-3}]
    options = ImportOptions(preset="sr8xx", sigma=0.01)
    exc = one_line_error(tmp_path, json.dumps(rows), options, name="data.json")
    assert (exc.line, exc.column) == (0, "row 2: X")


def test_a_file_too_large_is_refused_before_it_is_read(tmp_path, monkeypatch):
    monkeypatch.setattr(lockin_table, "MAX_MEASUREMENT_BYTES", 16)
    exc = one_line_error(tmp_path, SR, ImportOptions(preset="sr8xx", sigma=0.01))
    assert exc.line == 0 and "16" in exc.reason
