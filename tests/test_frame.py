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


# --------------------------------------------------------------------------- large variables
def test_only_long_last_axes_are_written_in_slabs(tmp_path):
    # a compressed variable whose last axis is longer than a slab (a long trace's
    # spectrum) gets HDF5 chunks of one slab along it; a large one with a short last axis
    # (a study's amplitude: ..., harmonic) keeps netCDF's default chunks: slabs of
    # (1, ..., 1, 3) would be 24-byte chunks, 6x the file and 30x the time (measured
    # 38.4 MB and 8.5 s against 6.5 MB and 0.29 s for these 7.7 MB of random values)
    import netCDF4

    from hertzsweep.output.dataset import SLAB_BYTES

    rng = np.random.default_rng(1)
    slab = SLAB_BYTES // 8
    study = rng.random((400, 2, 2, 200, 3))
    spectrum = rng.random((2, slab + 1000))
    frame = Frame(
        {
            "amplitude": (("a", "b", "c", "d", "harmonic"), study, {}),
            "spectrum": (("sigma", "order"), spectrum, {}),
        },
        {},
        {},
    )
    path = tmp_path / "large.nc"
    write_atomic(frame, path)
    with netCDF4.Dataset(path) as nc:
        assert nc["spectrum"].chunking() == [1, slab]
        assert nc["amplitude"].chunking()[-1] == 3 and np.prod(nc["amplitude"].chunking()) > 1e4
        np.testing.assert_array_equal(nc["spectrum"][...], spectrum)
        np.testing.assert_array_equal(nc["amplitude"][...], study)
    assert path.stat().st_size < 1.2 * (study.nbytes + spectrum.nbytes)  # random: no gain
