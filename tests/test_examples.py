"""The example scenes shipped in the package (:mod:`hertzsweep.core.examples`): each one
is a file that loads and passes the checks, and the checkout's configs/ links to it."""

import pytest

from hertzsweep.core.checks import load_checked_scene
from hertzsweep.core.examples import EXAMPLES, example_path
from hertzsweep.errors import HertzsweepError

from .conftest import CONFIGS


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_every_example_is_a_scene_that_passes_the_checks(name):
    path = example_path(name)
    assert path.is_file() and (path.parent / "rig.toml").is_file()
    scene, _ = load_checked_scene(path)
    assert scene.excitation.sigma


@pytest.mark.parametrize("name", ["default", "smoke", "rig"])
def test_the_checkout_scenes_are_the_packaged_ones(name):
    assert (CONFIGS / f"{name}.toml").read_bytes() == (
        example_path("default").parent / f"{name}.toml"
    ).read_bytes()


def test_an_unknown_example_is_one_line_naming_the_known_ones():
    with pytest.raises(HertzsweepError) as info:
        example_path("nope")
    assert str(info.value) == "unknown example 'nope' (known: default, smoke)"
