"""The ``povh3d`` command line.

Every user error becomes one red line on stderr and a non-zero exit code,
never a traceback.  Progress goes to stderr, results to stdout.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from . import __version__
from .errors import ConfigError, Povh3dError, RenderInterrupted

_PAIR = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*(?:[xX]\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*)?$")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not usage + message
        _fail(f"{message} (see '{self.prog} --help')", 2)


def _fail(message: str, code: int) -> NoReturn:
    red, reset = ("\033[31m", "\033[0m") if sys.stderr.isatty() else ("", "")
    print(f"{red}povh3d: error: {message}{reset}", file=sys.stderr)
    raise SystemExit(code)


def parse_pair(text: str, option: str, *, integral: bool) -> tuple[float, float] | float:
    """``'60x40'`` -> (60, 40), ``'60'`` -> 60; a ConfigError naming the option otherwise."""
    m = _PAIR.match(text)
    example = "60x40 or 60" if integral else "8x8 or 8"
    if not m:
        raise ConfigError(f"{option} takes a number or WxH like {example}, got {text!r}")
    values = [float(g) for g in m.groups() if g is not None]
    if integral and any(v != int(v) for v in values):
        raise ConfigError(f"{option} takes whole numbers like {example}, got {text!r}")
    if integral:
        values = [int(v) for v in values]
    return tuple(values) if len(values) == 2 else values[0]


def _add_array_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("display and lens array (override the preset field by field)")
    g.add_argument("--preset", default="demo", help="display preset (default: demo; see 'povh3d presets')")
    g.add_argument("--grid", choices=("square", "lenticular", "hex"))
    g.add_argument("--lenses", help="lens count, LxxLy (lenticular: Lx)")
    g.add_argument("--ppl", help="pixels per lens, NxxNy (lenticular: Nx)")
    g.add_argument("--pixel-pitch", type=float, help="pixel pitch, mm")
    g.add_argument("--focal", type=float, help="lens focal length, mm")
    g.add_argument("--rows", type=int, help="panel height in pixel rows (lenticular)")
    g.add_argument("--panel", help="panel size WxH in pixels")


def _lens_array(args: argparse.Namespace):
    from .presets import describe_fields, get_preset, lens_array_from_fields, merge_overrides

    overrides: dict[str, Any] = {
        "grid": args.grid,
        "lenses": parse_pair(args.lenses, "--lenses", integral=True) if args.lenses else None,
        "ppl": parse_pair(args.ppl, "--ppl", integral=False) if args.ppl else None,
        "pixel_pitch": args.pixel_pitch,
        "focal": args.focal,
        "rows": args.rows,
        "panel": parse_pair(args.panel, "--panel", integral=True) if args.panel else None,
    }
    if overrides["panel"] is not None and not isinstance(overrides["panel"], tuple):
        raise ConfigError(f"--panel takes WxH like 1920x1080, got {args.panel!r}")
    fields = merge_overrides(get_preset(args.preset), overrides)
    return lens_array_from_fields(fields), {"preset": args.preset, **describe_fields(fields)}


def _progress(enabled: bool):
    if not enabled:
        return None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=0, unit="frame", file=sys.stderr, dynamic_ncols=True, leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return update, bar.close


def cmd_render(args: argparse.Namespace) -> int:
    from .api import render
    from .render import RenderSettings

    lens_array, display = _lens_array(args)
    settings = RenderSettings(quality=args.quality, jobs=args.jobs, threads=args.threads,
                              timeout=args.timeout, use_cache=not args.no_cache,
                              bit_depth=args.bit_depth, back_off=args.front_clearance)
    output = Path(args.output) if args.output else Path(Path(args.scene).stem + "-h3d.png")
    update, close = _progress(not args.quiet and sys.stderr.isatty())
    try:
        record = render(args.scene, lens_array, output, method=args.method, settings=settings,
                        views_dir=args.views_dir, include_dirs=tuple(args.include), display=display,
                        progress=update)
    finally:
        close()
    t = record["timings"]
    print(f"{output}  {lens_array.panel.width}x{lens_array.panel.height}  {args.method}  "
          f"{t['render_seconds']:.2f} s ({t['frames_from_cache']}/{t['frames']} frames from cache)")
    return 0


def cmd_interleave(args: argparse.Namespace) -> int:
    from .api import interleave_dir

    record = interleave_dir(args.views_dir, args.output)
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  from {record['views'][0]}x{record['views'][1]} views")
    return 0


def cmd_extract(args: argparse.Namespace) -> int:
    from .api import extract_file

    ppl = parse_pair(args.ppl, "--ppl", integral=True)
    nx, ny = ppl if isinstance(ppl, tuple) else (ppl, 1)
    record = extract_file(args.h3d, (ny, nx), args.output)
    print(f"{args.output}  {nx}x{ny} views of {record['view_size_px'][0]}x{record['view_size_px'][1]}")
    return 0


def cmd_presets(args: argparse.Namespace) -> int:
    from .presets import load_presets

    for name, fields in load_presets().items():
        print(f"{name:22s} {fields.get('description', '')}")
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    lens_array, display = _lens_array(args)
    info = {**display, **lens_array.describe()}
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    for key, value in info.items():
        if key == "view_angles_deg":
            value = {k: [round(a, 3) for a in v] for k, v in value.items()}
        print(f"{key:22s} {value}")
    return 0


def _add_calibration_commands(sub) -> None:
    """Capture-side processing (thesis chapter 4): calibrate, undistort, borders, equalise, viewpoints, stitch."""
    from .calibration import commands as c

    def run(fn, show):
        return lambda args: (print(show(args, fn(args))), 0)[1]

    p = sub.add_parser("calibrate", help="find the lens grid in a white image -> grid.json")
    p.add_argument("white", help="PNG of a white background taken through the lens array")
    p.add_argument("-o", "--output", required=True, help="grid file to write (.json)")
    p.add_argument("--lattice", choices=("square", "hex"), help="expected lattice (default: detect)")
    p.add_argument("--no-distortion", action="store_true", help="fit a straight lattice (no Brown terms)")
    p.set_defaults(func=run(lambda a: c.calibrate_file(a.white, a.output, lattice=a.lattice,
                                                       distortion=not a.no_distortion),
                            lambda a, g: f"{a.output}  {g.lattice}  pitch {g.pitch_px:.4f} px  rotation "
                                         f"{g.rotation_deg:.4f} deg  {int(g.inside.sum())} lenses  k1 "
                                         f"{g.distortion.k1:.3g}  residual {g.residual_px:.4f} px  "
                                         f"confidence {g.confidence:.3f}"))

    def image_cmd(name, help_text, fn, extra=()):
        p = sub.add_parser(name, help=help_text)
        p.add_argument("image", help="capture (PNG)")
        p.add_argument("--grid", required=True, help="grid.json from 'povh3d calibrate'")
        p.add_argument("-o", "--output", required=True)
        for args, kwargs in extra:
            p.add_argument(*args, **kwargs)
        p.set_defaults(func=run(fn, lambda a, r: f"{a.output}  {name}"))

    image_cmd("undistort", "remove the barrel/pincushion distortion of a capture",
              lambda a: c.undistort_file(a.image, a.grid, a.output))
    image_cmd("borders", "flat-field micro-images and clean the dark borders between them",
              lambda a: c.borders_file(a.image, a.grid, a.output, threshold=a.threshold, fill=a.fill),
              [(("--threshold",), dict(type=float, default=0.5, help="border below this fraction of a lens's peak")),
               (("--fill",), dict(choices=("black", "nearest"), default="black"))])
    image_cmd("equalise", "resample every micro-image to one size (upright, square)",
              lambda a: c.equalise_file(a.image, a.grid, a.output, size=a.size),
              [(("--size",), dict(type=int, help="pixels per micro-image side (default: the mean size)"))])
    image_cmd("viewpoints", "extract viewpoint images (pixel a, b of every micro-image) into a folder",
              lambda a: c.viewpoints_file(a.image, a.grid, a.output, ppl=a.ppl),
              [(("--ppl",), dict(type=int, required=True, help="pixels per micro-image side to sample"))])

    p = sub.add_parser("stitch", help="join two captures taken a whole number of lenses apart")
    p.add_argument("a")
    p.add_argument("b")
    p.add_argument("--grid", required=True)
    p.add_argument("-o", "--output", required=True)
    p.set_defaults(func=run(lambda a: c.stitch_files(a.a, a.b, a.grid, a.output),
                            lambda a, r: f"{a.output}  {r['size_px'][0]}x{r['size_px'][1]}  B shifted "
                                         f"{r['shift_lenses']['rows']} rows, {r['shift_lenses']['cols']} columns "
                                         f"of lenses ({r['mode']})"))


def build_parser() -> argparse.ArgumentParser:
    from .methods import METHODS
    from .render import QUALITY_OPTIONS

    parser = _Parser(prog="povh3d", description="Holoscopic 3D (integral imaging) images with POV-Ray.")
    parser.add_argument("--version", action="version", version=f"povh3d {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser("render", help="render a POV-Ray scene to an H3D image")
    p.add_argument("scene", help="POV-Ray scene without a camera (.pov)")
    p.add_argument("-o", "--output", help="H3D PNG to write (default: SCENE-h3d.png)")
    p.add_argument("--method", choices=list(METHODS), default="multi-ortho")
    p.add_argument("--quality", choices=list(QUALITY_OPTIONS), default="normal")
    p.add_argument("--jobs", type=int, help="parallel POV-Ray processes")
    p.add_argument("--threads", type=int, help="POV-Ray threads per process")
    p.add_argument("--timeout", type=float, help="seconds allowed to each POV-Ray run")
    p.add_argument("--views-dir", help="also write the view stack here (v_LLL_KKK.png)")
    p.add_argument("--no-cache", action="store_true", help="render everything again, ignore the cache")
    p.add_argument("--bit-depth", type=int, choices=(8, 16), default=8)
    p.add_argument("--front-clearance", type=float, metavar="MM",
                   help="how far in front of the screen rays start (default: 4 panel widths)")
    p.add_argument("--include", action="append", default=[], metavar="DIR", help="extra include folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    _add_array_options(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("interleave", help="interleave a folder of views into an H3D image")
    p.add_argument("views_dir")
    p.add_argument("-o", "--output", required=True)
    p.set_defaults(func=cmd_interleave)

    p = sub.add_parser("extract", help="extract the views of an H3D image")
    p.add_argument("h3d")
    p.add_argument("--ppl", required=True, help="pixels per lens NxxNy (lenticular: Nx)")
    p.add_argument("-o", "--output", required=True, help="folder for v_LLL_KKK.png")
    p.set_defaults(func=cmd_extract)

    _add_calibration_commands(sub)

    p = sub.add_parser("presets", help="list the display presets")
    p.set_defaults(func=cmd_presets)

    p = sub.add_parser("info", help="derived values of a display / lens array")
    p.add_argument("--json", action="store_true")
    _add_array_options(p)
    p.set_defaults(func=cmd_info)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        return args.func(args)
    except RenderInterrupted as exc:
        _fail(str(exc) or "interrupted; every POV-Ray process was stopped", exc.exit_code)
    except KeyboardInterrupt:
        _fail("interrupted", 130)
    except Povh3dError as exc:
        _fail(str(exc), exc.exit_code)


if __name__ == "__main__":
    sys.exit(main())
