"""`make paper`: the validation table's builder, the measurements behind it, the
manifest of configs/paper, the note on Figure 15's grid step, and (slow) the whole reduced
run, its figures' metadata included."""

import re

import numpy as np
import pytest
import xarray as xr
from matplotlib.image import imread
from PIL import Image

from hertzsweep.core.config import load_scene
from hertzsweep.core.kinds import KINDS
from hertzsweep.core.model import check_stability
from hertzsweep.errors import ConfigError
from hertzsweep.jobs import paper
from hertzsweep.jobs.paper import AGREE, Ours, Reported, validation_table
from hertzsweep.output.dataset import open_dataset

from .conftest import CONFIGS, run_cli

PAPER_DIR = CONFIGS / "paper"

SMALL_PAPER = {
    "f0": Reported("natural frequency f0", "232", "Hz", "eq. (15)", "the paper's rounding"),
    "z_s": Reported("static compression z_s", "7", "um", "eq. (14)", "unused"),
    "w_u": Reported("up jump", "0.984", "", "section 4.1", "experiment vs model"),
    "loss": Reported("out of contact", "40", "%", "Fig. 12", "damping fitted per figure"),
    "k": Reported("contact stiffness k", "5.98e9", "N m^-3/2", "eq. (13)", "E = 206 GPa"),
}


def _rows(table):
    """Markdown rows (header and rule excluded) as lists of stripped cells."""
    lines = table.strip().splitlines()
    assert lines[1] == "|---|---|---|---|---|---|"
    return {
        cells[0]: cells
        for cells in ([c.strip() for c in line.strip("|").split("|")] for line in lines[2:])
    }


def test_printed_precision():
    assert Reported("", "0.984", "", "", "").quantum == pytest.approx(1e-3)
    assert Reported("", "5.98e9", "", "", "").quantum == pytest.approx(1e7)
    assert Reported("", "7", "", "", "").quantum == 1.0
    assert Reported("", "0.560", "", "", "").quantum == pytest.approx(1e-3)  # trailing 0 counts


def test_validation_table_small():
    ours = {
        "f0": Ours(230.776, "E = 210 GPa"),
        "z_s": 6.884,  # a plain float is accepted
        "w_u": Ours(0.985, "up sweep", resolution=0.0025),
        "loss": Ours(0.0, "at w = 0.99"),
        # "k" not computed
    }
    rows = _rows(validation_table(ours, SMALL_PAPER))
    assert list(rows) == [r.quantity for r in SMALL_PAPER.values()]  # the paper's order
    f0 = rows["natural frequency f0"]
    # ours with one digit more than printed; difference in the unit and relative
    assert f0[1:] == [
        "232 Hz",
        "eq. (15)",
        "230.8 Hz (E = 210 GPa)",
        "-1.22 Hz (-0.5 %)",
        "the paper's rounding",
    ]
    # 6.884 rounds to the printed 7: the same number to the paper's digits
    assert rows["static compression z_s"][3] == "6.9 um"
    assert rows["static compression z_s"][5] == AGREE
    # 0.985 vs 0.984 differs in the printed digit but lies within our grid step
    assert rows["up jump"][5] == "agrees within our grid step (0.0025)"
    assert rows["up jump"][4] == "+0.001 (+0.1 %)"
    # percentages: the difference in points; the reason given where they differ
    assert rows["out of contact"][3:] == [
        "0.0 % (at w = 0.99)",
        "-40 points",
        "damping fitted per figure",
    ]
    assert rows["contact stiffness k"][3:5] == ["not computed", "n/a"]


def test_format_like_scientific():
    assert paper.format_like(6.0903e9, "5.98e9") == "6.090e9"
    assert paper.format_like(float("nan"), "232") == "n/a"
    assert paper.format_like(0.97250, "0.957") == "0.9725"


def test_refined_peak_exact_for_a_parabola():
    # the vertex of the parabola through the maximum and its neighbours: exact for one
    x = np.linspace(0.9, 1.1, 21)
    y = 1.0 - 40.0 * (x - 1.0031) ** 2
    assert paper.refined_peak(x, y) == pytest.approx(1.0031, abs=1e-12)
    # at the end of the grid the grid point itself
    assert paper.refined_peak(x, x) == pytest.approx(1.1)


def _sweep_like(w, h1, h2, loss, sigma=(0.014, 0.03, 0.07)):
    """A minimal sweep dataset (direction, sigma, frequency_ratio, harmonic): the same
    response at every level."""
    shape = (2, len(sigma), w.size)
    amp = np.broadcast_to(np.stack([h1, h2], axis=-1), shape + (2,))
    base = ("direction", "sigma", "frequency_ratio")
    return xr.Dataset(
        {
            "amplitude": (base + ("harmonic",), amp),
            "force_max": (base, 1 + amp[..., 0]),
            "force_min": (base, 1 - amp[..., 0]),
            "contact_loss_fraction": (base, np.broadcast_to(loss, shape)),
            "flight_time": (base, np.broadcast_to(loss * 1e-2, shape)),
            "jump_frequency_ratio": (("direction", "sigma"), np.tile([[0.98], [0.95]], len(sigma))),
        },
        coords={
            "direction": ["up", "down"],
            "sigma": list(sigma),
            "frequency_ratio": w,
            "harmonic": [1, 2],
        },
        attrs={"sweep_step": 0.01, "natural_frequency": 230.0},
    )


def test_peak_point_and_measurements():
    w = np.array([0.9, 0.92, 0.94, 0.96])
    h1 = np.array([0.5, 1.8, 1.2, 0.7])
    ds = _sweep_like(w, h1, 0.5 * h1, np.array([0.1, 0.65, 0.3, 0.0]))
    point = paper.peak_point(ds, 0.07)
    assert float(point.frequency_ratio) == 0.92
    constants = paper.derive(load_scene(CONFIGS / "default.toml").rig)
    ours = paper.measurements({"fig09_10": ds}, constants)
    assert ours["loss_7"].value == pytest.approx(65.0)
    assert ours["loss_1.4"].note == "at w = 0.92, down sweep"
    assert ours["h2h1_7"].value == pytest.approx(50.0)
    assert ours["flight_7"].value == pytest.approx(1e3 * 0.65e-2)
    assert ours["w_d_7"].value == 0.95 and ours["w_d_7"].resolution == 0.01
    assert ours["w_u_7"].value == 0.98
    # the runs not given leave their numbers out; the rig's are always there
    assert "f0_measured" not in ours and "w_u_1" not in ours
    assert ours["f0"].value == pytest.approx(230.78, abs=0.01)


def test_manifest_of_the_paper():
    runs = paper.read_manifest(PAPER_DIR)
    names = [run.name for run in runs]
    assert names[:2] == ["fig03", "fig04_06"]
    figures = sorted(f for run in runs for f in run.figures)
    # Figures 3-17 but 11 (the rig's measurement; Figure 15 is its computed counterpart)
    assert figures == [f"fig{n:02d}" for n in range(3, 18) if n != 11]
    for run in runs:
        if run.kind != "study":
            scene = load_scene(run.source, run.overrides)
            check_stability(scene)  # every scene is valid and within the stability limit
    quick = {run.name: run for run in paper.read_manifest(PAPER_DIR, quick=True)}
    assert "sweep.settle_periods=150" in quick["fig04_06"].overrides
    trace = quick["fig07_08"]
    assert trace.kind == "trace" and trace.frequency == "peak"
    assert load_scene(trace.source, trace.overrides).excitation.sigma == (0.01,)


def test_grid_note_on_figure_15():
    """Figure 15 of `make paper` is swept on a coarser grid than `make fig15` and the
    manual's table: validation.md says so, with both steps."""
    runs = paper.read_manifest(PAPER_DIR)
    (fig15,) = [run for run in runs if run.name == "fig15"]
    assert "sweep.step=0.005" in fig15.overrides
    coarse = xr.Dataset(attrs={"sweep_step": 0.005})
    (note,) = paper.grid_notes(runs, {"fig15": coarse})
    assert note.startswith("`fig15.png` (run `fig15`) sweeps with a frequency step of 0.005")
    assert "not the 0.0025 of its study file `fig15.toml`" in note
    assert "manual's Figure 15 table" in note
    assert paper.grid_notes(runs, {"fig15": xr.Dataset(attrs={"sweep_step": 0.0025})}) == []
    result = paper.PaperResult(grid_notes=[note])
    assert f"- {note}" in paper.validation_report(result, quick=False)


@pytest.mark.parametrize(
    "text, key",
    [
        ('[[run]]\nname = "a"\nkind = "sweep"\nscene = "s.toml"\ncolour = 1\n', "run[0].colour"),
        ('[[run]]\nname = "a"\nkind = "movie"\nscene = "s.toml"\n', "run[0].kind"),
        ('[[run]]\nname = "a"\nkind = "sweep"\nscene = "none.toml"\n', "run[0].scene"),
        (
            '[[run]]\nname = "a"\nkind = "sweep"\nscene = "s.toml"\nfigures.f = { dpi = 3 }\n',
            "run[0].figures.f",
        ),
        ('[[run]]\nname = "a"\nkind = "sweep"\nscene = "s.toml"\noverlay = "b"\n', "a.overlay"),
        (
            '[[run]]\nname = "a"\nkind = "trace"\nscene = "s.toml"\nperiods = "8"\n',
            "run[0].periods",
        ),
        (
            '[[run]]\nname = "a"\nkind = "sweep"\nscene = "s.toml"\nset = "sweep.step=0.01"\n',
            "run[0].set",
        ),
    ],
)
def test_manifest_errors_name_the_key(tmp_path, text, key):
    (tmp_path / "s.toml").write_text(
        (CONFIGS / "default.toml")
        .read_text()
        .replace('rig = "rig.toml"', f'rig = "{CONFIGS / "rig.toml"}"')
    )
    (tmp_path / "paper.toml").write_text(text)
    with pytest.raises(ConfigError) as info:
        paper.read_manifest(tmp_path)
    assert info.value.key == key


def test_missing_manifest_exit_2(tmp_path, capsys):
    code, _, err = run_cli(["paper", tmp_path, tmp_path / "out"], capsys)
    assert code == 2
    assert "paper.toml" in err and "no such file" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_manifest_kinds_are_the_registry(tmp_path):
    (tmp_path / "s.toml").write_text("")
    (tmp_path / "paper.toml").write_text('[[run]]\nname = "a"\nkind = "movie"\nscene = "s.toml"\n')
    with pytest.raises(ConfigError, match=f"expected one of {', '.join(KINDS)}, got 'movie'"):
        paper.read_manifest(tmp_path)


@pytest.mark.slow
def test_make_paper_quick(tmp_path, capsys):
    # The reduced configuration of `make paper` (every run's `quick` overrides), run as
    # `make paper` runs it: through the command line
    out = tmp_path / "paper"
    code, printed, err = run_cli(["paper", PAPER_DIR, out, "--quick"], capsys)
    assert code == 0, err
    table = (out / "validation.md").read_text()
    rows = _rows(table[table.index("| quantity") : table.index("## Runs")])
    assert list(rows) == [r.quantity for r in paper.PAPER.values()]
    number = re.compile(r"^[-+]?\d+(\.\d+)?(e\d+)?\b")
    for cells in rows.values():  # every run ran: every row has our number
        assert number.match(cells[3]), cells
    by_key = dict(zip(paper.PAPER, rows.values(), strict=True))
    assert by_key["z_s"][5] == AGREE and by_key["p0"][5] == AGREE
    f0 = float(by_key["f0"][3].split()[0])
    assert f0 == pytest.approx(230.8, abs=0.05)
    # sigma = 1 %: no loss of contact, so N_min > 0 and N_max < 2.5 (paper: 0.08, 2.3)
    assert 0 < float(by_key["n_min_1"][3].split()[0]) < 0.2
    assert 2.0 < float(by_key["n_max_1"][3].split()[0]) < 2.5
    # every figure of the manifest is drawn, a PNG of its documented size
    runs = paper.read_manifest(PAPER_DIR, quick=True)
    figures = [f for run in runs for f in run.figures]
    assert len(figures) == 14 and all(f"{f}.png from " in printed for f in figures)
    for figure in figures:
        image = imread(out / f"{figure}.png")
        assert image.shape[0] >= 350 and image.shape[1] >= 700  # the smallest: 7 x 3.5 in
    # and every run's dataset, of its kind
    for run in runs:
        paths = sorted(out.glob(f"{run.name}.nc")) or sorted(out.glob(f"{run.name}_*.nc"))
        assert paths, run.name
        assert {open_dataset(p).attrs["hertzsweep_kind"] for p in paths} == {run.kind}
    assert "validation table ->" in printed
    assert "sweeps with a frequency step of 0.01, not the 0.0025" in table
    # each figure names its dataset(s), the command and the version in its metadata
    with Image.open(out / "fig14.png") as image:
        text = dict(image.text)
    sources = text["Source"].split("; ")
    assert sources == [str((out / "fig14.nc").resolve()), str((out / "fig14_sweep.nc").resolve())]
    assert (
        f"drawn by: hertzsweep paper {PAPER_DIR.resolve()} {out.resolve()} --quick"
        in (text["Description"])
    )
    assert text["Software"].startswith("hertzsweep ")
    study = open_dataset(out / "fig15.nc")
    assert study.attrs["hertzsweep_kind"] == "study"
    assert study.attrs["sweep_step"] == 0.01  # the quick override reached the base scene
    assert {"damping_exponent", "sigma"} <= set(study.jump_frequency_ratio.dims)
    assert not (out / "fig15.nc.parts").exists()  # the parts are removed once combined
