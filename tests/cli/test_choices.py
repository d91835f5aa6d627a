"""The CLI names its choices without importing the engine; they must be the registries'."""

from povh3d.cli.render import METHOD_NAMES, QUALITY_NAMES
from povh3d.renderer.methods.registry import METHODS
from povh3d.renderer.methods.quality import AUTO, QUALITY_LEVELS


def test_method_choices_are_the_registry():
    assert METHOD_NAMES == tuple(METHODS)


def test_quality_choices_are_the_levels_and_auto():
    assert QUALITY_NAMES == (*QUALITY_LEVELS, AUTO)
