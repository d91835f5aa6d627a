"""A library message names parameters (``errors.param``); the command line shows each as its flag.

The flag of a name: the explicit table below (library names no option's ``dest`` matches), else
the option spelled like the name (``lens_rotation`` -> ``--lens-rotation``), else the long option
of the ``dest`` of that name, else ``--`` and the name with dashes.
"""

from __future__ import annotations

import argparse
from typing import Any

from ..errors import raw_message, render_params

# Library parameter names (RenderRequest, LensArray, keywords) whose flag is not their dest's.
NAMES = {
    "lenses_x": "--lenses",
    "lenses_y": "--lenses",
    "lens_count": "--lenses",
    "ppl": "--ppl",
    "pixels_per_lens": "--ppl",
    "depth_maps": "--depth-maps",
    "max_error_db": "--max-error",       # RenderSettings.max_error_db
    "include_dirs": "--include",         # RenderRequest.include_dirs
    "use_cache": "--no-cache",           # RenderSettings.use_cache
    "per_lens": "--subpixels-per-lens",  # mapping_options (display.mappings.MappingOptions)
    "slope": "--slant-tan or --slant-deg",
    "placement.mode": "--placement",   # RenderRequest.placement, a PlacementOptions
    "placement.center": "--display-center",
    "placement.normal": "--display-normal",
    "placement.up": "--display-up",
    "placement.width": "--display-width",
    "placement.fit_depth": "--fit-depth",
}

_options: set[str] = set()
_dests: dict[str, str] = {}


def learn(parser: argparse.ArgumentParser, command: str | None = None) -> None:
    """Learn the options of ``parser`` (its subcommands too); those of ``command`` win a tie."""
    _options.clear()
    _dests.clear()
    own: dict[str, str] = {}
    for name, sub in _walk(parser, None):
        for action in sub._actions:
            long = [s for s in action.option_strings if s.startswith("--")]
            if not long:
                continue
            _options.update(long)
            _dests.setdefault(action.dest, long[0])
            if name == command:
                own[action.dest] = long[0]
    _dests.update(own)


def _walk(parser: argparse.ArgumentParser, name: str | None) -> Any:
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                yield from _walk(sub, sub_name)


def as_flag(name: str) -> str:
    """The command-line flag of the library parameter ``name``."""
    if name in NAMES:
        return NAMES[name]
    dashed = "--" + name.replace("_", "-")
    if dashed in _options or name not in _dests:
        return dashed
    return _dests[name]


def flags(message: str | BaseException) -> str:
    """``message`` (or an error's raw message) with its marked parameters written as flags."""
    text = raw_message(message) if isinstance(message, BaseException) else message
    return render_params(text, as_flag)
