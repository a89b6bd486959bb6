"""Options shared by several commands."""

from __future__ import annotations

import click

from ..core.config import Scene, load_scene

scene_argument = click.argument("scene_file", metavar="SCENE", type=click.Path(dir_okay=False))
output_option = click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="netCDF file to write."
)
set_option = click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="TABLE.KEY=VALUE",
    help="Override a config key (TOML value syntax); repeatable.",
)
quiet_option = click.option("-q", "--quiet", is_flag=True, help="No progress bar.")


def read_scene(scene_file: str, overrides: tuple[str, ...] = ()) -> Scene:
    return load_scene(scene_file, overrides)
