"""``povh3d replay``: an H3D image on its display, seen from an eye (commands/replay.py)."""

from __future__ import annotations

import argparse
from typing import Any

from .options import parse_size


def cmd_replay(args: argparse.Namespace) -> int:
    from ..commands.replay import parse_eye, parse_sweep, replay_file

    size: Any = "lenses" if args.size == "lenses" else parse_size(args.size, "--size", "WxH like 800x600 or 'lenses'")
    sweep = parse_sweep(args.sweep)
    record = replay_file(args.h3d, args.output, eye=parse_eye(args.eye), optics=args.optics, size=size,
                         sweep=sweep, json_path=args.json, quality=args.quality, ior=args.ior, lenslet=args.lenslet,
                         pupil=args.pupil)
    eyes = record["eyes_mm"]
    first = ",".join(f"{v:g}" for v in eyes[0])
    what = f"{len(eyes)} eyes from ({first})" if len(eyes) > 1 else f"eye ({first}) mm"
    extra = ""
    if record.get("reports"):
        r = record["reports"][0]
        if "camera_view" in r.get("aperture", {}) and not r["aperture"]["measured"]:
            extra = (f", {record['device']['device']}: every lens's aperture straddles a view boundary "
                     "(the eye is between two views)")
        elif "camera_view" in r.get("aperture", {}):  # a Looking Glass
            a, b = r["aperture"], r["aperture_7_rows"]
            extra = (f", {record['device']['device']}: the eye in view {int(a['eye_slot'])}'s slot (camera view "
                     f"{a['camera_view']}); over 7 rows each lens's views centred on its slot's on "
                     f"{100 * b['mean_view_share']:.1f} % of lenses, its commonest view that one on "
                     f"{100 * b['dominant_view_share']:.1f} %, within one view on "
                     f"{100 * a['dominant_within_one_view_share']:.1f} % (a row)")
        elif "geometric_view_share" in r:  # a mapped panel
            extra = (f", the view pointing at the eye on {100 * r['geometric_view_share']:.1f} % of lens samples "
                     f"({100 * r['within_one_view_share']:.1f} % within one view)")
            if r.get("aperture", {}).get("measured") and r["aperture_3d_pixel"]["measured"]:
                a, b = r["aperture"], r["aperture_3d_pixel"]
                extra += (f"; over each lens's aperture its commonest view the right one on "
                          f"{100 * a['dominant_view_share']:.1f} % of lenses (a row), {100 * b['dominant_view_share']:.1f} % "
                          f"({b['aperture_rows']} rows), its views centred on the right one on "
                          f"{100 * b['mean_view_share']:.1f} % ({b['aperture_rows']} rows)")
        else:
            extra = f", own lens {100 * r['own_lens_share']:.1f} %"
        if "view_zone" in r:
            zone = r["view_zone"]["every_lens_zone_mm"]
            extra += (f", every lens in zone for x in [{zone[0]:.1f}, {zone[1]:.1f}] mm" if zone
                      else ", no eye x sees every lens in zone")
        if "light_shares" in r:
            extra += f", chief pixel {100 * r['light_shares']['chief_pixel']:.0f} % of the aperture"
    if record.get("timings_s"):
        extra += f", {record['timings_s']['total_s']:.2f} s"
    print(f"{args.output}  {args.optics}, {what}{extra}")
    return 0


def add_parsers(sub: Any) -> None:
    p = sub.add_parser("replay", help="an H3D image on its display, seen from an eye (the virtual display)")
    p.add_argument("h3d", help="H3D PNG with its sidecar; or a mapped panel (alioscopy-42, philips-20), a Looking "
                   "Glass native image or quilt that povh3d render wrote")
    p.add_argument("-o", "--output", required=True,
                   help="replay .png (with --sweep: a .gif or .mp4, the frames and a viewer page .html beside it)")
    p.add_argument("--eye", metavar="X,Y,Z", help="eye in mm, display coordinates, viewer at z < 0 (default 0,0,-300; a "
                   "lenticular render: the viewing distance its rows were rendered for; a Looking Glass: its viewer "
                   "distance)")
    p.add_argument("--optics", default="pinhole", choices=("pinhole", "barrier", "lens", "none"),
                   help="pinhole mask at the lens centres (exact; default), barrier (slits, lenticular), lens "
                        "(the real lenslets, through POV-Ray; a mapped panel or Looking Glass image: its slanted lenticules over "
                        "its R, G, B stripes), none (no sheet: the panel alone)")
    p.add_argument("--size", default="lenses", metavar="lenses|WxH",
                   help="one pixel a lens (default), or a WxH perspective picture of the display's area")
    p.add_argument("--sweep", metavar="X0:X1:N", help="N eyes from x = X0 to X1 mm (y:Y0:Y1:N along y): "
                   "frames, a GIF and a viewer page")
    p.add_argument("--json", metavar="REPORT", help="write the report (per eye: the views shown, view zone) here")
    p.add_argument("--quality", default="draft", choices=("draft", "high"),
                   help="--optics lens: draft (one ray a pixel) or high (antialiased)")
    p.add_argument("--ior", type=float, help="--optics lens: the lenslets' index of refraction (default 1.49)")
    p.add_argument("--lenslet", default="spherical", choices=("spherical", "conic"),
                   help="--optics lens: the curved face, a sphere (default) or a conic (aberration-free only for a panel on its flat face)")
    p.add_argument("--pupil", type=float, metavar="MM", help="--optics lens: the eye's pupil diameter, as focal "
                   "blur focused on the lens plane (default: a pinhole eye)")
    p.set_defaults(func=cmd_replay)
