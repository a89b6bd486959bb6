"""A long trace's record streams to its file as it is integrated: the same file as the
record held in memory, flights joined across chunks, memory that does not grow with the
record, and a failed write as one line."""

import os
import subprocess
import sys

import netCDF4
import numpy as np
import pytest

from hertzsweep.core import checks
from hertzsweep.core.config import load_scene
from hertzsweep.drivers import trace
from hertzsweep.drivers.trace import FlightLog, flight_intervals
from hertzsweep.output import dataset

from .conftest import CONFIGS, run_cli, run_on_a_small_disk
from .test_trace import IMPACT, _scene_file

IMPACT_TOML = """
rig = "{rig}"
[damping]
ratio = 0.01
law = "contact"
exponent = 1.5
[excitation]
sigma = [0.078, 0.07]
[sweep]
start = 0.8
stop = 0.95
step = 0.01
settle_periods = 200
"""


def impact_scene(tmp_path):
    """The paper's Fig. 17 case (IMPACT: from rest at 0.95 onto the impacting branch)
    with two sigma: a flight every period at 0.85."""
    assert IMPACT["damping"]["exponent"] == 1.5  # the same case as test_trace's
    path = tmp_path / "impact.toml"
    path.write_text(IMPACT_TOML.format(rig=CONFIGS / "rig.toml"))
    return path


def netcdf_contents(path, naming=("history", "date_created")):
    """Every variable's dims, type, attributes, filters and values, and the global
    attributes but those that name the run."""
    with netCDF4.Dataset(path) as nc:
        attrs = {k: nc.getncattr(k) for k in nc.ncattrs() if k not in naming}
        variables = {}
        for name, var in nc.variables.items():
            var.set_auto_mask(False)
            variables[name] = (
                var.dimensions,
                var.dtype,
                {k: var.getncattr(k) for k in var.ncattrs()},
                var.filters(),
                var[...],
            )
    return attrs, variables


def assert_same_file(a, b, naming=("history", "date_created")):
    attrs_a, vars_a = netcdf_contents(a, naming)
    attrs_b, vars_b = netcdf_contents(b, naming)
    assert attrs_a.keys() == attrs_b.keys()
    for key, value in attrs_a.items():
        np.testing.assert_array_equal(value, attrs_b[key], err_msg=key)
    assert vars_a.keys() == vars_b.keys()
    for name, (dims, dtype, attrs, filters, values) in vars_a.items():
        other = vars_b[name]
        assert (dims, dtype, filters) == other[:2] + other[3:4], name
        assert attrs.keys() == other[2].keys(), name
        for key, value in attrs.items():
            np.testing.assert_array_equal(value, other[2][key], err_msg=f"{name}.{key}")
        np.testing.assert_array_equal(values, other[4], err_msg=name)  # bit for bit, NaN = NaN


# --------------------------------------------------------------------------- the same file
def test_streamed_file_equals_the_in_memory_one(tmp_path, capsys, monkeypatch):
    # chunks of 3 periods x 64 samples, so that 20 periods make 7 chunks, every boundary
    # inside a flight or next to one; streamed and in memory run the same chunks, so the
    # files agree bit for bit (record, coordinates, spectrum, readings, flights, attributes)
    scene = impact_scene(tmp_path)
    monkeypatch.setattr(trace, "CHUNK_SAMPLES", 3 * 64)
    argv = ["trace", scene, "-w", "0.85", "--periods", "20", "--samples-per-period", "64", "-q"]
    code, held, err = run_cli([*argv, "-o", tmp_path / "held.nc"], capsys)
    assert code == 0, err
    monkeypatch.setattr(checks, "STREAM_RECORD_BYTES", 0)
    code, streamed, err = run_cli([*argv, "-o", tmp_path / "streamed.nc"], capsys)
    assert code == 0, err
    assert streamed.replace("streamed.nc", "held.nc") == held and held.count("21 flight(s)") == 2
    assert_same_file(tmp_path / "held.nc", tmp_path / "streamed.nc")
    with netCDF4.Dataset(tmp_path / "streamed.nc") as nc:
        assert nc["normal_force"].chunking() == [1, 3 * 64]  # one HDF5 chunk per chunk
        assert nc["in_contact"].dtype == np.int8
    assert sorted(p.name for p in tmp_path.iterdir()) == ["held.nc", "impact.toml", "streamed.nc"]


def test_chunked_readings_agree_with_one_block(tmp_path):
    # the readings of 7 chunks combined (Block.then) against one block of 20 periods:
    # the lock-in sums add in another order and the state crosses each chunk boundary as
    # a displacement, so they agree to round-off grown through 20 impacts, not bit for bit
    scene = load_scene(impact_scene(tmp_path))
    whole = trace.run_trace(scene, 0.85, periods=20, samples_per_period=64)
    trace.CHUNK_SAMPLES, saved = 3 * 64, trace.CHUNK_SAMPLES
    try:
        chunked = trace.run_trace(scene, 0.85, periods=20, samples_per_period=64)
    finally:
        trace.CHUNK_SAMPLES = saved
    np.testing.assert_allclose(chunked.amplitude, whole.amplitude, rtol=1e-11)
    np.testing.assert_allclose(chunked.record, whole.record, rtol=0, atol=1e-10)
    np.testing.assert_allclose(chunked.flights.start, whole.flights.start, rtol=1e-12)
    np.testing.assert_array_equal(chunked.flights.complete, whole.flights.complete)
    for name in ("mean_force", "force_max", "force_min", "contact_loss_fraction"):
        np.testing.assert_allclose(getattr(chunked, name), getattr(whole, name), rtol=1e-12)


# --------------------------------------------------------------------------- flights
@pytest.mark.parametrize("offset", [0, 7, 32])  # in contact, in flight, at a crossing
def test_flight_log_joins_chunks_bit_for_bit(offset):
    # q = -3/2 + cos(tau): a flight on [pi/2, 3pi/2] of every 2 pi. Cut into chunks of
    # every length from 1 to 40 samples, the log gives the whole record's flights bit
    # for bit, the cut ones at either end included
    dt = 2 * np.pi / 64
    tau = (np.arange(300) + offset) * dt
    record = np.zeros((tau.size, 4))
    record[:, 0] = -1.5 + np.cos(tau)
    record[:, 1] = -np.sin(tau)
    record[:, 3] = (record[:, 0] > -1.5).astype(float)
    whole = flight_intervals(record, dt)
    assert whole[0].size >= 4 and (offset != 32 or whole[2][0] == 0)
    for chunk in range(1, 41):
        log = FlightLog(dt)
        for first in range(0, tau.size, chunk):
            lead = 1 if first else 0
            end = min(first + chunk, tau.size)
            log.add(record[first - lead : end], first - lead, last=end == tau.size)
        for got, want in zip(log.intervals(), whole, strict=True):
            np.testing.assert_array_equal(got, want, err_msg=f"chunk {chunk}")


# --------------------------------------------------------------------------- memory
PEAK = """
import sys
from hertzsweep.core import checks
from hertzsweep.core.config import load_scene
checks.STREAM_RECORD_BYTES = int(sys.argv[1])
from hertzsweep.cli import main
try:
    main(sys.argv[2:])
except SystemExit as exc:
    assert not exc.code, exc.code
status = open("/proc/self/status").read().split("VmHWM:")[1].split()
print(int(status[0]) * 1024)
"""


def peak_bytes(tmp_path, scene, periods, threshold):
    """Peak resident memory of ``hertzsweep trace`` recording ``periods`` periods."""
    out = tmp_path / f"trace{periods}.nc"
    argv = ["trace", scene, "-w", "0.98", "--periods", str(periods), "-o", out, "-q"]
    done = subprocess.run(
        [sys.executable, "-c", PEAK, str(threshold), *map(str, argv)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    return int(done.stdout.split()[-1])


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads VmHWM from /proc")
def test_streamed_trace_memory_does_not_grow_with_the_record(tmp_path):
    # 1000 and 7000 periods x 256 samples x 2 sigma, streamed: the record (32 bytes per
    # sample and sigma) is in the file; what the run holds grows only with the spectrum:
    # one sigma's N/F_s in the transform's own input (1 float a sample), per sigma half
    # a spectrum, and its orders and frequencies (1 float): 2 floats a sample = 8 bytes
    # per sample and sigma, plus the writer's and the transform's buffers: measured 19.
    # Held in memory, the same runs grow by about 75 bytes a sample and sigma (the
    # record, the dataset's and the writer's copies, the in-memory file image): the
    # bound, 3/4 of the record alone, tells them apart with room for the allocator.
    scene = _scene_file(tmp_path)
    small = peak_bytes(tmp_path, scene, 1000, 0)
    large = peak_bytes(tmp_path, scene, 7000, 0)
    per_sample = (large - small) / (6000 * 256 * 2)
    assert per_sample < 24, f"{per_sample:.1f} bytes per sample and sigma"


# --------------------------------------------------------------------------- failures
def test_a_failed_streamed_write_is_one_line(tmp_path, capsys, monkeypatch):
    # the netCDF library fails a chunk's write ("HDF error", no errno): with the disk full
    # it is "No space left on device", else an I/O error quoting the library; one line,
    # exit 2, no temporary left, an earlier file untouched
    out = tmp_path / "x.nc"
    out.write_bytes(b"an earlier trace")
    monkeypatch.setattr(checks, "STREAM_RECORD_BYTES", 0)
    calls = []

    class Failing:  # the file, whose variables fail from the second chunk on
        def __init__(self, nc):
            self.nc = nc

        def __getattr__(self, name):
            return getattr(self.nc, name)

        def __getitem__(self, name):
            calls.append(name)
            if len(calls) > 6:  # tau, time and 4 record variables: one chunk
                raise RuntimeError("NetCDF: HDF error")
            return self.nc[name]

    real_open = dataset.RecordStream.open

    def open_failing(self, *args):
        real_open(self, *args)
        self.nc = Failing(self.nc)

    monkeypatch.setattr(dataset.RecordStream, "open", open_failing)
    monkeypatch.setattr(trace, "CHUNK_SAMPLES", 256)
    argv = ["trace", _scene_file(tmp_path), "-w", "0.98", "--periods", "4", "-o", out, "-q"]
    code, stdout, err = run_cli(argv, capsys)
    assert (code, stdout) == (2, "") and err.count("\n") == 1, err
    assert err == f"hertzsweep: error: {out}: Input/output error (netCDF: NetCDF: HDF error)\n"
    assert out.read_bytes() == b"an earlier trace"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml", "x.nc"]

    class Full:
        f_bavail, f_frsize = 3, 4096

    calls.clear()
    monkeypatch.setattr(dataset.os, "statvfs", lambda path: Full)
    code, stdout, err = run_cli(argv, capsys)
    assert (code, err) == (2, f"hertzsweep: error: {out}: No space left on device\n"), err


def test_a_really_full_disk_while_streaming_is_one_line(tmp_path):
    # a 256 kB tmpfs (root, unshare): 1100 periods x 256 samples x 2 sigma (18 MB of
    # record) stream, and a chunk's write fails; the library's "HDF error" is reported as
    # the full disk it is, exit 2, nothing left in full/
    scene = _scene_file(tmp_path)
    assert checks.streams_record(load_scene(scene), 1100 * 256)
    argv = [sys.executable, "-m", "hertzsweep", "trace", str(scene), "-w", "0.98"]
    argv += ["--periods", "1100", "-o", "full/x.nc", "-q"]
    stdout, stderr = run_on_a_small_disk(tmp_path, argv, "256k")
    assert stdout.split() == ["status=2"], stdout  # nothing left in full/
    assert stderr == "hertzsweep: error: full/x.nc: No space left on device\n"


def test_rerun_of_a_streamed_trace_streams_the_same_file(tmp_path, capsys, monkeypatch):
    # rerun reads only the input's attributes and streams the record again: the same
    # data and attributes bit for bit (but those naming the run and its scene's source)
    scene = impact_scene(tmp_path)
    monkeypatch.setattr(checks, "STREAM_RECORD_BYTES", 0)
    monkeypatch.setattr(trace, "CHUNK_SAMPLES", 3 * 64)
    first, again = tmp_path / "first.nc", tmp_path / "again.nc"
    argv = ["trace", scene, "-w", "0.85", "--periods", "7", "--samples-per-period", "64"]
    code, _, err = run_cli([*argv, "-q", "-o", first], capsys)
    assert code == 0, err
    streamed = []
    real_open = dataset.RecordStream.open

    def counting_open(self, *args):
        streamed.append(args)
        real_open(self, *args)

    monkeypatch.setattr(dataset.RecordStream, "open", counting_open)
    code, out, err = run_cli(["rerun", first, "-q", "-o", again], capsys)
    assert code == 0, err
    assert len(streamed) == 1 and streamed[0][:3] == (2, 7 * 64, 3 * 64)
    assert_same_file(first, again, naming=("history", "date_created", "scene_file"))


def test_a_streamed_file_is_on_the_disk_before_it_is_renamed(tmp_path, capsys, monkeypatch):
    # the streamed temporary is flushed (fsync) after its last write and before the
    # rename onto the output, as the held file's write is: complete or absent
    events = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        events.append(("fsync", os.readlink(f"/proc/self/fd/{fd}")))
        return real_fsync(fd)

    def replace(src, dst, **kwargs):
        events.append(("replace", os.fspath(src)))
        return real_replace(src, dst, **kwargs)

    monkeypatch.setattr(checks, "STREAM_RECORD_BYTES", 0)
    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    out = tmp_path / "x.nc"
    code, _, err = run_cli(["trace", _scene_file(tmp_path), "-w", "0.98", "-o", out, "-q"], capsys)
    assert code == 0, err
    renamed = [i for i, (what, _) in enumerate(events) if what == "replace"]
    assert len(renamed) == 1, events
    temporary = events[renamed[0]][1]
    assert ("fsync", temporary) in events[: renamed[0]], events


def test_no_prediction_where_the_monodromy_jumps():
    # contact damping n = 0: the coefficient jumps where the contact opens; elsewhere the
    # monodromy is continuous and the walk predicts Newton's last iterate
    from hertzsweep.drivers.oscillator import Oscillator
    from hertzsweep.drivers.shooting import continuous_monodromy

    from .conftest import make_scene

    def oscillator(law, exponent):
        scene = make_scene(damping={"ratio": 0.01, "law": law, "exponent": exponent})
        return Oscillator(scene, 0.01)

    assert not continuous_monodromy(oscillator("contact", 0.0))
    assert continuous_monodromy(oscillator("contact", 0.5))
    assert continuous_monodromy(oscillator("viscous", 1.5))
