"""``hertzsweep compare``: synthetic datasets of every kind, real sweeps, the smoke scene."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest
import xarray as xr

from hertzsweep.output.compare import TOLERANCES, compare, parse_variable_tolerance
from hertzsweep.output.dataset import attrs, open_dataset

from .conftest import CONFIGS, DATA, ROOT, run_cli

SMOKE = CONFIGS / "smoke.toml"
SMOKE_REFERENCE = DATA / "smoke-reference.nc"
GOLDEN = DATA / "golden"


# --------------------------------------------------------------------------- helpers
def sweep_ds(frequency_ratio=None, step: float = 0.01) -> xr.Dataset:
    """A small sweep-like dataset with the real names, units and attributes."""
    w = np.round(0.95 + step * np.arange(5), 12) if frequency_ratio is None else frequency_ratio
    w = np.asarray(w, dtype=float)
    full = (2, 2, w.size, 2)
    base = full[:3]
    amplitude = 0.1 + 0.01 * np.arange(np.prod(full)).reshape(full)
    phase = np.linspace(1.0, 179.0, int(np.prod(full))).reshape(full)
    data = {
        "amplitude": (full, amplitude),
        "phase": (full, phase),
        "force_max": (base, 1.5 + 0.001 * np.arange(np.prod(base)).reshape(base)),
        "force_min": (base, 0.5 - 0.001 * np.arange(np.prod(base)).reshape(base)),
        "flight_time": (base, np.zeros(base)),
        "settled": (base, np.ones(base, dtype=np.int8)),
        "jump_frequency_ratio": ((2, 2), np.array([[0.97, np.nan], [0.98, 0.96]])),
    }
    dims = ("direction", "sigma", "frequency_ratio", "harmonic")
    variables = {
        name: (dims[: len(shape)], values, attrs(name)) for name, (shape, values) in data.items()
    }
    variables["jump_frequency"] = (
        ("direction", "sigma"),
        data["jump_frequency_ratio"][1] * 230.0,
        attrs("jump_frequency"),
    )
    ds = xr.Dataset(
        variables,
        coords={
            "direction": ("direction", np.array(["up", "down"], dtype=object)),
            "sigma": ("sigma", [0.006, 0.01]),
            "frequency_ratio": ("frequency_ratio", w, attrs("frequency_ratio")),
            "frequency": ("frequency_ratio", w * 230.0, attrs("frequency")),
            "harmonic": ("harmonic", [1, 2]),
        },
        attrs={
            "hertzsweep_kind": "sweep",
            "sweep_step": step,
            "natural_frequency": 230.0,
            "damping_ratio": 0.0045,
            "damping_law": "viscous",
            "excitation_sigma": np.array([0.006, 0.01]),
            "steps_per_period": 256,
            "history": "synthetic",
        },
    )
    ds["settled"].attrs.update(flag_values=np.array([0, 1], dtype=np.int8), flag_meanings="no yes")
    return ds


def write(ds: xr.Dataset, path) -> str:
    ds.to_netcdf(path, engine="netcdf4")
    return str(path)


def run_compare(run: xr.Dataset, reference: xr.Dataset, tmp_path, capsys, *options):
    """``hertzsweep compare`` on two datasets written to files; (status, report or text,
    stderr) with the JSON report parsed when ``--json`` is among the options."""
    a = write(run, tmp_path / "run.nc")
    b = write(reference, tmp_path / "reference.nc")
    code, out, err = run_cli(["compare", a, b, *options], capsys)
    return code, (json.loads(out) if "--json" in options else out), err


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hertzsweep: error: "), err
    return lines[0]


# --------------------------------------------------------------------------- synthetic
def test_identical_datasets_are_equal(tmp_path, capsys):
    ds = sweep_ds()
    code, report, err = run_compare(ds, ds.copy(deep=True), tmp_path, capsys, "--json")
    assert code == 0 and err == ""
    assert report["equal"] is True and report["kind"] == "sweep"
    assert report["coordinate_mismatches"] == [] and report["config_differences"] == []
    assert sorted(report["variables"]) == sorted(ds.data_vars)
    for name, result in report["variables"].items():
        assert result["passed"] is True and result["failing"] == 0, name
        assert result["total"] == ds[name].size and result["worst"] is None
    code, text, _ = run_compare(ds, ds, tmp_path, capsys)
    assert text.strip().splitlines() == [
        "equal: 8 variables within tolerance (sweep; "
        f"{tmp_path / 'run.nc'} against {tmp_path / 'reference.nc'})"
    ]


def test_amplitude_failure_names_the_worst_point(tmp_path, capsys):
    ref = sweep_ds()
    run = ref.copy(deep=True)
    # two points outside rtol 1e-6: the second by far more (relative to its tolerance)
    run["amplitude"].values[0, 1, 2, 0] *= 1 + 1e-5
    run["amplitude"].values[1, 0, 4, 1] *= 1 + 1e-3
    run["amplitude"].values[1, 1, 1, 1] *= 1 + 1e-7  # inside
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 1 and report["equal"] is False
    amp = report["variables"]["amplitude"]
    assert amp["passed"] is False and amp["failing"] == 2 and amp["total"] == 40
    worst = amp["worst"]
    assert worst["coords"] == {
        "direction": "down",
        "sigma": 0.006,
        "frequency_ratio": 0.99,
        "harmonic": 2,
    }
    expected = float(ref["amplitude"].values[1, 0, 4, 1])
    assert worst["reference"] == expected
    assert worst["run"] == pytest.approx(expected * (1 + 1e-3), rel=1e-15)
    assert worst["difference"] == pytest.approx(expected * 1e-3, rel=1e-9)
    assert worst["tolerance"]["rtol"] == 1e-6 and worst["tolerance"]["atol"] == 1e-10
    assert worst["tolerance"]["allowed"] == pytest.approx(1e-10 + 1e-6 * expected, rel=1e-12)
    # every other variable is untouched
    assert [n for n, v in report["variables"].items() if not v["passed"]] == ["amplitude"]

    code, text, _ = run_compare(run, ref, tmp_path, capsys)
    line = next(s for s in text.splitlines() if s.startswith("amplitude:"))
    assert line.startswith(
        "amplitude: 2 of 40 points outside tolerance; worst at direction=down, sigma=0.006, "
        f"frequency_ratio=0.99, harmonic=2: run {expected * (1 + 1e-3):.10g}, "
        f"reference {expected:.10g} (difference "
    )
    assert line.endswith("rtol 1e-06, atol 1e-10)")
    assert text.splitlines()[-1].startswith("differ: 1 of 8 variables outside tolerance")


def test_phase_wraps_around(tmp_path, capsys):
    ref = sweep_ds()
    run = ref.copy(deep=True)
    ref["phase"].values[0, 0, 0, 0] = 0.1
    run["phase"].values[0, 0, 0, 0] = 359.9  # 0.2 degree apart across 0
    ref["phase"].values[1, 1, 3, 1] = 359.95
    run["phase"].values[1, 1, 3, 1] = 0.25  # 0.3 degree apart the other way
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 0, report["summary"]
    phase = report["variables"]["phase"]
    assert phase["passed"] is True and phase["failing"] == 0
    assert phase["tolerance"]["mode"] == "phase" and phase["tolerance"]["atol"] == 0.5
    assert phase["worst"]["coords"]["frequency_ratio"] == 0.98  # 0.3 of 0.5 allowed
    assert phase["worst"]["difference"] == pytest.approx(0.3, abs=1e-9)
    # 1.5 degree apart across 0 fails, and is reported as -1.5, not 358.5
    run["phase"].values[0, 0, 0, 0] = 358.6
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    phase = report["variables"]["phase"]
    assert code == 1 and phase["failing"] == 1
    assert phase["worst"]["difference"] == pytest.approx(-1.5, abs=1e-9)
    assert phase["worst"]["run"] == 358.6 and phase["worst"]["reference"] == 0.1
    # --atol is for the relative variables; a phase tolerance is set per variable
    assert run_compare(run, ref, tmp_path, capsys, "--atol", "10")[0] == 1
    assert run_compare(run, ref, tmp_path, capsys, "--var", "phase=0,2")[0] == 0


def test_nan_is_equal_only_where_both_are_missing(tmp_path, capsys):
    ref = sweep_ds()
    run = ref.copy(deep=True)
    for ds in (ref, run):
        ds["force_max"].values[0, 0, 1] = np.nan
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 0 and report["variables"]["force_max"]["failing"] == 0
    run["force_max"].values[1, 0, 3] = np.nan  # missing in the run only
    ref["force_min"].values[0, 1, 2] = np.nan  # missing in the reference only
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 1
    fmax, fmin = report["variables"]["force_max"], report["variables"]["force_min"]
    assert fmax["failing"] == 1 and fmin["failing"] == 1
    assert fmax["worst"]["coords"] == {"direction": "down", "sigma": 0.006, "frequency_ratio": 0.98}
    assert fmax["worst"]["run"] is None and fmax["worst"]["difference"] is None
    assert fmax["worst"]["reference"] == float(ref["force_max"].values[1, 0, 3])
    assert fmin["worst"]["coords"]["frequency_ratio"] == 0.97 and fmin["worst"]["reference"] is None
    text = run_compare(run, ref, tmp_path, capsys)[1]
    assert "force_max: 1 of 20 points outside tolerance; worst at direction=down, " in text
    assert f"run nan, reference {ref['force_max'].values[1, 0, 3]:.10g} (NaN in one only;" in text


def test_jump_frequency_within_one_grid_step(tmp_path, capsys):
    ref = sweep_ds(step=0.0025)
    run = ref.copy(deep=True)
    run["jump_frequency_ratio"].values[0, 0] += 0.0025  # one dwell later: passes
    run["jump_frequency"].values[0, 0] += 0.0025 * 230.0
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 0, report["summary"]
    jump = report["variables"]["jump_frequency_ratio"]
    assert jump["tolerance"]["atol"] == 0.0025 and jump["tolerance"]["note"] == "one grid step"
    assert report["variables"]["jump_frequency"]["tolerance"]["atol"] == pytest.approx(0.575)
    run["jump_frequency_ratio"].values[1, 1] -= 0.005  # two dwells: fails
    run["jump_frequency"].values[1, 1] -= 0.005 * 230.0
    run["jump_frequency_ratio"].values[0, 1] = 0.99  # a jump where the reference has none
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 1
    jump = report["variables"]["jump_frequency_ratio"]
    assert jump["failing"] == 2 and report["variables"]["jump_frequency"]["failing"] == 1
    assert jump["worst"]["coords"] == {"direction": "up", "sigma": 0.01}  # NaN beats 2 steps
    hz = report["variables"]["jump_frequency"]["worst"]
    assert hz["coords"] == {"direction": "down", "sigma": 0.01}
    assert hz["difference"] == pytest.approx(-1.15)
    # a looser grid tolerance by --var (ATOL in the variable's units)
    code, report, _ = run_compare(
        run, ref, tmp_path, capsys, "--json", "--var", "jump_frequency=0,2"
    )
    assert report["variables"]["jump_frequency"]["passed"] is True


def test_flags_and_strings_are_exact(tmp_path, capsys):
    ref = sweep_ds()
    ref["bifurcation_kind"] = ("sigma", np.array(["fold", ""], dtype=object))
    run = ref.copy(deep=True)
    run["settled"].values[1, 1, 4] = 0
    run["bifurcation_kind"].values[0] = "period-doubling"
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json", "--rtol", "1")
    assert code == 1
    settled, kind = report["variables"]["settled"], report["variables"]["bifurcation_kind"]
    assert settled["failing"] == 1 and settled["tolerance"]["mode"] == "exact"
    assert settled["worst"]["coords"] == {
        "direction": "down",
        "sigma": 0.01,
        "frequency_ratio": 0.99,
    }
    assert (settled["worst"]["run"], settled["worst"]["reference"]) == (0, 1)
    assert kind["failing"] == 1 and kind["worst"]["run"] == "period-doubling"
    assert kind["worst"]["coords"] == {"sigma": 0.006}
    text = run_compare(run, ref, tmp_path, capsys)[1]
    assert (
        "settled: 1 of 20 points outside tolerance; worst at direction=down, sigma=0.01, "
        "frequency_ratio=0.99: run 0, reference 1 (must be equal)" in text
    )
    assert "bifurcation_kind: 1 of 2 points" in text


def test_different_grid_is_a_coordinate_mismatch(tmp_path, capsys):
    ref = sweep_ds(frequency_ratio=np.round(0.9 + 0.005 * np.arange(31), 12), step=0.005)
    run = sweep_ds(frequency_ratio=np.round(0.9 + 0.0025 * np.arange(61), 12), step=0.0025)
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 1 and report["equal"] is False
    assert report["coordinate_mismatches"] == [
        {
            "name": "frequency_ratio",
            "message": "61 values vs 31 in the reference",
            "blocks": ["frequency_ratio"],
        }
    ]
    along = ["amplitude", "phase", "force_max", "force_min", "flight_time", "settled"]
    for name in along:  # not compared as values
        assert report["variables"][name]["passed"] is None, name
        assert report["variables"][name]["worst"] is None
    for name in ("jump_frequency_ratio", "jump_frequency"):  # not along the grid: compared
        assert report["variables"][name]["passed"] is not None
    assert report["config_differences"] == [
        {"key": "sweep_step", "run": 0.0025, "reference": 0.005}
    ]
    text = run_compare(run, ref, tmp_path, capsys)[1].splitlines()
    assert text[0] == "coordinate mismatch: frequency_ratio: 61 values vs 31 in the reference"
    assert text[1] == f"not compared (coordinate mismatch): {', '.join(along)}"
    assert not any(s.startswith("amplitude:") for s in text)
    # the same length, other values: the first differing value is named
    shifted = sweep_ds(
        frequency_ratio=np.round(0.95 + 0.01 * np.arange(5) + [0, 0, 0.001, 0, 0], 12)
    )
    code, report, _ = run_compare(shifted, sweep_ds(), tmp_path, capsys, "--json")
    assert code == 1
    assert report["coordinate_mismatches"][0] == {
        "name": "frequency_ratio",
        "message": "first at frequency_ratio[2]: run 0.971, reference 0.97 (1 of 5 values differ)",
        "blocks": ["frequency_ratio"],
    }
    # frequency (Hz) differs too, but it is not reported twice
    assert len(report["coordinate_mismatches"]) == 1


def test_auxiliary_coordinate_is_reported_but_values_compared(tmp_path, capsys):
    ref = sweep_ds()
    run = ref.assign_coords(frequency=ref.frequency * 1.001)  # another f0, the same grid
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 1
    (mismatch,) = report["coordinate_mismatches"]
    assert mismatch["name"] == "frequency" and mismatch["blocks"] == []
    assert mismatch["message"].startswith(
        "first at frequency_ratio[0]: run 218.7185, reference 218.5"
    )
    assert all(v["passed"] for v in report["variables"].values())


def test_tolerance_options(tmp_path, capsys):
    ref = sweep_ds()
    run = ref.copy(deep=True)
    run["amplitude"].values[0, 0, 0, 0] *= 1 + 1e-5
    run["flight_time"].values[0, 0, 0] = 5e-13  # within the 1e-12 s floor
    assert run_compare(run, ref, tmp_path, capsys)[0] == 1
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json", "--rtol", "1e-4")
    assert code == 0 and report["variables"]["amplitude"]["tolerance"]["rule"] == "--rtol/--atol"
    assert report["variables"]["amplitude"]["tolerance"]["rtol"] == 1e-4
    assert run_compare(run, ref, tmp_path, capsys, "--atol", "1e-5")[0] == 0  # 0.1 * 1e-5 = 1e-6
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json", "--var", "amplitude=2e-5")
    assert code == 0 and report["variables"]["amplitude"]["tolerance"]["rule"] == "--var"
    assert report["variables"]["force_max"]["tolerance"]["rtol"] == 1e-6  # others unchanged
    # an explicit zero tolerance makes the flight-time floor bite
    code, report, _ = run_compare(
        run, ref, tmp_path, capsys, "--json", "--var", "amplitude=1", "--var", "flight_time=0,0"
    )
    assert code == 1 and report["variables"]["flight_time"]["failing"] == 1
    assert report["variables"]["flight_time"]["worst"]["run"] == 5e-13


def test_parse_variable_tolerance():
    assert parse_variable_tolerance("amplitude=1e-4") == ("amplitude", (1e-4, None))
    assert parse_variable_tolerance(" phase = 0 , 1 ") == ("phase", (0.0, 1.0))
    for bad in ("amplitude", "=1", "amplitude=", "amplitude=x", "amplitude=1,2,3", "a=-1", "a=nan"):
        with pytest.raises(ValueError, match="--var"):
            parse_variable_tolerance(bad)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--var", "nonsense=1"], "--var nonsense: no such variable in "),
        (["--var", "amplitude"], "--var 'amplitude': expected NAME=RTOL[,ATOL]"),
        (["--var", "amplitude=1,x"], "--var 'amplitude=1,x': expected NAME=RTOL[,ATOL]"),
        (["--rtol", "-1"], "--rtol: expected a tolerance >= 0, got -1.0"),
        (["--atol", "nan"], "--atol: expected a tolerance >= 0, got nan"),
    ],
)
def test_usage_errors_in_options(tmp_path, capsys, options, message):
    ds = sweep_ds()
    code, out, err = run_compare(ds, ds, tmp_path, capsys, *options)
    assert code == 2 and out == ""
    assert one_error_line(err).startswith(f"hertzsweep: error: {message}")


def test_usage_errors_in_files(tmp_path, capsys):
    sweep = write(sweep_ds(), tmp_path / "sweep.nc")
    trace = sweep_ds()
    trace.attrs["hertzsweep_kind"] = "trace"
    trace = write(trace, tmp_path / "trace.nc")
    code, out, err = run_cli(["compare", trace, sweep], capsys)
    assert code == 2 and out == ""
    assert one_error_line(err) == (
        f"hertzsweep: error: {trace}: a trace dataset, but {sweep} is a sweep dataset "
        "(compare datasets of one kind)"
    )
    missing = tmp_path / "absent.nc"
    code, _, err = run_cli(["compare", sweep, missing], capsys)
    expected = f"hertzsweep: error: {missing}: No such file or directory"
    assert code == 2 and one_error_line(err) == expected
    garbage = tmp_path / "garbage.nc"
    garbage.write_text("not netCDF\n")
    code, _, err = run_cli(["compare", garbage, sweep], capsys)
    assert code == 2 and one_error_line(err).startswith(
        f"hertzsweep: error: {garbage}: cannot read it as netCDF"
    )
    plain = sweep_ds()
    del plain.attrs["hertzsweep_kind"]
    plain = write(plain, tmp_path / "plain.nc")
    code, _, err = run_cli(["compare", sweep, plain], capsys)
    assert code == 2 and one_error_line(err) == (
        f"hertzsweep: error: {plain}: not a hertzsweep dataset (no hertzsweep_kind attribute)"
    )


def test_missing_and_new_variables(tmp_path, capsys):
    ref = sweep_ds()
    run = ref.drop_vars("force_min")
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 1 and report["missing_variables"] == ["force_min"]
    text = run_compare(run, ref, tmp_path, capsys)[1]
    assert f"missing in {tmp_path / 'run.nc'}: force_min" in text
    assert text.splitlines()[-1].startswith(
        "differ: 0 of 7 variables outside tolerance, 1 variable missing"
    )
    run = ref.assign(finished=(("direction", "sigma"), np.ones((2, 2), dtype=np.int8)))
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 0 and report["new_variables"] == ["finished"]


def test_config_differences_explain_but_do_not_fail(tmp_path, capsys):
    ref = sweep_ds()
    run = ref.copy(deep=True)
    run.attrs.update(
        damping_ratio=0.005,
        excitation_sigma=np.array([0.006, 0.02]),
        history="another time",
        integration_steps=12,
    )
    del run.attrs["damping_law"]
    code, text, _ = run_compare(run, ref, tmp_path, capsys)
    assert code == 0
    assert text.splitlines()[:3] == [
        "config: damping_ratio: run 0.005, reference 0.0045",
        "config: damping_law: run (absent), reference viscous",
        "config: excitation_sigma: run [0.006, 0.02], reference [0.006, 0.01]",
    ]
    # with config_json in both, the differences come from it (provenance keys left out)
    for ds, ratio, source in ((run, 0.005, "a.toml"), (ref, 0.0045, "b.toml")):
        config = {
            "damping": {"ratio": ratio, "law": "viscous"},
            "source": source,
            "sweep": {"directions": ["up", "down"]},
        }
        ds.attrs["config_json"] = json.dumps(config)
    code, report, _ = run_compare(run, ref, tmp_path, capsys, "--json")
    assert code == 0 and report["config_source"] == "config_json"
    assert report["config_differences"] == [
        {"key": "damping.ratio", "run": 0.005, "reference": 0.0045}
    ]


def test_tolerance_table_is_one_table_with_sane_defaults():
    assert TOLERANCES["[degree]"].mode == "phase" and TOLERANCES["[degree]"].atol == 0.5
    assert TOLERANCES["[1]"].rtol == 1e-6 and 0 < TOLERANCES["[1]"].atol <= 1e-9
    for name in ("jump_frequency_ratio", "jump_frequency", "bifurcation_frequency_ratio"):
        assert TOLERANCES[name].mode == "grid" and TOLERANCES[name].steps == 1
    for key in ("<flag>", "<string>", "<integer>"):
        assert TOLERANCES[key].mode == "exact"


# --------------------------------------------------------------------------- other kinds
def test_study_jump_step_from_the_coordinate_spacing():
    """A study without sweep_step (it varied over the grid): the frequency_ratio spacing."""
    ref = sweep_ds(step=0.0025).expand_dims(damping_exponent=[0.5, 1.5], axis=1)
    ref.attrs.update(hertzsweep_kind="study", study_kind="sweep")
    del ref.attrs["sweep_step"]
    ref["case_failed"] = (
        ("damping_exponent", "sigma"),
        np.zeros((2, 2), dtype=np.int8),
        {**attrs("case_failed"), "flag_values": np.array([0, 1], np.int8)},
    )
    run = ref.copy(deep=True)
    run["jump_frequency_ratio"].values[1, 1, 1] += 0.0025
    run["jump_frequency"].values[1, 1, 1] += 0.0025 * 230
    report = compare(run, ref)
    assert report.equal, report.text()
    assert report.variables["jump_frequency_ratio"].rule.atol == pytest.approx(0.0025)
    run["case_failed"].values[0, 1] = 1
    run["jump_frequency_ratio"].values[0, 0, 0] += 0.006
    report = compare(run, ref)
    failing = {v.name: v for v in report.failing}
    assert sorted(failing) == ["case_failed", "jump_frequency_ratio"]
    assert failing["case_failed"].worst.coords == {"damping_exponent": 0.5, "sigma": 0.01}
    assert failing["jump_frequency_ratio"].worst.coords == {
        "direction": "up",
        "damping_exponent": 0.5,
        "sigma": 0.006,
    }
    branch_study = ref.copy()
    branch_study.attrs["study_kind"] = "branch"
    with pytest.raises(ValueError, match="a study of kind sweep, but reference is a study"):
        compare(run, branch_study)


def accuracy_ds() -> xr.Dataset:
    labels = ["N=64 settle=300", "N=128 settle=300", "N=256 shooting"]
    data = {
        "error_h1": np.array([1.6e-2, 4.3e-3, 0.0]),
        "error_jump": np.array([np.inf, 0.0, 0.0]),
        "cost_steps": np.array([2_500_000, 5_000_000, 860_000], dtype=np.int64),
        "wall_time": np.array([0.03, 0.05, 0.08]),
        "order_h1": np.array([1.9, np.nan, np.nan]),
    }
    ds = xr.Dataset(
        {name: ("setting", values, attrs(name)) for name, values in data.items()},
        coords={
            "setting_label": ("setting", np.array(labels, dtype=object)),
            "steps_per_period": ("setting", [64, 128, 256]),
        },
        attrs={"hertzsweep_kind": "accuracy", "sweep_step": 0.0025},
    )
    return ds


def test_accuracy_wall_time_is_not_compared_and_settings_are_coordinates():
    ref = accuracy_ds()
    run = ref.copy(deep=True)
    run["wall_time"].values[:] *= 3  # another machine
    run["pareto"] = ("setting", np.array([1, 0, 1], dtype=np.int8), attrs("pareto"))
    ref["pareto"] = ("setting", np.array([0, 1, 1], dtype=np.int8), attrs("pareto"))
    report = compare(run, ref)
    assert report.equal, report.text()
    assert report.variables["wall_time"].passed is None
    assert report.variables["pareto"].passed is None  # drawn from the wall time
    assert "not compared (skipped by default; --var NAME=RTOL compares it): wall_time" in (
        report.text()
    )
    assert (
        compare(run, ref, variables={"wall_time": (0.1, None)}).variables["wall_time"].failing == 3
    )
    run["cost_steps"].values[2] += 1
    run["error_jump"].values[0] = 0.0025  # inf in the reference
    failing = {v.name: v for v in compare(run, ref).failing}
    assert sorted(failing) == ["cost_steps", "error_jump"]
    worst = failing["cost_steps"].worst
    assert worst.coords == {
        "setting": 2,
        "setting_label": "N=256 shooting",
        "steps_per_period": 256,
    }
    assert (worst.run, worst.reference) == (860_001, 860_000)
    assert failing["error_jump"].as_dict()["worst"]["reference"] == "inf"
    other = ref.assign_coords(setting_label=("setting", ["a", "N=128 settle=300", "b"]))
    report = compare(other, ref)
    assert [m.name for m in report.coordinate_mismatches] == ["setting_label"]
    assert report.coordinate_mismatches[0].message == (
        "first at setting[0]: run a, reference 'N=64 settle=300' (2 of 3 values differ)"
    )
    assert all(v.passed is None for v in report.variables.values())


def test_golden_branch_and_trace(capsys):
    for name in ("branch-default", "trace-vibro", "sweep-default"):
        path = GOLDEN / f"{name}.nc"
        code, out, _ = run_cli(["compare", path, path], capsys)
        assert code == 0 and out.startswith("equal: "), out
    branch = open_dataset(GOLDEN / "branch-default.nc")
    run = branch.copy(deep=True)
    run["bifurcation_frequency_ratio"].values[0, 0] += 0.002  # within the 0.0025 step
    assert compare(run, branch).equal
    run["bifurcation_frequency_ratio"].values[0, 1] -= 0.003
    run["bifurcation_kind"].values[0, 1] = "period-doubling"
    failing = {v.name: v for v in compare(run, branch).failing}
    assert sorted(failing) == ["bifurcation_frequency_ratio", "bifurcation_kind"]
    assert failing["bifurcation_kind"].worst.coords == {"sigma": 0.01, "bifurcation": 1}
    assert failing["bifurcation_frequency_ratio"].worst.difference == pytest.approx(-0.003)
    trace = open_dataset(GOLDEN / "trace-vibro.nc")
    run = trace.copy(deep=True)
    run["normal_force"].values[0, 700] += 1e-3
    (failing,) = compare(run, trace).failing
    assert failing.name == "normal_force" and failing.failing == 1
    coords = failing.worst.coords
    assert coords["sigma"] == 0.078 and coords["sample"] == 700
    assert coords["tau"] == float(trace.tau[700]) and coords["time"] == float(trace.time[700])


# --------------------------------------------------------------------------- real sweeps
SMALL = ["--set", "sweep.start=0.97", "--set", "sweep.stop=0.99", "--quiet"]


def sweep(tmp_path, capsys, name, *options):
    out = tmp_path / f"{name}.nc"
    code, _, err = run_cli(["sweep", SMOKE, "-o", out, *SMALL, *options], capsys)
    assert code == 0, err
    return out


def test_real_sweeps_identical_and_damping_changed(tmp_path, capsys):
    a = sweep(tmp_path, capsys, "a")
    b = sweep(tmp_path, capsys, "b")
    code, out, _ = run_cli(["compare", a, b], capsys)
    assert code == 0 and out.startswith("equal: 15 variables within tolerance (sweep;")
    c = sweep(tmp_path, capsys, "c", "--set", "damping.ratio=0.004545")  # +1 %
    code, out, _ = run_cli(["compare", c, a, "--json"], capsys)
    assert code == 1
    report = json.loads(out)
    assert report["config_differences"] == [
        {"key": "damping.ratio", "run": 0.004545, "reference": 0.0045}
    ]
    amp = report["variables"]["amplitude"]
    assert amp["passed"] is False
    # the count and the worst point, recomputed here from the two files
    run, ref = open_dataset(c).amplitude, open_dataset(a).amplitude
    allowed = 1e-10 + 1e-6 * np.abs(ref.values)
    excess = np.abs(run.values - ref.values) / allowed
    assert amp["failing"] == int(np.sum(excess > 1)) and amp["total"] == ref.size == 72
    assert amp["failing"] > 60  # a 1 % damping change moves (nearly) every amplitude
    i = np.unravel_index(np.argmax(excess), ref.shape)
    assert amp["worst"]["coords"] == {
        "direction": str(ref.direction[i[0]].values),
        "sigma": float(ref.sigma[i[1]]),
        "frequency_ratio": float(ref.frequency_ratio[i[2]]),
        "harmonic": int(ref.harmonic[i[3]]),
    }
    assert amp["worst"]["run"] == float(run.values[i]) and amp["worst"]["reference"] == float(
        ref.values[i]
    )
    code, text, _ = run_cli(["compare", c, a], capsys)
    at = ", ".join(
        f"{k}={v:.10g}" if isinstance(v, float) else f"{k}={v}"
        for k, v in amp["worst"]["coords"].items()
    )
    assert f"amplitude: {amp['failing']} of 72 points outside tolerance; worst at {at}: " in text
    assert "config: damping.ratio: run 0.004545, reference 0.0045" in text


# --------------------------------------------------------------------------- the smoke scene
def test_smoke_reference_is_small_and_made_by_the_sweep_command():
    assert SMOKE_REFERENCE.stat().st_size < 100_000
    ref = open_dataset(SMOKE_REFERENCE)
    assert ref.attrs["hertzsweep_kind"] == "sweep"
    history = ref.attrs["history"]  # the command line, its paths absolute
    assert "hertzsweep sweep " in history and "configs/smoke.toml -o " in history
    assert ref.sizes["frequency_ratio"] <= 20 and not np.all(np.isnan(ref.jump_frequency_ratio))


def make_smoke_commands() -> list[list[str]]:
    """The hertzsweep commands of ``make smoke`` (from ``make -n``), without the venv path."""
    if shutil.which("make") is None:
        pytest.skip("make is not installed")
    done = subprocess.run(
        ["make", "-n", "-s", "smoke"], cwd=ROOT, capture_output=True, text=True, check=True
    )
    commands = [line.split() for line in done.stdout.splitlines() if "bin/hertzsweep " in line]
    return [words[1:] for words in commands]


def test_make_smoke_passes_and_fails_on_a_changed_model(tmp_path, capsys, monkeypatch):
    commands = make_smoke_commands()
    assert [c[0] for c in commands] == ["sweep", "compare"]
    sweep_command, compare_command = commands
    monkeypatch.chdir(ROOT)
    out = str(tmp_path / "smoke.nc")
    sweep_argv = [out if w == "results/smoke.nc" else w for w in sweep_command]
    compare_argv = [out if w == "results/smoke.nc" else w for w in compare_command]
    assert compare_argv[1:] == [out, "tests/data/smoke-reference.nc"]
    code, _, err = run_cli(sweep_argv, capsys)
    assert code == 0, err
    code, text, _ = run_cli(compare_argv, capsys)
    assert code == 0, text  # make smoke passes on this checkout
    # the model changed (damping 1 % up, as a changed kernel constant would): exit 1
    code, _, err = run_cli([*sweep_argv, "--set", "damping.ratio=0.004545"], capsys)
    assert code == 0, err
    code, out_json, _ = run_cli([*compare_argv, "--json"], capsys)
    report = json.loads(out_json)
    assert code == 1 and report["variables"]["amplitude"]["failing"] > 100


def test_smoke_reference_perturbed_fails(tmp_path, capsys):
    ref = open_dataset(SMOKE_REFERENCE)
    for factor, status in ((1 + 1e-9, 0), (1 + 1e-5, 1)):
        bad = ref.copy(deep=True)
        bad["force_max"].values[1, 0, 5] *= factor
        path = write(bad, tmp_path / "perturbed.nc")
        code, out, _ = run_cli(["compare", SMOKE_REFERENCE, path, "--json"], capsys)
        report = json.loads(out)
        assert code == status, report["summary"]
        fmax = report["variables"]["force_max"]
        assert fmax["failing"] == status
        assert fmax["worst"]["coords"] == {
            "direction": "down",
            "sigma": 0.006,
            "frequency_ratio": float(ref.frequency_ratio[5]),
        }


# --------------------------------------------------------------------------- old files
def test_an_integer_harmonic_of_an_earlier_version_reads_as_float(tmp_path, capsys):
    # Files made before orders that are not whole hold ``harmonic`` as integers (int32: the
    # smoke reference, the golden files); every file since holds float64. The one reader
    # (open_dataset) casts the old to float64, so old and new compare, align and select
    # alike: the smoke reference against a fresh run of its scene and against itself with a
    # float coordinate, both ways, with every value equal.
    import netCDF4

    with netCDF4.Dataset(SMOKE_REFERENCE) as nc:
        assert nc["harmonic"].dtype == np.int32
    old = open_dataset(SMOKE_REFERENCE)
    assert old.harmonic.dtype == np.float64 and old.harmonic.values.tolist() == [1.0, 2.0]
    assert old.harmonic.attrs["long_name"] == "harmonic order k of the transmitted normal force"
    new = tmp_path / "smoke.nc"
    code, _, err = run_cli(["sweep", SMOKE, "-o", new, "-q"], capsys)
    assert code == 0, err
    with netCDF4.Dataset(new) as nc:
        assert nc["harmonic"].dtype == np.float64
    for pair in ((new, SMOKE_REFERENCE), (SMOKE_REFERENCE, new)):
        code, out, _ = run_cli(["compare", *pair, "--json"], capsys)
        report = json.loads(out)
        assert report["coordinate_mismatches"] == [], report["summary"]
        assert report["variables"]["amplitude"]["failing"] == 0
        # the reference, older, lacks what the datasets gained since (response_period and
        # the subharmonic jumps): as the candidate it misses them, so only that way differs
        assert code == (0 if pair[0] == new else 1), report["summary"]
    assert float(old.amplitude.sel(harmonic=2).max()) == pytest.approx(
        float(open_dataset(new).amplitude.sel(harmonic=2.0).max()), rel=1e-12
    )
