"""The parts of a random study's ``split_realisations``: a case run as groups of its
realisations, and the groups' parts merged into the case's dataset.

A sub-case's part (``OUT.parts/<hash>.nc``) is the random dataset of its group of
realisations plus what the statistics are formed from, trajectory by trajectory
(:func:`group_variables`, on a ``realisation`` dimension; realisations
``realisation_first`` onwards of the case): the tallies, the histogram, the Welch sums (the
cross-spectrum's real and imaginary parts apart) and, for the ball model, the steps of both
contacts open. :func:`merged_part` joins the groups' sums in realisation order and forms
the statistics as one run of every realisation forms them
(:func:`hertzsweep.drivers.random.merge`): the case's dataset, bit for bit that of the
unsplit case, without these variables.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.config import Scene
from ..output.dataset import open_dataset, random_dataset, write_atomic
from ..output.frame import Frame

if TYPE_CHECKING:
    import xarray as xr

    from ..drivers.random import RandomResult, Sums

PREFIX = "realisation_"  # the part's own variables (a study's dataset has none)
TALLY = f"{PREFIX}tally"  # float[tally_field, rms, realisation]
HISTOGRAM = f"{PREFIX}histogram"  # float[force_bin, rms, realisation]
ON_REALISATIONS = ("rms", "realisation")
WELCH = ("nn", "ff", "fn_real", "fn_imag")  # float[rms, realisation, frequency_ratio] each


def group_variables(result: RandomResult) -> dict[str, Any]:
    """``{name: (dims, values, attrs)}``: the sums of a sub-case's trajectories, [..., T]
    (level outer, realisation inner) as [..., rms, realisation]."""
    sums = result.sums
    if sums is None:
        raise ValueError("a random result without its sums cannot be merged with others")
    levels = result.rms.size

    def split(values: np.ndarray) -> np.ndarray:
        return values.reshape(values.shape[:-1] + (levels, -1))

    note = {
        "comment": "a part of a study's split_realisations: realisations realisation_first "
        "onwards of the case, what the statistics are formed from"
    }
    welch = sums.welch
    spectra = {"nn": welch.nn, "ff": welch.ff, "fn_real": welch.fn.real, "fn_imag": welch.fn.imag}
    data = {
        TALLY: (("tally_field", *ON_REALISATIONS), split(sums.tally.sums), note),
        HISTOGRAM: (("force_bin", *ON_REALISATIONS), split(sums.tally.histogram), note),
        f"{PREFIX}low": (ON_REALISATIONS, split(sums.tally.low), note),
        f"{PREFIX}width": (ON_REALISATIONS, split(sums.tally.width), note),
    }
    for name, values in spectra.items():  # [T, K] -> [L, R, K]
        data[f"{PREFIX}welch_{name}"] = (
            (*ON_REALISATIONS, "frequency_ratio"),
            np.moveaxis(split(np.asarray(values).T), 0, -1),
            note,
        )
    if sums.ball_flight is not None:
        data[f"{PREFIX}ball_flight"] = (ON_REALISATIONS, split(sums.ball_flight), note)
    return data


def add_group_variables(dataset: Frame | xr.Dataset, result: RandomResult, scene: Scene) -> None:
    """Add a sub-case's sums (:func:`group_variables`) and their attributes to its dataset:
    ``realisation_first``, the Welch sums' ``realisation_welch_scale`` and
    ``realisation_steps`` (every trajectory's integration steps)."""
    for name, entry in group_variables(result).items():
        dataset[name] = entry
    sums = result.sums
    dataset.attrs.update(
        realisation_first=int(scene.random.first_realisation),
        realisation_welch_scale=float(sums.welch.scale),
        realisation_steps=int(sums.steps),
    )


def is_group_part(ds: xr.Dataset) -> bool:
    """Whether a part holds a group's sums (:func:`group_variables`)."""
    return TALLY in ds.data_vars and "realisation_welch_scale" in ds.attrs


def group_sums(ds: xr.Dataset) -> Sums:
    """The :class:`~hertzsweep.drivers.random.Sums` of a sub-case's part, [..., T] again."""
    from ..drivers.random import Sums, TraceRows, WelchSums
    from ..kernels.random import Tally

    def joined(name: str) -> np.ndarray:
        values = ds[name].values
        return np.ascontiguousarray(values.reshape(values.shape[:-2] + (-1,)))

    def rows(name: str) -> np.ndarray:  # [L, R, K] -> [T, K]
        values = ds[f"{PREFIX}welch_{name}"].values
        return np.ascontiguousarray(values.reshape((-1, values.shape[-1])))

    fn = np.empty(rows("fn_real").shape, dtype=complex)
    fn.real, fn.imag = rows("fn_real"), rows("fn_imag")
    tally = Tally(
        joined(TALLY), joined(HISTOGRAM), joined(f"{PREFIX}low"), joined(f"{PREFIX}width")
    )
    welch = WelchSums(
        rows("nn"),
        rows("ff"),
        fn,
        int(ds.attrs["welch_segments"]),
        float(ds.attrs["realisation_welch_scale"]),
    )
    empty = np.zeros((ds.sizes["rms"], 0))
    trace = TraceRows(
        ds["trace_force"].values if "trace_force" in ds else empty,
        ds["trace_forcing"].values if "trace_forcing" in ds else empty,
    )
    flight = f"{PREFIX}ball_flight"
    ball_flight = joined(flight) if flight in ds else None
    return Sums(tally, welch, trace, int(ds.attrs["realisation_steps"]), ball_flight)


def merged_part(
    scene: Scene, groups: Sequence[xr.Dataset], folder: Path, history: str | None = None
) -> xr.Dataset:
    """The dataset of a case (its ``scene``) from the parts of its groups of realisations,
    in order: what its part would hold unsplit, written and read back (in ``folder``, the
    file then removed) as a part is."""
    from ..drivers.random import merge

    complete = all(bool(ds.attrs["complete"]) for ds in groups)
    result = merge(scene, [group_sums(ds) for ds in groups], complete)
    with tempfile.TemporaryDirectory(dir=folder, prefix=".merge-") as scratch:
        path = write_atomic(random_dataset(result, scene, history), Path(scratch) / "case.nc")
        return open_dataset(path)


__all__ = ["add_group_variables", "group_sums", "group_variables", "is_group_part", "merged_part"]
