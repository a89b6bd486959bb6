"""``hertzsweep random``: random excitation of a scene with ``[excitation] kind = "random"``."""

from __future__ import annotations

from ..errors import Interrupted
from . import options
from .group import cli


@cli.command("random")
@options.scene_argument
@options.output_option
@options.set_option
@options.quiet_option
def random_command(scene_file: str, output: str, overrides: tuple[str, ...], quiet: bool) -> None:
    """Random excitation (Gaussian, band-limited, [excitation] kind = "random") at every
    rms level, its realisations in lockstep: the PSD of N/F_s, the FRF estimate and
    coherence, moments, PDF, extremes and contact-loss figures, each with its standard
    error across realisations; prints one line per level."""
    from ..api.runs import run_random

    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, scene.inputs)
    try:
        run = run_random(scene, options.progress(quiet))
    except Interrupted as exc:
        keep_partial(exc, scene, output)
        raise
    options.write_run(run, output)


def keep_partial(exc: Interrupted, scene, output: str) -> None:
    """Write the statistics of the segments an interrupted run finished to
    ``OUT.partial.nc`` (attribute ``complete = 0``); the output itself stays absent."""
    from ..api.runs import partial_random

    kept = partial_random(exc, scene)
    if kept is None:
        return
    ds, segments = kept
    held = f"{segments} finished segment(s) of every realisation"
    options.keep_partial(ds, scene, output, "the finished segments", held)


__all__ = ["random_command"]
