"""``hertzsweep random``: random excitation of a scene with ``[excitation] kind = "random"``."""

from __future__ import annotations

from functools import partial

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
    from ..api.runs import partial_random, run_random

    scene = options.read_scene(scene_file, overrides)
    options.claim_output(output, scene.inputs)
    run = partial(run_random, scene, options.progress(quiet))
    options.write_or_keep(run, partial_random, scene, output)


__all__ = ["random_command"]
