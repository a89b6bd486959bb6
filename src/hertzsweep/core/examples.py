"""The example scenes shipped inside the package (``hertzsweep/examples/``), so that an
installed copy without the source tree runs them: the checkout's ``configs/default.toml``,
``configs/smoke.toml`` and ``configs/rig.toml`` are links to these files. A scene names its
rig as ``rig = "rig.toml"``, beside it."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from ..errors import HertzsweepError

EXAMPLES = {  # name -> what it runs: the scenes a user may ask for by name
    "default": "the paper's Figures 4 and 5: sigma = 0.6 % and 1 %, up and down sweeps",
    "smoke": "the default scene on a reduced grid around the jumps: a few seconds",
}


def example_path(name: str) -> Path:
    """The file of an example scene.

    Parameters
    ----------
    name : str
        A key of :data:`EXAMPLES`, e.g. ``"default"``.

    Returns
    -------
    pathlib.Path
        The scene file inside the installed package (its rig file beside it), to pass to
        :func:`hertzsweep.core.config.load_scene` like any scene file.

    Raises
    ------
    HertzsweepError
        ``name`` is not an example, or the package is not installed as files on disk
        (imported from a zip archive).
    """
    if name not in EXAMPLES:
        raise HertzsweepError(f"unknown example {name!r} (known: {', '.join(EXAMPLES)})")
    resource = files("hertzsweep") / "examples" / f"{name}.toml"
    if not isinstance(resource, Path) or not resource.is_file():
        raise HertzsweepError(f"example {name!r}: no scene file {resource} in the package")
    return resource
