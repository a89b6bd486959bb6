"""The golden cases: commands whose datasets are kept in ``tests/data/golden/``.

Each case is a command line (run in-process through :func:`hertzsweep.cli.main`) and the
name of its reference file. ``python tests/golden_cases.py`` regenerates the references
(only when a change of the numbers is intended, with the reason in the CHANGELOG);
``tests/test_golden.py`` reruns every case and compares every data variable.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "golden"
DEFAULT = str(ROOT / "configs" / "default.toml")
FIG17 = str(ROOT / "configs" / "paper" / "fig17.toml")
VIBRO = [  # the vibro-impact scene on a coarser grid: sigma 7.8 %, zeta 1 %, n = 3/2
    "--set", "sweep.step=0.01", "--set", "sweep.start=0.55", "--set", "sweep.stop=0.95",
    "--set", 'sweep.directions=["up","down"]',
]  # fmt: skip

CASES: dict[str, list[str]] = {
    # the default scene (sigma 0.6 % and 1 %, viscous): H1/H2, jumps, force extremes
    "sweep-default": ["sweep", DEFAULT],
    # loss of contact and impacts, contact law n = 3/2
    "sweep-vibro": ["sweep", FIG17, *VIBRO],
    # contact laws n = 0, 1/2, 1 and a general exponent, with loss of contact
    **{
        f"sweep-contact-n{n}": [
            "sweep",
            FIG17,
            *VIBRO,
            "--set",
            f"damping.exponent={n}",
            "--set",
            "sweep.settle_periods=100",
        ]
        for n in ("0", "0.5", "1", "0.7")
    },  # fmt: skip
    # viscous law with loss of contact
    "sweep-viscous-loss": [
        "sweep",
        FIG17,
        *VIBRO,
        "--set",
        "damping.law=viscous",
        "--set",
        "sweep.settle_periods=100",
    ],  # fmt: skip
    "sweep-auto": [
        "sweep",
        DEFAULT,
        "--set",
        "sweep.settle_periods=auto",
        "--set",
        "excitation.sigma=[0.01]",
    ],  # fmt: skip
    "sweep-shooting": ["sweep", DEFAULT, "--set", "sweep.steady_state=shooting"],
    "trace-vibro": [
        "trace",
        FIG17,
        "--frequency",
        "0.58",
        *VIBRO,
        "--set",
        "sweep.settle_periods=200",
    ],  # fmt: skip
    "branch-default": ["branch", DEFAULT, "--set", "excitation.sigma=[0.01]"],
    "branch-vibro": ["branch", FIG17],
}


def run(name: str, output: Path) -> None:
    """Run case ``name`` writing its dataset to ``output``."""
    from hertzsweep.cli import main

    try:
        main([*CASES[name], "-o", str(output), "-q"])
    except SystemExit as exc:
        if exc.code not in (0, None):
            raise


if __name__ == "__main__":
    GOLDEN.mkdir(parents=True, exist_ok=True)
    for case in sys.argv[1:] or CASES:
        run(case, GOLDEN / f"{case}.nc")
        print(case, (GOLDEN / f"{case}.nc").stat().st_size, "bytes")
