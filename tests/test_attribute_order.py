"""The global attributes come in one order (``ATTRIBUTE_ORDER`` of
:mod:`hertzsweep.output.dataset`): the ACDD and CF ones first, then the rig's, the
scene's, the solver's and the provenance; the same in the dataset in memory and in the
file the writer makes."""

from __future__ import annotations

import netCDF4
import pytest

from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.drivers.trace import run_trace
from hertzsweep.io.measured import measured_dataset, read_measurements
from hertzsweep.output.dataset import (
    RIG_ATTRIBUTES,
    SUMMARIES,
    ordered_attributes,
    sweep_dataset,
    trace_dataset,
    write_atomic,
)

from .conftest import CONFIGS, make_scene

FIRST = (  # ACDD 1.3 and CF, what a reader of `ncdump -h` sees first
    "title",
    "summary",
    "Conventions",
    "source",
    "history",
    "references",
    "hertzsweep_kind",
    "hertzsweep_version",
)
TINY = {  # one level, three dwells of 20 + 4 periods of 64 steps: well under a second
    "excitation": {"sigma": [0.01]},
    "sweep": {
        "start": 0.9,
        "stop": 0.95,
        "step": 0.025,
        "settle_periods": 20,
        "measure_periods": 4,
    },
    "solver": {"steps_per_period": 64},
}


@pytest.fixture(scope="module")
def datasets():
    """A sweep, a trace and a measured dataset, as built in memory."""
    scene = make_scene(**TINY)
    trace = run_trace(scene, 0.95, periods=2, samples_per_period=16)
    measured = read_measurements(CONFIGS / "measured" / "paper-up-jumps.csv")
    return {
        "sweep": sweep_dataset(run_sweep(scene), scene),
        "trace": trace_dataset(trace, scene),
        "measured": measured_dataset(measured),
    }


@pytest.mark.parametrize("kind", ["sweep", "trace", "measured"])
def test_in_memory_the_acdd_attributes_come_first(datasets, kind):
    ds = datasets[kind]
    names = list(ds.attrs)
    assert tuple(names[: len(FIRST)]) == FIRST, names
    assert ds.attrs["hertzsweep_kind"] == kind and ds.attrs["summary"] == SUMMARIES[kind]
    assert names == list(ordered_attributes(ds.attrs))


def test_the_groups_follow_in_order(datasets):
    names = list(datasets["sweep"].attrs)
    groups = [
        names.index("ball_radius"),  # the rig's
        names.index("natural_frequency"),  # ... its derived constants
        names.index("damping_ratio"),  # the scene's
        names.index("sweep_start"),
        names.index("steps_per_period"),  # the solver's
        names.index("python_version"),  # provenance
        names.index("config_json"),
        names.index("integration_steps"),  # the kind's own
    ]
    assert groups == sorted(groups)
    assert names[len(FIRST) : len(FIRST) + 2] == ["rig_geometry", "ball_radius"]
    assert set(RIG_ATTRIBUTES) >= {"contact_stiffness", "static_load", "ball_mass"}


def test_an_attribute_added_later_takes_its_place():
    attrs = {"integration_steps": 5, "sweep_step": 0.1, "title": "t", "numba_version": "0"}
    attrs |= {"mass": 1.0, "Conventions": "CF-1.11", "zeta": 1, "alpha": 2}
    expected = ["title", "Conventions", "mass", "sweep_step", "numba_version"]
    assert list(ordered_attributes(attrs)) == [*expected, "integration_steps", "zeta", "alpha"]


@pytest.mark.parametrize("kind", ["sweep", "trace", "measured"])
def test_the_written_file_has_the_order_of_the_dataset(datasets, kind, tmp_path):
    # the file as the commands write it: `ncdump -h` lists title, summary, Conventions ...
    # first (a file netCDF builds in its own memory image would list them in name-hash
    # order: Unidata/netcdf-c#3334)
    path = write_atomic(datasets[kind], tmp_path / f"{kind}.nc")
    with netCDF4.Dataset(str(path)) as nc:
        names = nc.ncattrs()
    assert tuple(names[: len(FIRST)]) == FIRST, names
    assert names == list(datasets[kind].attrs)
