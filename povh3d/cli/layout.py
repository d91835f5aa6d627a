"""``povh3d layout``: a picture of the set-up (content, screen, depth budget, lens array,
viewing cone) to check before a long render; parsing only, the work is ``commands.layout``'s."""

from __future__ import annotations

import argparse
from typing import Any

from .options import add_array_options, display_from_args, parse_numbers, parse_size, parse_triple
from .render import add_placement_options, placement_options_from_args
from .volume import add_volume_source_options



def cmd_layout(args: argparse.Namespace) -> int:
    from ..commands.layout import layout

    display = display_from_args(args)
    size = parse_size(args.size, "--size", "WxH pixels like 1200x900")
    spacing = parse_triple(args.spacing, "--spacing")
    rotate = parse_triple(args.rotate, "--rotate")
    model: dict[str, Any] = {"depth": args.depth, "up": args.up, "rotate": rotate, "unit": args.unit}
    volume: dict[str, Any] = {"orientation": args.orientation, "rotate": rotate, "depth": args.depth,
                              "spacing": spacing, "series": args.series, "iso": parse_numbers(args.iso, "--iso")}
    record = layout(args.source, args.output, display.lens_array, display=display,
                    placement=placement_options_from_args(args),
                    include_dirs=tuple(args.include), model=model, volume=volume, size=size,
                    use_cache=not args.no_cache)
    depth = record["content_depth"]
    reach = (f"content z {depth['near_mm']:+.3g}..{depth['far_mm']:+.3g} mm, {100 * depth['outside']:.0f} % "
             f"outside" if depth.get("points") else "content: nothing seen")
    budget = record["setup"]["depth_budget_mm"]
    t = record["timings"]
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  {record['content']['kind']}  "
          f"depth budget +-{budget / 2:.3g} mm  {reach}  {t['content_seconds'] + t['picture_seconds']:.2f} s")
    return 0


def add_parsers(sub: Any) -> None:
    p = sub.add_parser("layout", help="draw the set-up (content, screen, depth budget, lens array, viewing "
                       "cone) to check before rendering")
    p.add_argument("source", help="a POV-Ray scene (.pov), a mesh model (.obj .stl .ply ...) or a volume "
                   "(.vti .vtk .nrrd .mha .nii .npy, a DICOM folder)")
    p.add_argument("-o", "--output", required=True, help="the picture to write (.png, with a .json of its numbers)")
    p.add_argument("--size", default="1200x900", metavar="WxH", help="picture size in pixels (default 1200x900)")
    p.add_argument("--include", action="append", default=[], metavar="DIR", help="extra include folder (scenes)")
    p.add_argument("--no-cache", action="store_true", help="measure the scene again, ignore the cache")
    add_placement_options(p)
    g = p.add_argument_group("models and volumes (as 'povh3d render')")
    g.add_argument("--depth", type=float, metavar="MM", help="the content's depth on the display")
    g.add_argument("--up", choices=("x", "y", "z", "-x", "-y", "-z"), help="a model's up axis")
    g.add_argument("--rotate", metavar="X,Y,Z", help="then turn it by these angles (degrees, as POV-Ray's rotate)")
    g.add_argument("--unit", choices=("mm", "cm", "m", "in"), help="a model's unit")
    add_volume_source_options(g)
    add_array_options(p)
    p.set_defaults(func=cmd_layout)
