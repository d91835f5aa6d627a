"""povh3d: holoscopic 3D (integral imaging, light-field) images rendered with POV-Ray.

    import povh3d
    povh3d.render("scene.pov", "out.png", preset="demo", quality="draft")
    array = povh3d.presets.lens_array("demo", ppl=6)
    povh3d.render("scene.pov", "out6.png", lens_array=array)
    h3d, lens_array = povh3d.read_h3d("out.png")
    views = povh3d.extract(h3d, lens_array)                  # every command, on arrays (docs/api.md)

The names below are loaded when first used, so ``import povh3d`` (and the
``povh3d`` command's start-up) costs nothing until a render is asked for.
"""

from __future__ import annotations

import importlib

from ._version import __version__

# Not ``typing.TYPE_CHECKING``: importing typing took 7 ms of the command's start-up before
# ``povh3d.cli`` installs its signal handlers (a Ctrl-C then is Python's traceback); type checkers
# read a constant named TYPE_CHECKING as theirs.
TYPE_CHECKING = False
if TYPE_CHECKING:  # what type checkers and editors see
    from .api import (borders, calibrate, convert_mesh, equalise, extract, info, interleave, layout, map, moire,  # noqa: F401 (map: not in __all__, it would hide the builtin)
                      preview, read_h3d, refocus, replay, resample, quilt, stitch, undistort, unquilt, viewpoints)
    from .renderer.api import render
    from .display.display import Display, build_display
    from .renderer.request import ModelOptions, RenderRequest, VolumeOptions
    from .renderer.animation import FrameRange
    from .renderer.methods.quality import Quality, RenderSettings
    from .errors import ConfigError, InputError, OutputError, Povh3dError, PovrayError
    from .display import presets
    from .geometry.crop import CropSettings
    from .geometry.lens_array import LensArray, Panel

# the commands as functions on arrays (povh3d/api.py, docs/api.md)
_COMMANDS = ("read_h3d", "interleave", "extract", "map", "resample", "quilt", "unquilt", "refocus", "preview",
             "replay", "info", "moire", "calibrate", "undistort", "borders", "equalise", "viewpoints", "stitch",
             "convert_mesh", "layout")
_PUBLIC = {
    **dict.fromkeys(_COMMANDS, "povh3d.api"),
    "render": "povh3d.renderer.api",
    "RenderRequest": "povh3d.renderer.request", "ModelOptions": "povh3d.renderer.request",
    "VolumeOptions": "povh3d.renderer.request",
    "Display": "povh3d.display.display", "build_display": "povh3d.display.display",
    "FrameRange": "povh3d.renderer.animation",
    "Quality": "povh3d.renderer.methods.quality", "RenderSettings": "povh3d.renderer.methods.quality",
    "CropSettings": "povh3d.geometry.crop",
    "LensArray": "povh3d.geometry.lens_array", "Panel": "povh3d.geometry.lens_array",
    "Povh3dError": "povh3d.errors", "ConfigError": "povh3d.errors", "InputError": "povh3d.errors",
    "OutputError": "povh3d.errors", "PovrayError": "povh3d.errors",
}
_MODULES = {"presets": "povh3d.display.presets"}

__all__ = ["__version__", "render", "Display", "build_display", "RenderRequest", "ModelOptions", "VolumeOptions", "FrameRange", "Quality", "RenderSettings",
           "CropSettings", "LensArray", "Panel", "presets", "Povh3dError", "ConfigError", "InputError",
           "OutputError", "PovrayError",
           # _COMMANDS but map: a star import must not hide the builtin
           "read_h3d", "interleave", "extract", "resample", "quilt", "unquilt", "refocus", "preview", "replay", "info", "moire",
           "calibrate", "undistort", "borders", "equalise", "viewpoints", "stitch", "convert_mesh", "layout"]


def __getattr__(name: str) -> object:
    if name in _MODULES:
        return importlib.import_module(_MODULES[name])
    if name in _PUBLIC:
        return getattr(importlib.import_module(_PUBLIC[name]), name)
    raise AttributeError(f"module 'povh3d' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*__all__, *_COMMANDS})
