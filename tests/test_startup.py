"""Each command imports only what it uses (run in a fresh interpreter, as a shell would)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from .conftest import CONFIGS

HEAVY = ("numba", "xarray", "matplotlib", "dask", "dask.array", "distributed", "pyfftw")
HEAVY += ("scipy", "pandas")
PROBE = """
import json, sys
from hertzsweep.cli import main
try:
    main(sys.argv[1:])
except SystemExit as exc:
    assert exc.code in (0, None), exc.code
heavy = {heavy!r}
print(json.dumps(sorted(m for m in heavy if m in sys.modules)))
"""


def loaded(*argv: str) -> set[str]:
    """The heavy modules a command leaves in ``sys.modules``."""
    code = PROBE.format(heavy=HEAVY)
    done = subprocess.run(
        [sys.executable, "-c", code, *argv], capture_output=True, text=True, check=True
    )
    return set(json.loads(done.stdout.strip().splitlines()[-1]))


@pytest.mark.parametrize(
    "argv",
    [("--help",), ("--version",), ("rig", str(CONFIGS / "rig.toml")),
     ("validate", str(CONFIGS / "default.toml"))],
    ids=["help", "version", "rig", "validate"],
)  # fmt: skip
def test_light_commands_load_no_heavy_module(argv):
    assert loaded(*argv) == set()


def test_sweep_loads_neither_matplotlib_nor_pyfftw_nor_dask_arrays(tmp_path):
    """xarray asks dask's core whether each array it wraps is a dask collection
    (``dask.base``, 0.07 s); dask.array (0.2 s) and distributed are never loaded."""
    modules = loaded(
        "sweep", str(CONFIGS / "default.toml"), "-o", str(tmp_path / "s.nc"), "-q",
        "--set", "sweep.start=0.97", "--set", "sweep.stop=0.98",
    )  # fmt: skip
    assert {"numba", "xarray"} <= modules  # it does compile and write
    assert not modules & {"matplotlib", "pyfftw", "dask.array", "distributed"}
