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


@pytest.mark.parametrize(
    "argv",
    [("sweep", str(CONFIGS / "default.toml"), "--set", "sweep.start=0.97",
      "--set", "sweep.stop=0.98"),
     ("trace", str(CONFIGS / "default.toml"), "-w", "0.97", "--periods", "2",
      "--set", "sweep.start=0.97", "--set", "sweep.stop=0.98")],
    ids=["sweep", "trace"],
)  # fmt: skip
def test_writing_a_run_loads_no_xarray_pandas_matplotlib_or_dask(tmp_path, argv):
    """A sweep or a trace builds its dataset as numpy arrays (output.frame) and writes it
    with netCDF4: xarray and pandas (0.3 s), and the dask xarray probes, are never
    loaded; pyfftw only by a trace's spectrum."""
    modules = loaded(*argv, "-o", str(tmp_path / "s.nc"), "-q")
    assert "numba" in modules  # it does compile and write
    assert not modules & {"xarray", "pandas", "matplotlib", "dask", "distributed"}
    assert ("pyfftw" in modules) == (argv[0] == "trace")
