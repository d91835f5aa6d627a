"""``povh3d viewer`` and ``povh3d annotate``: parsing only, the work is ``commands.viewer``'s and
``commands.annotate``'s."""

from __future__ import annotations

import argparse
from typing import Any

_RENDER_HELP = ("an H3D image with its sidecar (.json), a views folder (render --views-dir) or an "
                "animation's frames (OUT.png for OUT_0000.png ...)")


def cmd_viewer(args: argparse.Namespace) -> int:
    from ..commands.viewer import write_viewer

    cdp = None
    if args.cdp:
        from ..commands.annotate import read_cdp_text

        cdp = read_cdp_text(args.cdp)
    record = write_viewer(args.render, args.output, fps=args.fps, cdp=cdp, title=args.title, objects=args.objects,
                          reads=(args.cdp,) if args.cdp else ())
    print(f"{record['output']}  {record['frames']} frame(s)  {record['views'][0]}x{record['views'][1]} views of "
          f"{record['view_size_px'][0]}x{record['view_size_px'][1]}  {record['bytes'] / 1e6:.2f} MB")
    return 0


def cmd_annotate(args: argparse.Namespace) -> int:
    from ..commands.annotate import annotate

    record = annotate(args.render, args.objects, args.output, links=args.links)
    print(f"{record['output']}  {record['objects']} object(s)  {record['annotations']} annotation(s)  "
          f"frames {record['frames'][0]}..{record['frames'][1]}")
    return 0


def add_parsers(sub: Any) -> None:
    p = sub.add_parser("viewer", help="write a render's views as one HTML page that follows the mouse "
                       "(no server needed)")
    p.add_argument("render", help=_RENDER_HELP)
    p.add_argument("-o", "--output", required=True, help="the page to write (.html)")
    p.add_argument("--fps", type=float, default=12.0, help="frames per second of an animation (default 12)")
    p.add_argument("--cdp", metavar="FILE", help="a 3DCDP header (povh3d annotate) to hyperlink the objects")
    p.add_argument("--objects", metavar="DIR", help="the object masks (render --objects DIR): each view's own "
                   "boxes (else the header's centre-view boxes in every view)")
    p.add_argument("--title", help="the page's title")
    p.set_defaults(func=cmd_viewer)

    p = sub.add_parser("annotate", help="write the 3DCDP header (XML) of a render's objects: their boxes "
                       "per frame, merged, with links")
    p.add_argument("render", help=_RENDER_HELP)
    p.add_argument("--objects", required=True, metavar="DIR", help="the object masks (render --objects DIR)")
    p.add_argument("-o", "--output", required=True, help="the header to write (.xml)")
    p.add_argument("--links", metavar="FILE", help="object name -> url and description (.toml or .json)")
    p.set_defaults(func=cmd_annotate)
