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
    from .crop import CropSettings, parse_bbox
    from .render import RenderSettings

    lens_array, display = _lens_array(args)
    mapping = mapped_panel = None
    if args.mapping:  # render exactly the views the mapping reads, then map them
        mapping, panel = _mapping(args, lens_array, display)
        mapped_panel = (panel.width, panel.height)
        lens_array = mapping.render_array(panel, lens_array.focal)
        display = {**display, "mapping": mapping.name}
    settings = RenderSettings(quality=args.quality, jobs=args.jobs, threads=args.threads,
                              timeout=args.timeout, use_cache=not args.no_cache,
                              bit_depth=args.bit_depth, back_off=args.front_clearance,
                              scheduler=args.scheduler, max_error_db=args.max_error)
    crop = CropSettings(args.crop, parse_bbox(args.bbox) if args.bbox else None)
    output = Path(args.output) if args.output else Path(Path(args.scene).stem + "-h3d.png")
    if args.frames is not None:
        return _render_animation(args, lens_array, display, settings, output)
    for option in ("video", "clock"):
        if getattr(args, option) is not None:
            raise ConfigError(f"--{option} needs --frames FIRST:LAST")
    update, close = _progress(not args.quiet and sys.stderr.isatty())
    try:
        from .mesh import is_mesh_file

        common = dict(method=args.method, settings=settings, views_dir=args.views_dir,
                      include_dirs=tuple(args.include), display=display, progress=update, mapping=mapping,
                      mapped_panel=mapped_panel, crop=crop, **_method_options(args))
        if is_mesh_file(args.scene):  # a model, not a scene: convert it and put it on the default stage
            from .api import render_model

            record = render_model(args.scene, lens_array, output, depth=args.depth, shading=args.shading,
                                  max_triangles=_max_triangles(args.max_triangles), **common)
            _warn(record["model"]["warnings"])
        else:
            record = render(args.scene, lens_array, output, **common)
    finally:
        close()
    t = record["timings"]
    size = mapped_panel or (lens_array.panel.width, lens_array.panel.height)
    print(f"{output}  {size[0]}x{size[1]}  {args.method}{'  ' + mapping.name if mapping else ''}  "
          f"{t['render_seconds']:.2f} s ({t['frames_from_cache']}/{t['frames']} frames from cache)")
    return 0


def _render_animation(args: argparse.Namespace, lens_array: Any, display: dict[str, Any],
                      settings: Any, output: Path) -> int:
    from .animation import FrameRange, parse_clock, parse_frames, render_animation

    if args.views_dir is not None:
        raise ConfigError("--views-dir cannot be combined with --frames; render one frame for its views")
    first, last = parse_frames(args.frames)
    clock = parse_clock(args.clock) if args.clock is not None else (0.0, 1.0)
    frames = FrameRange(first, last, *clock)
    update, close = _progress(not args.quiet and sys.stderr.isatty())
    try:
        report = render_animation(args.scene, lens_array, output, frames, method=args.method,
                                  settings=settings, include_dirs=tuple(args.include),
                                  display=display, progress=update, video=args.video, fps=args.fps)
    finally:
        close()
    names = report["frames"]
    print(f"{names[0]} .. {names[-1]}  {len(names)} frames  {report['rendered']} rendered, "
          f"{report['from_cache']} from cache, {report['copied']} copies (scene {'reads' if report['scene_uses_clock'] else 'ignores'} "
          f"the clock)  {report['seconds']:.2f} s")
    if report["video"]:
        print(report["video"])
    return 0


def _method_options(args: argparse.Namespace) -> dict[str, Any]:
    """--lenslet / --ior, for the methods that take them (single-stage)."""
    options = {"lenslet": args.lenslet, "ior": args.ior}
    if args.method != "single-stage":
        given = [f"--{k}" for k, v in options.items() if v is not None]
        if given:
            raise ConfigError(f"{' and '.join(given)} only apply to --method single-stage")
        return {}
    return options


def _warn(messages: list[str]) -> None:
    yellow, reset = ("\033[33m", "\033[0m") if sys.stderr.isatty() else ("", "")
    for message in messages:
        print(f"{yellow}povh3d: warning: {message}{reset}", file=sys.stderr)


def _max_triangles(text: str | None) -> int | str | None:
    if text is None or text == "auto":
        return text
    try:
        return int(text)
    except ValueError:
        raise ConfigError(f"--max-triangles takes a whole number or 'auto', got {text!r}") from None


def cmd_convert_mesh(args: argparse.Namespace) -> int:
    from .mesh import convert_mesh

    max_triangles = _max_triangles(args.max_triangles)
    if max_triangles == "auto":
        from .mesh.simplify import auto_budget

        max_triangles = auto_budget(_lens_array(args)[0])
    result = convert_mesh(args.model, args.output, name=args.name, unit=args.unit, shading=args.shading,
                          fit_depth=args.fit_depth, center=args.center, max_triangles=max_triangles)
    _warn(result.warnings)
    line = f"{result.include}  {result.ident}  {result.summary()}  {result.seconds:.2f} s"
    if result.simplification:
        s = result.simplification
        line += (f"  (simplified from {s['triangles_before']} triangles; "
                 f"silhouette error {100 * s['silhouette_error']:.3f} %)")
    print(line)
    return 0


def _add_mesh_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("mesh models (.obj .stl .ply .off .glb .gltf .3mf)")
    shading = g.add_mutually_exclusive_group()
    shading.add_argument("--smooth", dest="shading", action="store_const", const="smooth",
                         help="smooth shading with vertex normals (default, except STL)")
    shading.add_argument("--flat", dest="shading", action="store_const", const="flat",
                         help="flat triangles (default for STL)")
    g.add_argument("--max-triangles", metavar="N|auto",
                   help="simplify to at most N triangles; auto: from the display's 3D resolution")
    p.set_defaults(shading="auto")


def cmd_interleave(args: argparse.Namespace) -> int:
    from .api import interleave_dir

    record = interleave_dir(args.views_dir, args.output)
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  from {record['views'][0]}x{record['views'][1]} views")
    return 0


def cmd_extract(args: argparse.Namespace) -> int:
    from .api import extract_file

    if args.ppl is None:  # the lens array from the sidecar; hex / fractional PPL resampled
        record = extract_file(args.h3d, None, args.output)
        nx, ny = record["views"]
    else:
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
    if args.mapping:
        mapping, panel = _mapping(args, lens_array, display)
        info.update(mapping.figures(panel))
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    for key, value in info.items():
        if key == "view_angles_deg":
            value = {k: [round(a, 3) for a in v] for k, v in value.items()}
        print(f"{key:22s} {value}")
    return 0


def _add_mapping_options(p: argparse.ArgumentParser, required: bool = False) -> None:
    g = p.add_argument_group("pixel mapping (see 'povh3d map --help')")
    g.add_argument("--mapping", required=required, metavar="NAME",
                   help="alioscopy, philips, slanted, triangular, distributed, smart:N, distributed-smart:N")
    g.add_argument("--subpixels-per-lens", type=float, metavar="X", help="slanted: subpixels under one lens")
    g.add_argument("--views", type=int, metavar="N", help="slanted: view count")
    g.add_argument("--slant-tan", type=float, metavar="T", help="slanted: tan a (1/3 for 18.43 deg)")
    g.add_argument("--slant-deg", type=float, metavar="DEG", help="slanted: slant angle in degrees")
    g.add_argument("--offset", type=float, default=0.0, metavar="K", help="slanted: k_off in subpixels")
    g.add_argument("--rows-per-view", type=int, metavar="B", help="slanted: panel rows per view row")
    g.add_argument("--reverse-views", action="store_true", help="slanted: view N-1-v")
    g.add_argument("--blend", action="store_true", help="slanted: blend fractional views (linear light)")
    g.add_argument("--calibration", metavar="JSON", help="slanted: Looking Glass calibration (visual.json)")


def _mapping(args: argparse.Namespace, lens_array, display):
    from .display import mapping_for_display
    from .mappings import slope_from_degrees

    slope = 3 * args.slant_tan if args.slant_tan is not None else (
        slope_from_degrees(args.slant_deg) if args.slant_deg is not None else None)
    return mapping_for_display(args.mapping, display, lens_array, calibration_path=args.calibration,
                               per_lens=args.subpixels_per_lens, views=args.views, slope=slope,
                               offset=args.offset or None, rows_per_view=args.rows_per_view,
                               reverse=args.reverse_views or None, blend=args.blend or None)


def _ppl_arg(text: str | None, option: str = "--ppl") -> tuple[int, int] | None:
    if text is None:
        return None
    ppl = parse_pair(text, option, integral=True)
    return (ppl[1], ppl[0]) if isinstance(ppl, tuple) else (1, ppl)


def _image_lens_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--ppl", help="pixels per lens NxxNy (lenticular: Nx); default: from the sidecar")
    p.add_argument("--focal", type=float, help="focal length, mm (default: from the sidecar)")
    p.add_argument("--pixel-pitch", type=float, help="pixel pitch, mm (default: from the sidecar)")


def cmd_map(args: argparse.Namespace) -> int:
    from .display import map_file

    lens_array, display = _lens_array(args)
    mapping, _ = _mapping(args, lens_array, display)
    panel = parse_pair(args.panel_size, "--panel-size", integral=True) if args.panel_size else None
    if panel is not None and not isinstance(panel, tuple):
        raise ConfigError(f"--panel-size takes WxH like 1920x1080, got {args.panel_size!r}")
    record = map_file(args.input, mapping, args.output, panel)
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  {mapping.name}")
    return 0


def cmd_resample(args: argparse.Namespace) -> int:
    from .display import lens_info, resample_file

    info = lens_info(args.input, _ppl_arg(args.ppl), None, None)
    ppl_out = _ppl_arg(args.ppl_out, "--ppl-out")
    if info["ppl"][0] == 1 and ppl_out[0] == 1:
        pass
    elif len(str(args.ppl_out).lower().split("x")) == 1:
        ppl_out = (ppl_out[1], ppl_out[1])  # an omnidirectional image: N means NxN
    record = resample_file(args.input, args.output, info["ppl"], ppl_out, args.mode)
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  {args.mode}")
    return 0


def cmd_quilt(args: argparse.Namespace) -> int:
    from .display import export_quilt, import_quilt, lens_info

    grid = parse_pair(args.quilt, "--quilt", integral=True) if args.quilt else None
    if grid is not None and not isinstance(grid, tuple):
        raise ConfigError(f"--quilt takes COLSxROWS like 8x6, got {args.quilt!r}")
    if args.import_quilt:
        record = import_quilt(args.input, args.output, grid, args.views)
        print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  from {record['views'][0]} views")
        return 0
    if grid is None:
        raise ConfigError("give the quilt grid with --quilt COLSxROWS, e.g. --quilt 8x6")
    ppl = lens_info(args.input, _ppl_arg(args.ppl), None, None)["ppl"]
    if ppl[0] != 1:
        raise ConfigError("a quilt holds one row of views: use a lenticular (horizontal-only) H3D image")
    out = export_quilt(args.input, ppl[1], grid, args.output, args.aspect)
    print(out)
    return 0


def cmd_refocus(args: argparse.Namespace) -> int:
    from .display import lens_info, refocus_file

    info = lens_info(args.input, _ppl_arg(args.ppl), args.focal, args.pixel_pitch)
    if (args.depth is None) == (args.sweep is None):
        raise ConfigError("give one of --depth MM or --sweep N")
    sweep = None
    if args.sweep is not None:
        f = info["focal"] or 1.0
        sweep = (args.near if args.near is not None else -10 * f, args.far if args.far is not None else 10 * f,
                 args.sweep)
    record = refocus_file(args.input, args.output, info, depth=args.depth, sweep=sweep)
    extra = f"  sharpest at {record['sharpest_depth_mm']:.3g} mm" if "sharpest_depth_mm" in record else ""
    print(f"{args.output}  {len(record['depths_mm'])} plane(s){extra}")
    return 0


def cmd_preview(args: argparse.Namespace) -> int:
    from .display import lens_info, preview_file

    info = lens_info(args.input, _ppl_arg(args.ppl), args.focal, args.pixel_pitch)
    preview_file(args.input, args.output, info, frames=args.frames, scale=args.scale)
    print(f"{args.output}  {args.frames} frames, contact sheet {Path(args.output).with_suffix('.png')}")
    return 0


def _add_display_commands(sub) -> None:
    p = sub.add_parser("map", help="map an unmapped view-space H3D image onto a display's subpixels")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True, help="panel PNG to write")
    p.add_argument("--panel-size", metavar="WxH", help="panel size (default: the one the image fits)")
    _add_array_options(p)
    _add_mapping_options(p, required=True)
    p.set_defaults(func=cmd_map)

    p = sub.add_parser("resample", help="resample every micro-image (thesis appendix C)")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--ppl", help="pixels per lens of the input (default: from the sidecar)")
    p.add_argument("--ppl-out", required=True, help="pixels per lens of the output")
    p.add_argument("--mode", choices=("micro", "lenses"), default="micro",
                   help="micro: resize micro-images; lenses: fewer pixels per lens, more lenses")
    p.set_defaults(func=cmd_resample)

    p = sub.add_parser("quilt", help="export the views of an H3D image as a quilt, or import one")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True, help="export: folder; import: H3D PNG")
    p.add_argument("--quilt", metavar="COLSxROWS", help="grid, e.g. 8x6 (import: default from the name)")
    p.add_argument("--import", dest="import_quilt", action="store_true", help="quilt -> H3D image")
    p.add_argument("--ppl", help="pixels per lens (default: from the sidecar)")
    p.add_argument("--views", type=int, help="import: how many tiles hold views (default: all)")
    p.add_argument("--aspect", type=float, help="export: view aspect for the name (default: tile w/h)")
    p.set_defaults(func=cmd_quilt)

    p = sub.add_parser("refocus", help="refocus an H3D image at a depth (shift-and-sum over views)")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--depth", type=float, metavar="MM", help="depth of the focal plane (> 0 behind the screen)")
    p.add_argument("--sweep", type=int, metavar="N", help="N planes from --near to --far, with a contact sheet")
    p.add_argument("--near", type=float, metavar="MM")
    p.add_argument("--far", type=float, metavar="MM")
    _image_lens_options(p)
    p.set_defaults(func=cmd_refocus)

    p = sub.add_parser("preview", help="what a viewer sees across the viewing angle (GIF + contact sheet)")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True, help="preview .gif (the contact sheet goes beside it as .png)")
    p.add_argument("--frames", type=int, default=12)
    p.add_argument("--scale", type=int, help="enlarge each lens to this many pixels")
    _image_lens_options(p)
    p.set_defaults(func=cmd_preview)


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


def cmd_bench(args: argparse.Namespace) -> int:
    from .quality_bench import default_trials, format_table, run_bench, write_report
    from .scene import load_scene

    lens_array, _ = _lens_array(args)
    scene = load_scene(args.scene, tuple(args.include))
    trials = default_trials(args.methods.split(","))
    update, close = _progress(not args.quiet and sys.stderr.isatty())
    try:
        report = run_bench(scene, lens_array, trials, reference_samples=args.reference_samples,
                           on_trial=(lambda done, total, what: update(done, total)) if update else None)
    finally:
        close()
    paths = write_report(report, args.output)
    print(format_table(report))
    print(f"\n{paths['csv']}  {paths['table']}  {paths['plot']}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    from .methods import METHODS
    from .render import QUALITY_OPTIONS

    parser = _Parser(prog="povh3d", description="Holoscopic 3D (integral imaging) images with POV-Ray.")
    parser.add_argument("--version", action="version", version=f"povh3d {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)

    p = sub.add_parser("render", help="render a POV-Ray scene to an H3D image")
    p.add_argument("scene", help="POV-Ray scene without a camera (.pov), or a mesh model (.obj .stl .ply ...)")
    p.add_argument("-o", "--output", help="H3D PNG to write (default: SCENE-h3d.png)")
    p.add_argument("--method", choices=list(METHODS), default="multi-ortho")
    p.add_argument("--quality", choices=[*QUALITY_OPTIONS, "auto"], default="normal",
                   help="draft: one ray per pixel; normal: antialiased; high: 256 footprint samples, "
                   "converged; auto: the fastest that meets --max-error (see 'povh3d bench')")
    p.add_argument("--max-error", type=float, metavar="DB",
                   help="with --quality auto: the lowest PSNR against a converged reference to accept")
    p.add_argument("--jobs", type=int, help="parallel POV-Ray processes")
    p.add_argument("--threads", type=int, help="POV-Ray threads per process")
    p.add_argument("--timeout", type=float, help="seconds allowed to each POV-Ray run")
    p.add_argument("--views-dir", help="also write the view stack here (v_LLL_KKK.png)")
    p.add_argument("--no-cache", action="store_true", help="render everything again, ignore the cache")
    p.add_argument("--bit-depth", type=int, choices=(8, 16), default=8)
    p.add_argument("--front-clearance", type=float, metavar="MM",
                   help="how far in front of the screen rays start (default: 4 panel widths)")
    p.add_argument("--include", action="append", default=[], metavar="DIR", help="extra include folder")
    p.add_argument("--crop", choices=("auto", "off", "measure"), default="auto",
                   help="trace each view only where objects can be (multi-ortho): auto = from --bbox, "
                        "measure = find it with a pre-pass, off = trace everything")
    p.add_argument("--bbox", metavar="X0,Y0,Z0,X1,Y1,Z1",
                   help="a box (mm) that holds every object of the scene, for --crop auto")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    g = p.add_argument_group("animation and cluster")
    g.add_argument("--frames", metavar="FIRST:LAST",
                   help="render frames FIRST..LAST as OUT_nnnn.png (POV-Ray's +KFI/+KFF)")
    g.add_argument("--clock", metavar="START:END",
                   help="clock at the first and last frame (POV-Ray's +KI/+KF; default 0:1)")
    g.add_argument("--video", metavar="FILE", help="also assemble the frames into FILE (.mp4 or .gif)")
    g.add_argument("--fps", type=float, default=24.0, help="video frames per second (default 24)")
    g.add_argument("--scheduler", metavar="tcp://HOST:8786",
                   help="render on this Dask cluster instead of local processes")
    p.add_argument("--lenslet", choices=("spherical", "conic"),
                   help="single-stage lenslet surface (default: conic, aberration-free)")
    p.add_argument("--ior", type=float, help="single-stage lenslet index of refraction; the radius "
                   "follows from the lens-maker equation (default: an optically thin lens)")


    p.add_argument("--depth", type=float, metavar="MM",
                   help="a model's depth on the display (default: the depth budget the lens array shows sharply)")
    _add_mesh_options(p)
    _add_array_options(p)
    _add_mapping_options(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("convert-mesh", help="convert a mesh model to a POV-Ray mesh2 include")
    p.add_argument("model", help="model file: .obj .stl .ply .off .glb .gltf .3mf")
    p.add_argument("-o", "--output", help="include to write (default: MODEL.inc beside the model)")
    p.add_argument("--name", help="identifier to declare (default: from the file name)")
    p.add_argument("--unit", choices=("mm", "cm", "m", "in"),
                   help="the model's unit (default: the file's, else mm; glTF: m)")
    p.add_argument("--fit-depth", type=float, metavar="MM", help="scale the model to this depth (z extent)")
    p.add_argument("--center", action="store_true", help="centre the model's bounding box on the origin")
    _add_mesh_options(p)
    _add_array_options(p)  # only for --max-triangles auto
    p.set_defaults(func=cmd_convert_mesh)

    p = sub.add_parser("bench", help="run time against error of every method and quality setting")
    p.add_argument("scene", help="POV-Ray scene without a camera (.pov)")
    p.add_argument("-o", "--output", default="bench", help="folder for bench.csv, bench.md, bench.png")
    p.add_argument("--methods", default="multi-ortho,pinhole",
                   help="comma-separated methods to bench, e.g. multi-ortho,pinhole,single-stage:conic,"
                   "single-stage:spherical (default: multi-ortho,pinhole)")
    p.add_argument("--reference-samples", type=int, default=256, metavar="N",
                   help="footprint samples per pixel of the reference (default 256)")
    p.add_argument("--include", action="append", default=[], metavar="DIR", help="extra include folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    _add_array_options(p)
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("interleave", help="interleave a folder of views into an H3D image")
    p.add_argument("views_dir")
    p.add_argument("-o", "--output", required=True)
    p.set_defaults(func=cmd_interleave)

    p = sub.add_parser("extract", help="extract the views of an H3D image")
    p.add_argument("h3d")
    p.add_argument("--ppl", help="pixels per lens NxxNy (lenticular: Nx); default: the lens array "
                   "in the image's sidecar (hex and fractional PPL are resampled lens by lens)")
    p.add_argument("-o", "--output", required=True, help="folder for v_LLL_KKK.png")
    p.set_defaults(func=cmd_extract)

    _add_calibration_commands(sub)

    p = sub.add_parser("presets", help="list the display presets")
    p.set_defaults(func=cmd_presets)

    p = sub.add_parser("info", help="derived values of a display / lens array")
    p.add_argument("--json", action="store_true")
    _add_array_options(p)
    _add_mapping_options(p)
    p.set_defaults(func=cmd_info)
    _add_display_commands(sub)
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
