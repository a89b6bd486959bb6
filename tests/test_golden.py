"""Every command's numbers against reference datasets made by hertzsweep 0.1.0.

The references in ``tests/data/golden/`` (regenerated only by ``python
tests/golden_cases.py``) hold the datasets of the sweep (every damping-law kernel path,
fixed and automatic settling, shooting), trace and branch commands. Every data variable
must agree to 1e-12 relative to the variable's largest magnitude: the kernels may reorder
floating-point operations (contraction to FMA changes the last bit of a step), and a
rounding difference of one ulp per step grows to about 1e-13 over a dwell, far below
1e-12; a different formula or a lost step shows at 1e-6 or above.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from tests.golden_cases import CASES, GOLDEN, run

RTOL = 1e-12  # relative to the variable's largest magnitude (see the module docstring)
# variables the datasets gained after the references were made: checked by their own tests
ADDED = {  # tests/test_ballmode.py, tests/test_response_period.py
    "ball_mode_error",
    "response_period",
    "subharmonic_onset_frequency_ratio",
    "subharmonic_end_frequency_ratio",
}


def assert_same(new: xr.Dataset, ref: xr.Dataset, name: str) -> None:
    assert set(new.data_vars) - ADDED == set(ref.data_vars), name
    assert dict(new.sizes) == dict(ref.sizes), name
    for key in ref.variables:
        a, b = new[key].values, ref[key].values
        if b.dtype.kind in "OUS" or b.dtype.kind in "iub" or b.dtype.kind == "M":
            np.testing.assert_array_equal(a, b, err_msg=f"{name}: {key}")
            continue
        finite = np.isfinite(b)
        np.testing.assert_array_equal(np.isfinite(a), finite, err_msg=f"{name}: {key} NaN mask")
        if not finite.any():
            continue
        difference = np.abs(a[finite] - b[finite])
        if ref[key].attrs.get("units") == "degree":  # 359.99... and 0.00... are one phase
            difference = np.minimum(difference, 360.0 - difference)
        scale = max(float(np.max(np.abs(b[finite]))), 1e-300)
        worst = float(np.max(difference)) / scale
        assert worst <= RTOL, f"{name}: {key}: {worst:.3g} relative"


@pytest.mark.parametrize("name", sorted(CASES))
def test_command_matches_golden_data(name, tmp_path):
    output = tmp_path / f"{name}.nc"
    run(name, output)
    with xr.open_dataset(output) as new, xr.open_dataset(GOLDEN / f"{name}.nc") as ref:
        assert_same(new.load(), ref.load(), name)


def test_golden_comparison_can_fail():
    """A change of 1e-10 in one amplitude is caught (the comparison is not vacuous)."""
    with xr.open_dataset(GOLDEN / "sweep-default.nc") as ref:
        ref = ref.load()
    bad = ref.copy(deep=True)
    bad["amplitude"].values[0, 0, 10, 0] *= 1.0 + 1e-10
    with pytest.raises(AssertionError, match="amplitude"):
        assert_same(bad, ref, "perturbed")
    assert_same(ref, ref, "itself")
