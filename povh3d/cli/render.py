"""``povh3d render``, ``convert-mesh`` and ``bench``: parse the options, build the
request, hand it to ``povh3d.renderer``, print one summary line."""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from pathlib import Path
from typing import Any

from ..errors import ConfigError
from .flags import flags
from .volume import add_volume_options, volume_options_from_args
from .options import (add_array_options, add_mapping_options, add_mesh_options, display_from_args, finite_float,
                      lens_array_from_args, max_triangles, parse_triple, positive_int, progress_bar, warn)

METHOD_NAMES = ("multi-ortho", "multi-ortho-views", "pinhole", "single-stage", "subpixel")
QUALITY_NAMES = ("draft", "normal", "high", "auto")
#: The display options ``povh3d bench`` hands on to the ``povh3d render`` commands it times.
ARRAY_OPTIONS = ("--preset", "--grid", "--lenses", "--ppl", "--pixel-pitch", "--focal", "--rows", "--panel",
                 "--lens-rotation", "--lattice")


def request_from_args(args: argparse.Namespace) -> Any:
    """The ``RenderRequest`` the options of ``povh3d render`` describe."""
    from ..renderer.animation import FrameRange, parse_clock, parse_frames
    from ..renderer.request import ModelOptions, RenderRequest
    from ..renderer.request import RenderSettings
    from ..geometry.crop import CropSettings, parse_bbox

    method = args.method or "multi-ortho"   # None: not chosen, the render may trade it (renderer/placement/ray_state.py)
    display = display_from_args(args, method=method, mapped=True)
    settings = RenderSettings(quality=args.quality, jobs=args.jobs, threads=args.threads,
                              timeout=args.timeout, use_cache=not args.no_cache,
                              bit_depth=args.bit_depth, front_clearance=args.front_clearance,
                              scheduler=args.scheduler, max_error_db=args.max_error)
    frames = None
    if args.frames is not None:
        clock = parse_clock(args.clock) if args.clock is not None else (0.0, 1.0)
        frames = FrameRange(*parse_frames(args.frames), *clock)
    elif args.clock is not None:
        raise ConfigError("--clock needs --frames FIRST:LAST")
    return RenderRequest(
        source=Path(args.scene), display=display, output=output_path(args),
        method=method, method_chosen=args.method is not None, method_options=_method_options(args), settings=settings,
        crop=CropSettings(args.crop, parse_bbox(args.bbox) if args.bbox else None),
        include_dirs=tuple(Path(d) for d in args.include),
        views_dir=Path(args.views_dir) if args.views_dir else None,
        model=ModelOptions(args.depth, args.shading, max_triangles(args.max_triangles), args.up,
                           parse_triple(args.rotate, "--rotate"), args.unit),
        frames=frames, video=Path(args.video) if args.video else None, fps=args.fps,
        placement=placement_options_from_args(args),
        depth_maps=Path(args.depth_maps) if args.depth_maps else None, depth_format=args.depth_format,
        volume=volume_options_from_args(args, parse_triple(args.rotate, "--rotate")),
        dataset=Path(args.dataset) if args.dataset else None, dataset_all_views=args.dataset_all_views,
        objects=Path(args.objects) if args.objects else None, viewing_distance=args.viewing_distance)


def viewing_distance(text: str) -> float:
    """``--viewing-distance``: mm, or ``inf`` (orthographic rows)."""
    if text.strip().lower() in ("inf", "infinity"):
        return math.inf
    try:
        return finite_float(text)
    except argparse.ArgumentTypeError:   # its own words: inf is a distance here
        raise argparse.ArgumentTypeError(f"takes a distance in mm or inf, got {text!r}") from None


def placement_options_from_args(args: argparse.Namespace) -> Any:
    """``PlacementOptions`` from --placement and the explicit --display-* options."""
    from ..renderer.placement.pose import PlacementOptions

    fit = args.fit_depth
    if fit is not None and fit != "auto":
        try:
            fit = float(fit)
        except ValueError:
            raise ConfigError(f"--fit-depth takes 'auto' or a number of mm, got {fit!r}") from None
    scale = args.depth_scale
    if scale not in (None, "fit"):
        try:
            scale = float(scale)
        except ValueError:
            raise ConfigError(f"--depth-scale takes a factor (e.g. 0.5) or nothing, got {scale!r}") from None
    return PlacementOptions(args.placement, parse_triple(args.display_center, "--display-center"),
                        parse_triple(args.display_normal, "--display-normal"),
                        parse_triple(args.display_up, "--display-up"),
                        args.display_width, fit, scale, bool(getattr(args, "depth_report", False)))


def _method_options(args: argparse.Namespace) -> dict[str, Any]:
    """--lenslet / --ior, for the methods that take them (single-stage)."""
    options = {"lenslet": args.lenslet, "ior": args.ior}
    if args.method != "single-stage":
        given = [f"--{k}" for k, v in options.items() if v is not None]
        if given:
            raise ConfigError(f"{' and '.join(given)} only apply to --method single-stage")
        return {}
    return options


def output_path(args: argparse.Namespace) -> Path:
    """-o, or SCENE-h3d.png in the current folder."""
    return Path(args.output) if args.output else Path(Path(args.scene).stem + "-h3d.png")


def cmd_render(args: argparse.Namespace) -> int:
    from ..renderer import output_cache

    output = output_path(args)
    options = {k: v for k, v in vars(args).items() if k not in ("scene", "include", "output")}
    key = output_cache.request_key(args.scene, output, options, args.include)
    if key is not None:
        from ..image.io import check_output

        check_output(output, (args.scene,))   # a hit writes too: never over the scene or the user's NAME.json
        start = time.perf_counter()
        hit = output_cache.answer(key, output)
        if hit is not None:
            warn(list(hit.warnings))
            print(f"{output}  {hit.summary}  {time.perf_counter() - start:.2f} s (output from cache)")
            return 0
    from ..renderer.probe import probe_povray_early, stop_povray_probe

    if not args.scheduler:
        probe_povray_early()
    try:
        with output_cache.warnings_kept() as given:
            summary = _render(args)
    finally:
        stop_povray_probe()
    # A scene edited while it rendered: the image is of neither version's key.
    if key is not None and summary is not None and \
            output_cache.request_key(args.scene, output, options, args.include) == key:
        output_cache.keep(key, output, summary, given)
    return 0


def _render(args: argparse.Namespace) -> str | None:
    """Render and print the summary line (the warnings came as the render gave them); for a still,
    return what follows the output name in that line."""
    from ..renderer.run import run_request as render

    request = request_from_args(args)
    update, close = progress_bar(not args.quiet and sys.stderr.isatty())
    try:
        result: dict[str, Any] = render(request, update)   # the still's sidecar or the animation's report, as JSON
    finally:
        close()
    if request.objects is not None:   # renderer.render wrote them after the colour pass
        masks = result["object_masks"]
        print(f"{masks['folder']}  {masks['objects']} objects  {100 * masks['unresolved']:.2f} % of pixels "
              "unresolved")
    if request.frames is not None:
        names = result["frames"]
        print(f"{names[0]} .. {names[-1]}  {len(names)} frames  {result['rendered']} rendered, "
              f"{result['from_cache']} from cache, {result['copied']} copies (scene "
              f"{'reads' if result['scene_uses_clock'] else 'ignores'} the clock)  {result['seconds']:.2f} s")
        if result["video"]:
            print(result["video"])
        return None
    placed = result.get("placement", {})   # its warnings came through the one channel (renderer.render)
    t = result["timings"]
    w, h = request.image_size
    mapping = f"  {request.display.mapping.name}" if request.display.mapping else ""
    if "model" in result:
        mapping += f"  up {result['model']['up']} ({result['model']['up_reason']})"
    if "volume" in result:
        v = result["volume"]
        drawn = f"{len(v['surfaces'])} surfaces, {v['triangles']} triangles" if "surfaces" in v else "media"
        mapping += f"  {v['orientation']}, {drawn}"
    method = result.get("method", request.method)
    if (result.get("camera_model") or {}).get("camera_model") == "perspective":
        method = "the vendor's perspective cameras"
    if result.get("method_note"):   # the default traded for one that renders the scene right
        method += f" (not the default {request.method}: {result.get('method_fallback', 'see the sidecar')})"
    summary = flags(f"{w}x{h}  {method}{mapping}  {placement_phrase(placed)}  {clearance_phrase(result)}")
    seconds = t.get("total_seconds", t["render_seconds"])   # the camera and depth runs included
    print(f"{request.output}  {summary}  "
          f"{seconds:.2f} s ({t['shots_from_cache']}/{t['shots']} shots from cache)")
    return summary


_REASON_END = re.compile(r" \(|;|:")


def clearance_phrase(record: dict[str, Any]) -> str:
    """Where the rays start, and why when it is not the method's plain default."""
    q = record.get("quality", {})
    if "front_clearance_mm" not in q:
        return ""
    reason = q.get("front_clearance_reason", "")
    short = _REASON_END.split(reason)[0]   # its first words: the sidecar has the rest
    why = "" if reason == "the method's default" or not reason else f" ({short})"
    return f"rays from {q['front_clearance_mm']:.4g} mm{why}"


def placement_phrase(record: dict[str, Any]) -> str:
    """The placement in a few words: where it came from, its centre and scale."""
    source = record.get("source", "native")
    if source == "native" and record.get("units_per_mm", 1.0) == 1.0:
        text = "placement native (mm, z = 0)"
    elif source == "matrix":
        text = "placement matrix"
    else:
        centre = ",".join(f"{v:.4g}" for v in record["centre"])
        text = f"placement {source} (centre {centre}, {record['units_per_mm']:.4g} units/mm)"
    depth = record.get("depth")
    if depth and "near_mm" in depth:
        fit = f", fitted x{depth['fit']['factor']:.3g}" if depth.get("fit") else ""
        if record.get("depth_scale", 1) != 1:   # fitted by it, or given
            fit = f", {'fitted: ' if fit else ''}depth x{record['depth_scale']:.3g} (distorted)"
        text += (f"  depth {depth['near_mm']:.3g}..{depth['far_mm']:.3g} mm of +-"
                 f"{record['depth_budget_mm'] / 2:.3g}{fit}")
    return text


def cmd_convert_mesh(args: argparse.Namespace) -> int:
    from ..renderer.content.convert_mesh import convert_mesh

    budget = max_triangles(args.max_triangles)
    if isinstance(budget, str):  # 'auto', the one word max_triangles returns
        from ..mesh.simplify import auto_budget

        budget = auto_budget(lens_array_from_args(args))
    update, close = progress_bar(not args.quiet and sys.stderr.isatty(), "steps")
    try:
        result = convert_mesh(args.model, args.output, name=args.name, unit=args.unit, shading=args.shading,
                              fit_depth=args.fit_depth, center=args.center, max_triangles=budget, up=args.up,
                              rotate=parse_triple(args.rotate, "--rotate"), progress=update)
    finally:
        close()
    line = f"{result.include}  {result.ident}  {result.summary()}, up {result.up} ({result.up_reason})  " \
           f"{result.seconds:.2f} s"
    if result.simplification:
        s = result.simplification
        line += (f"  (simplified from {s['triangles_before']} triangles; "
                 f"silhouette error {100 * s['silhouette_error']:.3f} %)")
    print(flags(line))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from ..commands.bench import default_trials, format_table, run_bench, write_report
    from ..scene.scene import load_scene

    lens_array = lens_array_from_args(args)
    scene = load_scene(args.scene, tuple(args.include))
    trials = default_trials(lens_array, args.methods.split(","))
    # The trials are whole commands: the scene and the display options as given here.
    scene_args = [str(Path(args.scene).resolve()), *(a for d in args.include for a in ("--include", d))]
    for option in ARRAY_OPTIONS:
        value = getattr(args, option.lstrip("-").replace("-", "_"), None)
        if value is not None:
            scene_args += [option, str(value)]
    update, close = progress_bar(not args.quiet and sys.stderr.isatty(), "trials")
    try:
        report = run_bench(scene, lens_array, trials, scene_args=scene_args, reference_samples=args.reference_samples,
                           on_trial=(lambda done, total, what: update(done, total)) if update else None)
    finally:
        close()
    paths = write_report(report, args.output)
    print(format_table(report))
    print(f"\n{paths['csv']}  {paths['table']}  {paths['plot']}")
    return 0


def _add_orientation(p: argparse.ArgumentParser) -> None:
    p.add_argument("--up", choices=("x", "y", "z", "-x", "-y", "-z"),
                   help="the model's up axis (default: the format's: y for glTF and OBJ, z for 3MF; STL, PLY, "
                   "OFF: z when the model stands on z = 0, else y); the front then faces the viewer")
    p.add_argument("--rotate", metavar="X,Y,Z", help="then turn the model by these angles (degrees, as POV-Ray's rotate)")


def add_parsers(sub: Any) -> None:
    p = sub.add_parser("render", help="render a POV-Ray scene to an H3D image")
    p.add_argument("scene", help="POV-Ray scene (.pov; its camera places the display), a mesh model (.obj .stl .ply ...), "
                   "or a volume (.vti .nii .nrrd .mha ..., a DICOM folder)")
    p.add_argument("-o", "--output", help="H3D PNG to write (default: SCENE-h3d.png)")
    p.add_argument("--method", choices=METHOD_NAMES, default=None,
                   help="default multi-ortho (or multi-ortho-views where its mesh camera would render the scene wrong)")
    p.add_argument("--quality", default="normal", metavar="{draft,normal,high,auto,N}",
                   help="draft: one ray per pixel; normal: antialiased; high: 256 footprint samples, "
                   "converged; N: N footprint samples per pixel; auto: the fastest that meets --max-error "
                   "(see 'povh3d bench')")
    p.add_argument("--max-error", type=float, metavar="DB",
                   help="with --quality auto: the lowest PSNR against a converged reference to accept")
    p.add_argument("--jobs", type=positive_int, help="parallel POV-Ray processes")
    p.add_argument("--threads", type=positive_int, help="POV-Ray threads per process")
    p.add_argument("--timeout", type=float, help="seconds allowed to each POV-Ray run")
    p.add_argument("--views-dir", help="also write the view stack here (v_LLL_KKK.png)")
    p.add_argument("--objects", metavar="DIR", help="also write per view the id of the object each pixel's "
                   "ray first hits, and their names (docs/viewer.md); one more POV-Ray pass")
    p.add_argument("--depth-maps", metavar="DIR", help="also write per view the distance along each ray to the "
                   "first surface (d_LLL_KKK.npy, mm) and its disparity (p_LLL_KKK.npy, lenses per view step)")
    p.add_argument("--dataset", metavar="DIR", help="also write the HCI 4D light-field layout here (input_CamNNN.png, "
                   "parameters.cfg, gt_disp_lowres.pfm, gt_depth_lowres.pfm; odd view counts)")
    p.add_argument("--dataset-all-views", action="store_true", help="with --dataset: disparity and depth for "
                   "every camera, not only the centre one")
    p.add_argument("--depth-format", choices=("npy", "png"), default="npy",
                   help="depth maps as float32 .npy (default) or 16-bit PNG (scale and offset in depth_maps.json)")
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
    g = p.add_argument_group("single-stage")
    g.add_argument("--lenslet", choices=("spherical", "conic"),
                   help="single-stage lenslet surface (default: conic, aberration-free)")
    g.add_argument("--ior", type=float, help="single-stage lenslet index of refraction; the radius "
                   "follows from the lens-maker equation (default: an optically thin lens)")
    p.add_argument("--depth", type=float, metavar="MM",
                   help="a model's depth on the display (default: as deep as filling the panel makes it; "
                   "a warning says when that passes the depth budget)")
    _add_orientation(p)
    p.add_argument("--unit", choices=("mm", "cm", "m", "in"),
                   help="a model's unit (default: the file's); the stage scales the model to the panel anyway")
    add_placement_options(p)
    add_volume_options(p)
    add_mesh_options(p)
    add_array_options(p)
    add_mapping_options(p)
    p.add_argument("--camera-model", choices=("perspective", "orthographic"), default=None,
                   help="a Looking Glass preset's views: the vendor's sheared perspective cameras (default) or "
                        "the lens array's oblique orthographic views (docs/displays.md)")
    p.add_argument("--viewing-distance", type=viewing_distance, default=None, metavar="MM",
                   help="a lenticular panel's rows rendered as an eye MM in front of the screen, at its centre's "
                        "height, sees them (default: the preset's design distance; a custom array: none, "
                        "orthographic rows; inf: orthographic) (docs/geometry.md)")
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("convert-mesh", help="convert a mesh model to a POV-Ray mesh2 include")
    p.add_argument("model", help="model file: .obj .stl .ply .off .glb .gltf .3mf")
    p.add_argument("-o", "--output", help="include to write (default: MODEL.inc beside the model)")
    p.add_argument("--name", help="identifier to declare (default: from the file name)")
    p.add_argument("--unit", choices=("mm", "cm", "m", "in"),
                   help="the model's unit (default: the file's, else mm; glTF: m)")
    p.add_argument("--fit-depth", type=float, metavar="MM", help="scale the model to this depth (z extent)")
    p.add_argument("--center", action="store_true", help="centre the model's bounding box on the origin")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    _add_orientation(p)
    add_mesh_options(p)
    add_array_options(p)  # only for --max-triangles auto
    p.set_defaults(func=cmd_convert_mesh)

    p = sub.add_parser("bench", help="run time against error of every method and quality setting")
    p.add_argument("scene", help="POV-Ray scene without a camera (.pov)")
    p.add_argument("-o", "--output", default="bench", help="folder for bench.csv, bench.md, bench.png")
    p.add_argument("--methods", default="multi-ortho",
                   help="comma-separated methods to bench, e.g. multi-ortho,pinhole,single-stage:conic,"
                   "single-stage:spherical (default: multi-ortho; pinhole traces a shot per lens, "
                   "over a minute a level on the demo panel)")
    p.add_argument("--reference-samples", type=positive_int, default=512, metavar="N",
                   help="footprint samples per pixel of the reference, drawn twice for its noise floor "
                   "(default 512)")
    p.add_argument("--include", action="append", default=[], metavar="DIR", help="extra include folder")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    add_array_options(p)
    p.set_defaults(func=cmd_bench)


class _OldPlacementFlag(argparse.Action):
    """``--display-frame``, the name of ``--placement`` before issue 36: still taken, with a warning."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        warn([f"--display-frame is deprecated; use --placement {values}"])
        setattr(namespace, self.dest, values)


def add_placement_options(p: argparse.ArgumentParser) -> None:
    """Where the display sits in the scene (render and layout alike)."""
    g = p.add_argument_group("placement (where the display sits in the scene)")
    g.add_argument("--placement", choices=("auto", "camera", "native"), default="auto",
                   help="camera: the scene's camera places the display (look_at on the screen, its field "
                   "across the panel); native: the scene is in mm around the screen z = 0; auto (default): "
                   "camera when the scene has one, else native")
    g.add_argument("--display-frame", dest="placement", choices=("auto", "camera", "native"),
                   action=_OldPlacementFlag, help=argparse.SUPPRESS)
    g.add_argument("--display-center", metavar="X,Y,Z", help="the display's centre, scene units")
    g.add_argument("--display-normal", metavar="X,Y,Z", help="the display's normal, from the viewer into the scene")
    g.add_argument("--display-up", metavar="X,Y,Z", help="the display's up (default: the scene's y projected onto the "
                   "display, so x is horizontal; a normal along y keeps x = +x; within 10 deg of "
                   "the y axis a warning asks for this option)")
    g.add_argument("--display-width", type=float, metavar="UNITS", help="the panel's width in scene units")
    g.add_argument("--fit-depth", metavar="auto|MM",
                   help="measure the framed scene's depth and scale the pose (units per mm) so it fits the "
                   "display's depth budget (auto: 2 N f) or MM")
    g.add_argument("--depth-report", action="store_true",
                   help="measure the framed scene's depth (a small POV-Ray pass) for the summary and the sidecar, "
                   "and warn past the depth budget, without fitting it (--fit-depth, --depth-maps and --dataset "
                   "measure it too; povh3d info SCENE reports it)")
    g.add_argument("--depth-scale", nargs="?", const="fit", metavar="K",
                   help="compress depth alone along the display normal by K, keeping lateral sizes (a distortion); "
                   "bare, with --fit-depth: the K that makes the depth fit, instead of shrinking the whole scene")
