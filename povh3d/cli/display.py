"""Commands on displays and images: ``presets``, ``info``, ``interleave``, ``extract``,
``map``, ``resample``, ``quilt``, ``refocus``, ``preview``, ``moire``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from ..errors import ConfigError, plain
from .flags import as_flag, flags
from .options import (add_array_options, add_image_lens_options, add_mapping_options, display_from_args,
                      lens_array_from_args, parse_pair, parse_size, positive_int, ppl_arg)


def cmd_interleave(args: argparse.Namespace) -> int:
    from ..renderer.outputs.views import interleave_dir

    record = interleave_dir(args.views_dir, args.output)
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  from {record['views'][0]}x{record['views'][1]} views")
    return 0


def cmd_extract(args: argparse.Namespace) -> int:
    from ..renderer.outputs.views import extract_file

    if args.ppl is None:  # the lens array from the sidecar; hex / fractional PPL resampled
        record = extract_file(args.h3d, None, args.output)
        nx, ny = record["views"]
    else:
        from ..commands.images import is_lenticular

        ny, nx = ppl_arg(args.ppl, lenticular=is_lenticular(args.h3d))
        record = extract_file(args.h3d, (ny, nx), args.output)
    print(f"{args.output}  {nx}x{ny} views of {record['view_size_px'][0]}x{record['view_size_px'][1]}")
    return 0


def _lenticular(path: str) -> bool:
    from ..commands.images import is_lenticular

    return is_lenticular(path)


def cmd_presets(args: argparse.Namespace) -> int:
    from ..display.presets import load_presets

    for name, fields in load_presets().items():
        print(f"{name:22s} {fields.get('description', '')}")
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    # A calibration (or any mapping option) counts without --mapping too, as render reads it: a device's
    # visual.json calibrates the preset's own quilt and panel image.
    display = display_from_args(args, mapped=bool(args.mapping) or _mapping_given(args))
    lens_array = display.lens_array
    info = {**display.as_record()["display"], **lens_array.as_record()}
    if display.mapping is not None:
        info.update(display.mapping.figures(display.mapped_panel))
    from ..mesh.formats import is_mesh_file
    from ..volume.sources import is_volume_source

    if args.scene and (is_mesh_file(args.scene) or is_volume_source(args.scene)):  # as the stage places it
        from ..commands.layout import content_report

        info["content"] = content_report(args.scene, lens_array)
    elif args.scene:  # where the display sits in this scene, its depth against the budget
        from ..renderer.placement.place import scene_report

        info["scene"] = scene_report(args.scene, lens_array)
    if args.json:
        print(json.dumps(plain(info, as_flag), indent=2))
        return 0
    for key, value in info.items():
        if key in ("scene", "content"):
            continue
        if key == "view_angles_deg":
            value = {k: [round(a, 3) for a in v] for k, v in value.items()}
        print(flags(f"{key:22s} {value}"))
    if "scene" in info:
        _print_scene(info["scene"])
    if "content" in info:
        _print_content(info["content"])
    return 0


def _mapping_given(args: argparse.Namespace) -> bool:
    """Whether a pixel mapping option other than ``--mapping`` is on the command line."""
    return (args.calibration is not None or args.reverse_views or args.blend or bool(args.offset)
            or any(getattr(args, name) is not None
                   for name in ("subpixels_per_lens", "views", "slant_tan", "slant_deg", "rows_per_view")))


def _print_content(report: dict) -> None:
    print(f"{report['kind']:22s} {report['content']}")
    fit = report.get("fit") or {}
    if "size_mm" in fit:
        w, h, d = fit["size_mm"]
        print(f"{'placed size':22s} {w:.3g} x {h:.3g} x {d:.3g} mm (set by the display's {fit['limit']})")
    d, half = report["depth"], report["depth_budget_mm"] / 2
    if not d.get("points"):
        print(f"{'content depth':22s} nothing to measure")
        return
    verdict = "within" if d["outside"] == 0 else f"{100 * d['outside']:.0f} % BEYOND"
    print(f"{'content depth':22s} z = {d['near_mm']:.3g} .. {d['far_mm']:.3g} mm; {verdict} the depth budget "
          f"+-{half:.3g} mm")


def _print_scene(report: dict) -> None:
    from .render import placement_phrase

    print(f"{'scene':22s} {report['scene']}")
    print(flags(f"{'placement':22s} {placement_phrase({**report['placement'], 'depth': None})}"))
    d, half = report["depth"], report["depth_budget_mm"] / 2
    if d.get("empty"):
        print(f"{'scene depth':22s} nothing hit in the middle of the framed field")
        return
    if "reason" in d:   # blind or too bright: why, and the fix
        print(flags(f"{'scene depth':22s} {d['reason']}"))
        return
    verdict = "within" if d["within_budget"] else "BEYOND"
    print(f"{'scene depth':22s} subject z = {d['near_mm']:.3g} .. {d['far_mm']:.3g} mm, whole field "
          f"{d['field_near_mm']:.3g} .. {d['field_far_mm']:.3g} mm; {verdict} the depth budget +-{half:.3g} mm")


def cmd_map(args: argparse.Namespace) -> int:
    from ..commands.images import map_file

    from ..display.display import is_visual, read_calibration

    display = display_from_args(args, mapped=True)
    mapping = display.mapping
    panel = parse_size(args.panel_size, "--panel-size") if args.panel_size else None
    if args.calibration and is_visual(read_calibration(args.calibration)):  # the file's screen is the panel
        calibrated = display.image_size
        if panel is not None and tuple(panel) != calibrated:
            raise ConfigError(f"--panel-size {panel[0]}x{panel[1]} is not the calibration's {calibrated[0]}x"
                              f"{calibrated[1]} screen; drop --panel-size")
        panel = calibrated
    record = map_file(args.input, mapping, args.output, panel)
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  {mapping.name}")
    return 0


def cmd_resample(args: argparse.Namespace) -> int:
    from ..commands.images import is_lenticular, lens_info, lens_record
    from ..commands.resample import needs_panel_resample, resample_file, resample_panel_file
    from ..geometry.axes import from_edge

    lenticular = is_lenticular(args.input)
    out = parse_pair(args.ppl_out, "--ppl-out", integral=False)
    ppl_out = from_edge(out) if isinstance(out, tuple) else ((1.0, out) if lenticular else (out, out))
    side = lens_record(args.input)
    if needs_panel_resample(side, ppl_out):  # hex, fractional PPL: each new pixel's ray on the same panel
        lens_info(args.input, ppl_arg(args.ppl, lenticular=lenticular), None, None, resampled=True)
        record = resample_panel_file(args.input, args.output, ppl_out, args.mode)
    else:
        info = lens_info(args.input, ppl_arg(args.ppl, lenticular=lenticular), None, None)
        if not all(float(v).is_integer() for v in ppl_out):
            raise ConfigError(f"--ppl-out {args.ppl_out} is not whole pixels per lens, which needs the input's lens "
                              "array from its sidecar; give whole numbers, or resample a render with its sidecar")
        whole = ppl_arg(args.ppl_out, "--ppl-out", lenticular=lenticular or info["ppl"][0] == 1)
        record = resample_file(args.input, args.output, info["ppl"], whole, args.mode)
    print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  {args.mode}")
    return 0


def cmd_quilt(args: argparse.Namespace) -> int:
    from ..commands.quilt import export_quilt, import_quilt

    auto = args.quilt == "auto"
    grid = parse_size(args.quilt, "--quilt", "COLSxROWS like 8x6, or auto") if args.quilt and not auto else None
    if args.import_quilt:
        record = import_quilt(args.input, args.output, grid, args.views)
        print(f"{args.output}  {record['size_px'][0]}x{record['size_px'][1]}  from {record['views'][0]} views")
        return 0
    if grid is None and not auto:
        raise ConfigError("give the quilt grid with --quilt COLSxROWS, e.g. --quilt 8x6, or --quilt auto")
    ppl = ppl_arg(args.ppl, lenticular=True)
    out = export_quilt(args.input, args.output, grid or "auto", ppl=ppl, aspect=args.aspect, rows=args.rows)
    print(out)
    return 0


def cmd_refocus(args: argparse.Namespace) -> int:
    from ..commands.images import lens_info, refocus_file

    info = lens_info(args.input, ppl_arg(args.ppl, lenticular=_lenticular(args.input)), args.focal,
                     args.pixel_pitch, resampled=True)
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
    from ..commands.images import lens_info, preview_file

    info = lens_info(args.input, ppl_arg(args.ppl, lenticular=_lenticular(args.input)), args.focal,
                     args.pixel_pitch, resampled=True)
    preview_file(args.input, args.output, info, frames=args.frames, scale=args.scale)
    print(f"{args.output}  {args.frames} frames, contact sheet {Path(args.output).with_suffix('.png')}")
    return 0


def cmd_dataset(args: argparse.Namespace) -> int:
    from ..renderer.outputs.dataset import dataset_from_render

    written = dataset_from_render(args.h3d, args.output, all_views=args.all_views)
    cams = sum(1 for p in written if p.name.startswith("input_Cam"))
    print(f"{args.output}  HCI layout: {cams} cameras, {len(written)} files")
    return 0


def cmd_moire(args: argparse.Namespace) -> int:
    from ..commands.moire import moire_sweep_file, parse_range

    slants = parse_range(args.slant_range)
    lens_array = lens_array_from_args(args)
    m = moire_sweep_file(lens_array, slants, args.output, distance=args.distance, turn=args.turn,
                         blur=args.blur, spot=args.spot)
    best = min(range(len(slants)), key=lambda n: m["row_contrast"][n])
    print(f"{args.output}  {len(slants)} slants; row moire contrast {m['row_contrast'][0]:.3f} at "
          f"{slants[0]:g} deg, least {m['row_contrast'][best]:.3f} at {slants[best]:g} deg")
    return 0


def add_parsers(sub: Any) -> None:
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

    p = sub.add_parser("presets", help="list the display presets")
    p.set_defaults(func=cmd_presets)

    p = sub.add_parser("info", help="derived values of a display / lens array")
    p.add_argument("scene", nargs="?", metavar="SOURCE", help="also: where the display sits in this scene, or "
                   "how a mesh model or a volume is placed, and its depth against the display's depth budget")
    p.add_argument("--json", action="store_true")
    add_array_options(p)
    add_mapping_options(p)
    p.set_defaults(func=cmd_info)
    p = sub.add_parser("map", help="map an unmapped view-space H3D image onto a display's subpixels")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True, help="panel PNG to write")
    p.add_argument("--panel-size", metavar="WxH", help="panel size (default: the one the image fits)")
    add_array_options(p)
    add_mapping_options(p, required=True)
    p.set_defaults(func=cmd_map)

    p = sub.add_parser("resample", help="resample every micro-image (thesis appendix C)")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--ppl", help="pixels per lens of the input (default: from the sidecar)")
    p.add_argument("--ppl-out", required=True, help="pixels per lens of the output (from a sidecar's hex or "
                   "fractional array, or to a fractional one: the same lenses on the same panel)")
    p.add_argument("--mode", choices=("micro", "lenses"), default="micro",
                   help="micro: resize micro-images; lenses: fewer pixels per lens, more lenses")
    p.set_defaults(func=cmd_resample)

    p = sub.add_parser("quilt", help="export the views of an H3D image as a quilt, or import one")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True, help="export: folder; import: H3D PNG")
    p.add_argument("--quilt", metavar="COLSxROWS", help="grid, e.g. 8x6, or auto (a Looking Glass preset's "
                   "own layout, else the most square); import: default from the name")
    p.add_argument("--rows", choices=("centre", "all"), help="export from a square or hex image: the middle "
                   "row of views, or every row")
    p.add_argument("--import", dest="import_quilt", action="store_true", help="quilt -> H3D image")
    p.add_argument("--ppl", help="pixels per lens (default: from the sidecar)")
    p.add_argument("--views", type=positive_int, help="import: how many tiles hold views (default: all)")
    p.add_argument("--aspect", type=float, help="export: view aspect for the name "
                   "(default: the view's physical width / height, from the sidecar)")
    p.set_defaults(func=cmd_quilt)

    p = sub.add_parser("refocus", help="refocus an H3D image at a depth (shift-and-sum over views)")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--depth", type=float, metavar="MM", help="depth of the focal plane (> 0 behind the screen)")
    p.add_argument("--sweep", type=positive_int, metavar="N",
                   help="N planes from --near to --far, with a contact sheet")
    p.add_argument("--near", type=float, metavar="MM")
    p.add_argument("--far", type=float, metavar="MM")
    add_image_lens_options(p)
    p.set_defaults(func=cmd_refocus)

    p = sub.add_parser("preview", help="what a viewer sees across the viewing angle (GIF + contact sheet)")
    p.add_argument("input")
    p.add_argument("-o", "--output", required=True, help="preview .gif (the contact sheet goes beside it as .png)")
    p.add_argument("--frames", type=positive_int, default=12)
    p.add_argument("--scale", type=positive_int, help="enlarge each lens to this many pixels")
    add_image_lens_options(p)
    p.set_defaults(func=cmd_preview)

    p = sub.add_parser("dataset", help="an H3D render (with its sidecar) as an HCI 4D light-field dataset")
    p.add_argument("h3d")
    p.add_argument("-o", "--output", required=True, help="folder for input_CamNNN.png, parameters.cfg, *.pfm")
    p.add_argument("--all-views", action="store_true", help="disparity and depth for every camera")
    p.set_defaults(func=cmd_dataset)

    p = sub.add_parser("moire", help="moire of a cross-lenticular sheet against its slant (plot + sidecar)")
    p.add_argument("-o", "--output", required=True, help="plot .png (its sidecar holds the numbers)")
    p.add_argument("--slant-range", default="0:20:0.25", metavar="START:STOP:STEP", help="degrees")
    p.add_argument("--distance", type=float, default=500.0, help="viewer distance, mm (default 500)")
    p.add_argument("--turn", action="store_true", help="turn the whole pair instead of the horizontal sheet")
    p.add_argument("--blur", type=float, default=1.5, help="eye's low-pass, in lens pitches (default 1.5)")
    p.add_argument("--spot", type=float, default=0.0, help="panel area each lens averages, mm (default 0)")
    add_array_options(p)
    p.set_defaults(func=cmd_moire, preset="cross-lenticular-ipad")
