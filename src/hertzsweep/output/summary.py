"""What a command prints about its result: one function per dataset kind.

Each takes the driver's result and the dataset built from it, ``summary(result, ds)``,
and returns the text (lines joined by newlines; empty when there is nothing to print).
Pure: numbers in, text out.
"""

from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.lockin import first_harmonic_index, order_label

if TYPE_CHECKING:  # the results' types only
    import xarray as xr

    from ..drivers.accuracy import AccuracyReport
    from ..drivers.continuation import BranchResult

BRANCH_ENDS = {  # Branch.end -> why a branch stopped short
    "start": "it turned back and left the span where it began",
    "stalled": "the continuation stalled",
    "retraced": "it ran back onto itself past a corner of the map",
    "max-points": "too many points",
    "reconnected": "it returned to its parent's branch",
}
MAX_TABLE_ROWS = 60  # the jump table of a study is printed up to this many grid points
ROUGH_EXPONENT = 1.0  # contact damping d^n with n below this is not smooth at d = 0


def _jump_text(value: float, width: int) -> str:
    return f"{'-' if math.isnan(value) else f'{value:.4f}':>{width}s}"


# --------------------------------------------------------------------------- sweep
def sweep_summary(result: object, ds: Any) -> str:
    """A short table: per direction and sigma, the H1 peak (of the order
    :func:`~hertzsweep.core.lockin.first_harmonic_index` picks), the jump, the force
    extremes and the largest share out of contact (``ds``: a sweep dataset, a
    :class:`~hertzsweep.output.frame.Frame` or its xarray form)."""
    orders = ds["harmonic"].values
    first = first_harmonic_index(orders)
    peak_name = f"peak H{order_label(orders[first])}"
    lines = [
        f"{'direction':9s} {'sigma':>8s} {peak_name:>8s} {'at w':>7s} {'jump w':>7s} "
        f"{'N max':>6s} {'N min':>6s} {'loss':>5s}"
    ]
    w = ds["frequency_ratio"].values
    h1 = ds["amplitude"].values[..., first]
    jump = ds["jump_frequency_ratio"].values
    force_max, force_min = ds["force_max"].values, ds["force_min"].values
    loss = ds["contact_loss_fraction"].values
    for i, direction in enumerate(ds["direction"].values):
        for j, sigma in enumerate(ds["sigma"].values):
            peak = int(np.nanargmax(h1[i, j]))
            cells = (
                f"{direction:9s}",
                f"{sigma:8.4g}",
                f"{h1[i, j, peak]:8.4f}",
                f"{w[peak]:7.4f}",
                _jump_text(float(jump[i, j]), 7),
                f"{np.nanmax(force_max[i, j]):6.3f}",
                f"{np.nanmin(force_min[i, j]):6.3f}",
                f"{np.nanmax(loss[i, j]):5.2f}",
            )
            lines.append(" ".join(cells))
    return "\n".join(_subharmonic_columns(lines, ds))


SUBHARMONIC = ("subharmonic_onset_frequency_ratio", "subharmonic_end_frequency_ratio")


def _subharmonic_columns(lines: list[str], ds: Any) -> list[str]:
    """The sweep table with two more columns, the jumps onto and off the period-2
    response (``sub on``, ``sub off``; '-' for none), where any sweep has one; unchanged
    otherwise."""
    if not all(name in ds for name in SUBHARMONIC):
        return lines
    onset, end = (np.asarray(ds[name].values, dtype=float) for name in SUBHARMONIC)
    if not (np.isfinite(onset).any() or np.isfinite(end).any()):
        return lines
    out = [lines[0] + f" {'sub on':>7s} {'sub off':>7s}"]
    rows = ((i, j) for i in range(onset.shape[0]) for j in range(onset.shape[1]))
    for line, (i, j) in zip(lines[1:], rows, strict=True):
        out.append(f"{line} {_jump_text(onset[i, j], 7)} {_jump_text(end[i, j], 7)}")
    return out


# --------------------------------------------------------------------------- trace
def trace_summary(result: object, ds: Any) -> str:
    """One line per sigma: harmonics, force extremes, contact loss and flights."""
    lines = []
    value = {name: ds[name].values for name in TRACE_SUMMARY}
    for i, sigma in enumerate(ds["sigma"].values):
        harmonics = " ".join(
            f"H{order_label(k)} {a:.4f}"
            for k, a in zip(ds["harmonic"].values, value["amplitude"][i], strict=True)
        )
        count = int(value["flight_count"][i])
        flights = "no flight"
        if count:
            flights = f"{count} flight(s), longest {value['flight_time'][i] * 1e3:.3f} ms"
        state = "settled" if value["settled"][i] else "NOT settled"
        if not value["periodic"][i]:
            state += ", not periodic"
            period = int(ds["response_period"].values[i]) if "response_period" in ds else 0
            if period > 1:
                state += f": repeats every {period} periods"
        lines.append(
            f"sigma {sigma:.4g} w {ds.attrs['frequency_ratio']:.4f} {ds.attrs['branch']}: "
            f"{harmonics}  N max {value['force_max'][i]:.3f} min {value['force_min'][i]:.3f}  "
            f"loss {value['contact_loss_fraction'][i]:.3f}  {flights} ({state})"
        )
    return "\n".join(lines)


TRACE_SUMMARY = (  # the per-sigma variables of a trace's summary line
    "amplitude",
    "flight_count",
    "flight_time",
    "settled",
    "periodic",
    "force_max",
    "force_min",
    "contact_loss_fraction",
)


# --------------------------------------------------------------------------- branch
def _doubled_lines(result: BranchResult, primary: Any) -> list[str]:
    """One line per period-doubled branch of a primary's sigma (when followed): its period,
    where it started, its points and how it ended, and its own bifurcations."""
    if not result.follows_period_doubling:
        return []
    family = result.family(next(i for i, b in enumerate(result.branches) if b is primary))
    lines = []
    for index, branch in enumerate(family[1:], start=1):
        start = family[branch.parent].bifurcations[branch.parent_bifurcation].frequency_ratio
        lines.append(
            f"  branch {index}: period {branch.period_multiple} from w = {start:.6f} (branch "
            f"{branch.parent}), {branch.size} points, {int(branch.stable.sum())} stable, "
            f"ended: {BRANCH_ENDS.get(branch.end, branch.end)}"
        )
        lines += [
            f"    {found.kind:15s} w = {found.frequency_ratio:.6f}" for found in branch.bifurcations
        ]
    return lines


def branch_summary(result: BranchResult, ds: Any) -> str:
    """Per sigma: points, stable share, peak H1 and the located bifurcations; a caution
    where contact damping with n < 1 meets loss of contact."""
    lines = [
        f"branch from w = {result.start_frequency_ratio:g} to {result.end_frequency_ratio:g}; "
        f"{result.steps} integration steps"
    ]
    first = first_harmonic_index(result.harmonics)
    for branch in result.branches:
        peak = int(np.argmax(branch.amplitude[:, first]))
        state = ""
        if not branch.complete:
            state = f" (stopped short: {BRANCH_ENDS.get(branch.end, branch.end)})"
        lines.append(
            f"sigma {branch.sigma:g}: {branch.size} points, {int(branch.stable.sum())} stable, "
            f"peak H{order_label(result.harmonics[first])} {branch.amplitude[peak, first]:.4f} at "
            f"w = {branch.frequency_ratio[peak]:.4f}{state}"
        )
        if branch.bridges:
            lines.append(f"  {branch.bridges} gap(s) of the map crossed at fixed w")
        if not branch.bifurcations:
            lines.append("  no bifurcation")
        for found in branch.bifurcations:
            mu = found.multipliers[0]
            lines.append(
                f"  {found.kind:15s} w = {found.frequency_ratio:.6f}  H1 = {found.amplitude:.4f}  "
                f"multiplier {mu.real:+.6f}{mu.imag:+.6f}j"
            )
        lines += _doubled_lines(result, branch)
    law, exponent = ds.attrs.get("damping_law"), ds.attrs.get("damping_exponent", math.inf)
    rough = law == "contact" and float(exponent) < ROUGH_EXPONENT
    if rough and any(branch.contact_loss_fraction.max() > 0 for branch in result.branches):
        lines.append(
            "note: contact damping with n < 1 makes the scheme's one-period map non-smooth "
            "where the orbit loses contact; there the branch may stop short or show extra "
            "folds: check the jumps against a sweep"
        )
    return "\n".join(lines)


# --------------------------------------------------------------------------- study
def study_summary(result: object, ds: xr.Dataset) -> str:
    """For a sweep study: the jump frequency ratio per direction at every grid point
    (empty for a branch study, or beyond :data:`MAX_TABLE_ROWS` points)."""
    if ds.attrs.get("study_kind") != "sweep" or "jump_frequency_ratio" not in ds:
        return ""
    jumps = ds["jump_frequency_ratio"].transpose("direction", ...)
    grid = [d for d in jumps.dims if d != "direction"]
    points = list(itertools.product(*(range(jumps.sizes[d]) for d in grid)))
    if len(points) > MAX_TABLE_ROWS:
        return ""
    directions = "".join(f" {'jump ' + str(v):>10s}" for v in jumps.direction.values)
    lines = [" ".join(f"{d:>16s}" for d in grid) + directions]
    for point in points:
        cell = jumps.isel(dict(zip(grid, point, strict=True)))
        keys = " ".join(f"{str(cell[d].values):>16s}" for d in grid)
        lines.append(keys + "".join(f" {_jump_text(x, 10)}" for x in cell.values.tolist()))
    return "\n".join(lines)


# --------------------------------------------------------------------------- random
RANDOM_SUMMARY = (  # the per-level variables of a random run's summary line
    "force_rms",
    "force_skewness",
    "force_kurtosis",
    "contact_loss_fraction",
    "peak_frequency_ratio",
)


def random_summary(result: object, ds: Any) -> str:
    """One line per rms level: the RMS of N/F_s, its skewness and kurtosis, the share
    of the time out of contact and the frequency ratio of the PSD's peak (means over the
    realisations)."""
    value = {name: ds[name].values for name in RANDOM_SUMMARY}
    lines = []
    for i, rms in enumerate(ds["rms"].values):
        lines.append(
            f"rms {rms:.4g}: N rms {value['force_rms'][i]:.4g} "
            f"skewness {value['force_skewness'][i]:+.3f} "
            f"kurtosis {value['force_kurtosis'][i]:.3f} "
            f"loss {value['contact_loss_fraction'][i]:.4g} "
            f"peak w {value['peak_frequency_ratio'][i]:.4f}"
        )
    return "\n".join(lines)


# --------------------------------------------------------------------------- accuracy
def _number(x: float, spec: str = ".2e") -> str:
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "missed"
    return format(x, spec)


def accuracy_summary(report: AccuracyReport, ds: Any) -> str:
    """The table, the reference check, the observed order, the Pareto front and the
    recommendation."""
    lines = [
        f"{'setting':28s} {'err H1':>9s} {'err H2':>9s} {'err N':>9s} {'err jump':>8s} "
        f"{'steps':>11s} {'wall ms':>9s} {'order':>5s}  pareto"
    ]
    scene_index = report.index(report.scene_setting)
    pareto, recommended = report.pareto, report.recommended
    for i, (rung, err) in enumerate(zip(report.rungs, report.errors, strict=True)):
        mark = "*" if pareto[i] else ""
        if i == len(report.rungs) - 1:
            mark += " reference"
        if i == scene_index:
            mark += " scene"
        if i == recommended:
            mark += " recommended"
        lines.append(
            f"{rung.setting.label:28s} {_number(err.h1):>9s} {_number(err.h2):>9s} "
            f"{_number(err.force):>9s} {_number(err.jump, '.4f'):>8s} {rung.cost_steps:11d} "
            f"{1e3 * rung.wall_time:9.1f} {_number(report.orders[i], '.2f'):>5s}  {mark.strip()}"
        )
    lines += [
        "",
        "errors against the reference: H1, H2 max abs over the sweep relative to its",
        "largest H1, H2; N: force extremes in F_s; jump: |w - w_ref| (missed: one jumped)",
    ]
    ref = report.reference.setting.label
    if report.reference_error is not None:
        e = report.reference_error
        lines.append(
            f"reference {ref}: Richardson estimate of its own error "
            f"(order {report.richardson_order:g}): "
            f"H1 {_number(e.h1)}, H2 {_number(e.h2)}, N {_number(e.force)}"
            + ("" if e.jump == 0 else f", jumps differ by {_number(e.jump, '.4f')}")
        )
    if report.settle_check is not None:
        lines.append(
            f"settling check: {report.settle_check_label} differs from the reference by "
            f"H1 {_number(report.settle_check.h1)}"
        )
    order = _number(report.observed_order, ".2f")
    lines.append(f"observed order (steps axis, finest triple N, 2N, 4N): {order}")
    front = sorted(
        (r.wall_time, r.setting.label) for r, on in zip(report.rungs, pareto, strict=True) if on
    )
    lines.append(
        "Pareto front (wall time, err H1), fastest first: " + ", ".join(f[1] for f in front)
    )
    if report.target is not None:
        lines.append(_recommendation(report))
    lines += [f"note: {note}" for note in report.notes]
    return "\n".join(lines)


def _recommendation(report: AccuracyReport) -> str:
    target, recommended = report.target, report.recommended
    if recommended is None:
        return f"target {target:g} on H1: no setting of the ladder meets it; refine --steps"
    rung = report.rungs[recommended]
    err = report.errors[recommended]
    text = (
        f"target {target:g} on H1 (max abs error relative to the largest H1, against the "
        f"reference): recommended {rung.setting.label}, error {err.h1:.2e}, "
        f"{1e3 * rung.wall_time:.1f} ms"
    )
    scene_index = report.index(report.scene_setting)
    if scene_index is not None:
        scene_rung = report.rungs[scene_index]
        ratio = rung.wall_time / scene_rung.wall_time
        scene_error = report.errors[scene_index].h1
        text += (
            f" ({ratio:.2f}x the time of the scene's {scene_rung.setting.label}, whose error "
            f"is {scene_error:.2e})"
        )
    command = f"hertzsweep sweep {report.scene_arguments} {rung.setting.set_options}"
    return f"{text}\nreproduce: {command}"


__all__ = [
    "accuracy_summary",
    "branch_summary",
    "random_summary",
    "study_summary",
    "sweep_summary",
    "trace_summary",
]
