"""``hertzsweep export`` and ``hertzsweep import`` on the command line: a sweep goes out
as UFF 58b, UFF 58 and lock-in CSV and comes back with the same amplitudes and phases; a
LabOne-sweeper table is imported with its preset and fitted."""

from __future__ import annotations

import json

import numpy as np
import pytest

import hertzsweep as hs

from .conftest import CONFIGS, run_cli

SETTLED = {  # up and down, two levels, harmonics 1 and 2; every dwell settles (400 periods
    # are 11 decay times at zeta = 0.45 %)
    "sweep.start": 0.97,
    "sweep.stop": 0.99,
    "sweep.step": 0.005,
    "sweep.settle_periods": 400,
    "sweep.measure_periods": 4,
}
ROUND_TRIP = {  # format -> (relative tolerance of amplitudes, absolute of phases [degree])
    "uff58b": (1e-12, 1e-10),  # binary doubles: exact but for the complex form's rounding
    "uff58": (1e-11, 1e-9),  # ASCII 58 writes 12 significant digits (frequencies 6)
    "lockin-csv": (1e-12, 1e-10),  # repr digits; volts RMS and back
}


@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sweep")
    ds = hs.sweep(hs.load_scene(CONFIGS / "smoke.toml", overrides=SETTLED))
    assert int(ds.settled.sum()) == ds.settled.size  # nothing left out of the round trip
    return hs.save(ds, folder / "sweep.nc"), ds


@pytest.mark.parametrize("fmt", list(ROUND_TRIP))
def test_export_then_import_gives_the_sweep_back(tmp_path, capsys, sweep_file, fmt):
    path, ds = sweep_file
    out = tmp_path / ("out.csv" if fmt == "lockin-csv" else "out.uff")
    extra = ["--sensitivity", "0.0224"] if fmt == "lockin-csv" else []
    code, printed, err = run_cli(["export", path, "-o", out, "--format", fmt, *extra], capsys)
    assert code == 0, err
    assert printed.endswith(f"wrote {out}\n")
    measured = tmp_path / "m.nc"
    extra = ["--sensitivity", "0.0224", "--static-load", "110"] if fmt == "lockin-csv" else []
    code, _, err = run_cli(["import", out, "-o", measured, *extra], capsys)
    assert code == 0, err
    m = hs.open_dataset(measured)
    rtol, atol = ROUND_TRIP[fmt]
    for direction in ("up", "down"):
        for sigma in ds.sigma.values:
            for k in (1, 2):
                a = ds.sel(direction=direction, sigma=sigma, harmonic=k)
                b = m.sel(direction=direction, sigma=sigma, harmonic=k)
                b = b.sel(frequency=a.frequency.values, method="nearest", tolerance=1e-3)
                np.testing.assert_allclose(b.amplitude, a.amplitude, rtol=rtol)
                wrapped = (b.phase.values - a.phase.values + 180) % 360 - 180
                np.testing.assert_allclose(wrapped, 0, atol=atol)


def test_a_labone_sweeper_table_fits_f0_and_zeta(tmp_path, capsys):
    # a LabOne sweeper's CSV (x, y in volts RMS of a 0.0224 V/N transducer; phase: the lead)
    # of the linear force transmissibility at sigma = 0.03 %, f0 = 233.4 Hz, zeta = 0.0045
    f0, zeta, sigma, static_load, sensitivity = 233.4, 0.0045, 0.0003, 110.0, 0.0224
    rng = np.random.default_rng(7)
    f = np.sort(rng.uniform(0.9, 1.1, 40)) * f0  # a non-uniform grid
    w = f / f0
    h = (1 + 2j * zeta * w) / (1 - w * w + 2j * zeta * w)  # N1/F1 of eq. (8), linearised
    n1 = h * sigma * static_load  # [N] peak, in e^{+i w t}: A e^{-i phi}
    volts = n1 / np.sqrt(2) * sensitivity  # RMS; X + iY = R e^{i theta}, theta = -phi
    lines = ["grid;x;y;r;phase;frequency;bandwidth"]
    for i, (fi, v) in enumerate(zip(f, volts, strict=True)):
        lines.append(
            f"{i};{float(v.real)!r};{float(v.imag)!r};{float(abs(v))!r};{float(np.angle(v))!r};{float(fi)!r};10.0"
        )
    table = tmp_path / "sweep.csv"
    table.write_text("\n".join(lines) + "\n")
    measured = tmp_path / "m.nc"
    argv = ["import", table, "-o", measured, "--preset", "labone-sweeper", "--sigma", "0.0003"]
    argv += ["--sensitivity", "0.0224", "--static-load", "110"]
    code, _, err = run_cli(argv, capsys)
    assert code == 0, err
    assert_fits(measured, f0, zeta, tmp_path, capsys)


def assert_fits(measured, f0, zeta, tmp_path, capsys) -> None:
    """``hertzsweep fit --free rig.natural_frequency,damping.ratio`` of a measured file
    recovers f0 within 0.1 % and zeta within 5 % (the issue's tolerances)."""
    argv = ["fit", measured, "--scene", CONFIGS / "measured" / "paper-scene.toml", "--free"]
    argv += ["rig.natural_frequency,damping.ratio", "-o", tmp_path / "fit.nc", "--json", "-q"]
    code, printed, err = run_cli(argv, capsys)
    assert code == 0, err
    estimates = json.loads(printed)["parameters"]
    assert estimates["rig.natural_frequency"]["estimate"] == pytest.approx(f0, rel=1e-3)
    assert estimates["damping.ratio"]["estimate"] == pytest.approx(zeta, rel=0.05)


def test_export_leaves_out_what_was_not_settled(tmp_path, capsys, sweep_file):
    _, ds = sweep_file
    ds = ds.copy(deep=True)
    ds["settled"][0, 0, 1] = 0
    ds["amplitude"][1, 1, 2, 0] = np.nan
    path = hs.save(ds, tmp_path / "s.nc")
    code, printed, err = run_cli(["export", path, "-o", tmp_path / "s.uff"], capsys)
    assert code == 0, err
    # one unsettled dwell (both harmonics) and one unmeasured H1: 3 of 40 points
    assert "left out 3 of 40 points" in printed


def test_export_writes_the_whole_orders_of_a_fractional_sweep(tmp_path, capsys):
    # UFF's func_id and the CSVs' harmonic column hold whole orders: of a sweep reading
    # H1/2, H1, H3/2, H2 the export writes H1 and H2 (the same values as a sweep of them
    # alone) and counts the points of H1/2 and H3/2 in its one line
    halves = {**SETTLED, "lockin.harmonics": [0.5, 1, 1.5, 2]}
    ds = hs.sweep(hs.load_scene(CONFIGS / "smoke.toml", overrides=halves))
    path = hs.save(ds, tmp_path / "halves.nc")
    code, printed, err = run_cli(["export", path, "-o", tmp_path / "h.uff"], capsys)
    assert code == 0, err
    assert "wrote 8 UFF 58b sets of 40 points" in printed  # 2 x 2 levels x H1, H2
    assert "orders 1/2, 3/2 not written (func_id holds whole orders)" in printed
    csv = tmp_path / "h.csv"
    code, printed, err = run_cli(["export", path, "-o", csv, "--format", "csv"], capsys)
    assert code == 0, err
    assert "left out 40 of 80 points (0 not settled or not measured, 40 of a fractional" in printed
    code, _, err = run_cli(["import", tmp_path / "h.uff", "-o", tmp_path / "m.nc"], capsys)
    assert code == 0, err
    back = hs.open_dataset(tmp_path / "m.nc")
    assert back.harmonic.values.tolist() == [1.0, 2.0] and back.harmonic.dtype == np.float64
    a = ds.sel(direction="up", harmonic=2).isel(sigma=0).amplitude.values
    b = back.sel(direction="up", harmonic=2).isel(sigma=0).amplitude.values
    np.testing.assert_allclose(b, a, rtol=1e-12)


def test_export_refuses_a_trace(tmp_path, capsys):
    trace = hs.trace(hs.load_scene(CONFIGS / "smoke.toml", overrides=SETTLED), 0.98, periods=2)
    path = hs.save(trace, tmp_path / "t.nc")
    code, _, err = run_cli(["export", path, "-o", tmp_path / "t.uff"], capsys)
    assert (
        code == 2
        and err
        == "hertzsweep: error: cannot export a trace dataset (sweep, measured and fit only)\n"
    )
    assert not (tmp_path / "t.uff").exists()


def test_a_uff_file_of_another_program_fits_f0_and_zeta(tmp_path, capsys):
    # a UFF 58b written by pyuff alone: the force/force FRF of the linear oscillator at
    # sigma = 0.03 %, f0 = 233.4 Hz, zeta = 0.0045, on a non-uniform grid, no level in it
    import pyuff

    f0, zeta = 233.4, 0.0045
    f = np.sort(np.random.default_rng(3).uniform(0.9, 1.1, 50)) * f0
    w = f / f0
    frf = (1 + 2j * zeta * w) / (1 - w * w + 2j * zeta * w)  # N1/F1 of eq. (8), linearised
    dset = pyuff.prepare_58(
        binary=1, func_type=4, rsp_node=1, rsp_dir=3, ref_node=2, ref_dir=3,
        abscissa_spacing=0, abscissa_spec_data_type=18, ordinate_spec_data_type=13,
        orddenom_spec_data_type=13, id1="shaker rig: contact force / shaker force",
        x=f, data=frf,
    )  # fmt: skip
    path = tmp_path / "rig.uff"
    pyuff.UFF(str(path)).write_sets([dset], mode="add")
    measured = tmp_path / "m.nc"
    code, _, err = run_cli(["import", path, "-o", measured, "--sigma", "0.0003"], capsys)
    assert code == 0, err
    assert_fits(measured, f0, zeta, tmp_path, capsys)
