"""The numpy dataset the builders make (output.frame): its checks, and that its xarray
form is what reading the written file gives."""

from __future__ import annotations

import numpy as np
import pytest

from hertzsweep.drivers.sweep import run_sweep
from hertzsweep.output.dataset import open_dataset, sweep_dataset, write_atomic
from hertzsweep.output.frame import Frame

from .conftest import make_scene


def test_a_dimension_of_two_lengths_is_refused():
    coords = {"x": ("x", np.arange(3), {})}
    with pytest.raises(ValueError, match="dimension 'x' of lengths 3 and 4"):
        Frame({"a": ("x", np.zeros(4), {})}, coords, {})
    with pytest.raises(ValueError, match="a: 2 dimension"):
        Frame({"a": ("x", np.zeros((3, 1)), {})}, coords, {})


def test_the_xarray_form_is_what_the_file_reads_back(tmp_path):
    """Every variable, coordinate and attribute of ``to_xarray()`` equals the written
    file's, values bit for bit (NaN where NaN)."""
    scene = make_scene(
        excitation={"sigma": [0.01, 0.078]},
        sweep={"start": 0.9, "stop": 0.95, "step": 0.025, "settle_periods": 20},
        solver={"steps_per_period": 64},
    )
    frame = sweep_dataset(run_sweep(scene), scene)
    write_atomic(frame, tmp_path / "s.nc")
    back, built = open_dataset(tmp_path / "s.nc"), frame.to_xarray()
    assert set(back.variables) == set(built.variables)
    assert set(back.coords) == set(built.coords)
    for name, variable in built.variables.items():
        assert back[name].dims == variable.dims, name
        assert np.array_equal(
            back[name].values, variable.values, equal_nan=variable.dtype.kind == "f"
        ), name
        for key, value in variable.attrs.items():
            assert np.array_equal(back[name].attrs[key], value), (name, key)
    assert back.attrs.keys() == built.attrs.keys()
