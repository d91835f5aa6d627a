"""Options shared by several commands, and turning them into povh3d's own values.

Parsing only: numbers and pairs are checked here, everything they mean is
decided by ``povh3d.renderer`` and below.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from typing import Any, overload

from ..errors import ConfigError
from .flags import flags

_PAIR = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(?:[xX]\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*)?$")


def finite_float(text: str) -> float:
    """``type=float`` of every option: a finite number (``nan`` and ``inf`` are refused here)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"takes a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"takes a finite number, got {text!r}")
    return value


def parse_pair(text: str, option: str, *, integral: bool) -> tuple[float, float] | float:
    """``'60x40'`` -> (60, 40), ``'60'`` -> 60; a ConfigError naming the option otherwise."""
    m = _PAIR.match(text)
    example = "60x40 or 60" if integral else "8x8 or 8"
    if not m:
        raise ConfigError(f"{option} takes a number or WxH like {example}, got {text!r}")
    values = [float(g) for g in m.groups() if g is not None]
    if any(not math.isfinite(v) or v <= 0 for v in values):
        raise ConfigError(f"{option} takes positive numbers like {example}, got {text!r}")
    if integral and any(v != int(v) for v in values):
        raise ConfigError(f"{option} takes whole numbers like {example}, got {text!r}")
    if integral:
        values = [int(v) for v in values]
    return (values[0], values[1]) if len(values) == 2 else values[0]


def parse_size(text: str, option: str, form: str = "WxH like 1920x1080") -> tuple[int, int]:
    """``'1920x1080'`` -> (1920, 1080): two whole numbers, both given (a panel, a picture, a quilt grid)."""
    size = parse_pair(text, option, integral=True)
    if not isinstance(size, tuple):
        raise ConfigError(f"{option} takes {form}, got {text!r}")
    return size  # type: ignore[return-value]


def parse_numbers(text: str | None, option: str, kind: type = float) -> tuple[Any, ...] | None:
    if text is None:
        return None
    try:
        return tuple(kind(v) for v in text.split(","))
    except ValueError:
        raise ConfigError(f"{option} takes comma-separated {'whole ' if kind is int else ''}numbers, got "
                          f"{text!r}") from None


def parse_triple(text: str | None, option: str) -> tuple[float, float, float] | None:
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(abs(v) < float("inf") for v in values):
        raise ConfigError(f"{option} takes three numbers X,Y,Z, got {text!r}")
    return values


def add_array_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("display and lens array (override the preset field by field)")
    g.add_argument("--preset", default="demo", help="display preset (default: demo; see 'povh3d presets')")
    g.add_argument("--grid", choices=("square", "lenticular", "hex"))
    g.add_argument("--lenses", help="lens count, LxxLy (lenticular: Lx)")
    g.add_argument("--ppl", help="pixels per lens, NxxNy (lenticular: Nx)")
    g.add_argument("--pixel-pitch", type=float, help="pixel pitch, mm")
    g.add_argument("--focal", type=float, help="lens focal length, mm")
    g.add_argument("--rows", type=positive_int, help="panel height in pixel rows (lenticular)")
    g.add_argument("--panel", help="panel size WxH in pixels")
    g.add_argument("--lens-rotation", type=rotation_degrees, metavar="DEG",
                   help="turn the lens lattice by DEG within (-45, 45], counter-clockwise (slanted sheets)")
    g.add_argument("--lattice", metavar="A1X,A1Y;A2X,A2Y",
                   help="a lens lattice of two vectors in mm (parallelogram cells), or crossed lenticular "
                        "sheets 'cross:PITCH,SLANT_DEG' (multi-ortho only; docs/geometry.md)")


def array_overrides(args: argparse.Namespace) -> dict[str, Any]:
    """The preset fields the display options replace (``geometry.presets.FIELDS``), parsed."""
    return {
        "grid": args.grid,
        "lenses": parse_pair(args.lenses, "--lenses", integral=True) if args.lenses else None,
        "ppl": parse_pair(args.ppl, "--ppl", integral=False) if args.ppl else None,
        "pixel_pitch": args.pixel_pitch,
        "focal": args.focal,
        "rows": args.rows,
        "panel": parse_size(args.panel, "--panel") if args.panel else None,
        "lens_rotation": getattr(args, "lens_rotation", None),
        "lattice": getattr(args, "lattice", None),
    }


def display_from_args(args: argparse.Namespace, *, method: str = "multi-ortho", mapped: bool = False) -> Any:
    """The ``Display`` of the display options (``display.display.build_display``); ``mapped``:
    with the pixel mapping options (``--mapping``, ``--calibration`` ...) too."""
    from ..display.display import build_display

    mapping = {"mapping": args.mapping, "mapping_options": mapping_options(args),
               "calibration": args.calibration,
               "camera_model": getattr(args, "camera_model", None)} if mapped else {}
    return build_display(args.preset, array_overrides(args), method=method, **mapping)


def lens_array_from_args(args: argparse.Namespace) -> Any:
    """The display options' lens array (commands that need only the array)."""
    return display_from_args(args).lens_array


def progress_bar(enabled: bool, unit: str = "shots"):
    """``(update, close)``: a status line on stderr (``cli.progress``), or nothing when not `enabled`."""
    if not enabled:
        return None, lambda: None
    from .progress import StatusLine

    line = StatusLine(sys.stderr, unit)
    return line, line.close


def warn(messages: list[str]) -> None:
    yellow, reset = ("\033[33m", "\033[0m") if sys.stderr.isatty() else ("", "")
    for message in messages:
        print(f"{yellow}povh3d: warning: {flags(message)}{reset}", file=sys.stderr)


def max_triangles(text: str | None) -> int | str | None:
    if text is None or text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise ConfigError(f"--max-triangles takes a whole number or 'auto', got {text!r}") from None


def add_mesh_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("mesh models (.obj .stl .ply .off .glb .gltf .3mf)")
    shading = g.add_mutually_exclusive_group()
    shading.add_argument("--smooth", dest="shading", action="store_const", const="smooth",
                         help="smooth shading with vertex normals (default, except STL)")
    shading.add_argument("--flat", dest="shading", action="store_const", const="flat",
                         help="flat triangles (default for STL)")
    g.add_argument("--max-triangles", metavar="N|auto",
                   help="simplify to at most N triangles; auto: from the display's 3D resolution")
    p.set_defaults(shading="auto")


def add_mapping_options(p: argparse.ArgumentParser, required: bool = False) -> None:
    g = p.add_argument_group("pixel mapping (see 'povh3d map --help')")
    g.add_argument("--mapping", required=required, metavar="NAME",
                   help="alioscopy, philips, slanted, triangular, distributed, smart:N, distributed-smart:N")
    g.add_argument("--subpixels-per-lens", type=float, metavar="X", help="slanted: subpixels under one lens")
    g.add_argument("--views", type=positive_int, metavar="N", help="slanted: view count")
    g.add_argument("--slant-tan", type=float, metavar="T", help="slanted: tan a (1/3 for 18.43 deg)")
    g.add_argument("--slant-deg", type=float, metavar="DEG", help="slanted: slant angle in degrees")
    g.add_argument("--offset", type=float, default=0.0, metavar="K", help="slanted: k_off in subpixels")
    g.add_argument("--rows-per-view", type=positive_int, metavar="B", help="slanted: panel rows per view row")
    g.add_argument("--reverse-views", action="store_true", help="slanted: view N-1-v")
    g.add_argument("--blend", action="store_true", help="slanted: blend fractional views (linear light)")
    g.add_argument("--calibration", metavar="JSON", help="slanted: a Looking Glass visual.json or a 'povh3d calibrate --lattice lenticular' file; with render --method subpixel: the sheet it traces")


def mapping_options(args: argparse.Namespace) -> dict[str, Any]:
    """The pixel mapping options (``display.mappings.options_from_display``) given on the command line."""
    from ..display.mappings import slope_from_degrees

    slope = 3 * args.slant_tan if args.slant_tan is not None else (
        slope_from_degrees(args.slant_deg) if args.slant_deg is not None else None)
    return {"per_lens": args.subpixels_per_lens, "views": args.views, "slope": slope, "offset": args.offset or None,
            "rows_per_view": args.rows_per_view, "reverse": args.reverse_views or None, "blend": args.blend or None}


@overload
def ppl_arg(text: str, option: str = ..., *, lenticular: bool = ...) -> tuple[int, int]: ...
@overload
def ppl_arg(text: None, option: str = ..., *, lenticular: bool = ...) -> None: ...
def ppl_arg(text: str | None, option: str = "--ppl", *, lenticular: bool = False) -> tuple[int, int] | None:
    """``(Ny, Nx)`` from ``NxxNy`` or ``N``.  One number means what it means in ``render``:
    N x N pixels per lens, or N x 1 on a lenticular array (which has one row of views)."""
    from ..geometry.axes import from_edge

    if text is None:
        return None
    ppl = parse_pair(text, option, integral=True)
    if isinstance(ppl, tuple):  # whole numbers (integral): int() only tells the type checker
        return from_edge((int(ppl[0]), int(ppl[1])))
    return (1, int(ppl)) if lenticular else (int(ppl), int(ppl))


def add_image_lens_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--ppl", help="pixels per lens NxxNy (lenticular: Nx); default: from the sidecar")
    p.add_argument("--focal", type=float, help="focal length, mm (default: from the sidecar)")
    p.add_argument("--pixel-pitch", type=float, help="pixel pitch, mm (default: from the sidecar)")


def rotation_degrees(text: str) -> float:
    """``--lens-rotation``: degrees within (-45, 45] (the range itself is LensArray's to check)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"takes degrees within (-45, 45], got {text!r}")
    return value


def positive_int(text: str) -> int:
    """A whole number of at least 1 (``--scale``, ``--frames`` counts)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"takes a whole number of at least 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"takes a whole number of at least 1, got {text!r}")
    return value
