"""The one render path: a ``RenderRequest`` in, the H3D (or panel) image and its
sidecar out, for a still or every frame of an animation.

``render`` prepares once what every frame shares (the scene, or a mesh model
put on the default stage; the quality, when it is ``auto``), then hands
``render_image`` to the still or to the animation loop.  ``render_image`` runs
the method, applies the mapping and builds the sidecar record: a frame of an
animation and a still go through exactly the same steps.
"""

from __future__ import annotations

import glob
import re
import threading
import time
from dataclasses import replace
from functools import partial
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from .methods.registry import MethodResult, run_method
from .shots.clock_runs import ClockSequence
from .methods.quality import Progress, Quality, RenderSettings
from ..errors import RenderCancelled, param, warn
from pathlib import Path
from .budget import check_disk, check_memory as check_memory_budget
from ..image.interleave import extract
from .content.model import prepare_stage
from .placement.place import place_display
from .placement.ray_state import FALLBACK, fallback_beside_pass, settle_method
from .outputs.device_quilt import write_device_outputs
from .outputs.steps import Still, check_outputs, depth_beside, request_depth, write_outputs
from .passes.beside import BesidePass, stop_either
from .outputs.steps import check_outputs_against as outputs_against
from .passes.record import PassCost, recording
from ..povray.sandbox import describe as describe_sandbox
from ..scene.scene import Scene, load_scene
from .animation import RenderedImage, render_sequence
from .records import base_record, png_output, write_image
from .request import RenderRequest
from ..image.sidecar import PlacementRecord, QualityRecord, Sidecar, Timings
from ..jsontext import JSONObject, JSONValue

if TYPE_CHECKING:
    from .methods.auto import AutoChoice


def render(request: RenderRequest, progress: Progress | None = None) -> dict[str, JSONValue]:
    """Carry out ``request``; return the sidecar record of the still, or the animation's report.

    Every output is checked before any work and written atomically.  The record's ``passes`` lists
    the POV-Ray passes run besides the render and what each cost (``passes.record.PassCost``).
    """
    if request.objects is not None:   # a bug: renderer.run runs the mask pass after this colour pass
        raise RuntimeError("renderer.render.render takes a request without objects; use renderer.run.run_request")
    with recording() as passes:
        return _render(request, progress, passes)


def _render(request: RenderRequest, progress: Progress | None, passes: list[PassCost]) -> dict[str, JSONValue]:
    started = time.perf_counter()   # the whole time: the camera and depth runs too
    check_memory(request)
    output = png_output(request.output, inputs=(request.source,), sidecar=request.frames is None)
    check_outputs(request, output)   # views, dataset, depth maps, a Looking Glass quilt (outputs.steps)
    scene, model_record = load_content(request)
    check_outputs_against(request, output, (request.source, *scene.files))
    request, placed = place_display(request, scene, progress)
    ray_state, beside = None, False
    if not vendor_cameras(request):   # the vendor's perspective cameras trace no mesh camera
        beside = fallback_beside_pass(request, scene)   # the inside-solid pass beside the fallback's views
        if not beside:   # may trade the default method for one that renders it right
            request, ray_state = settle_method(request, scene, progress)
    placement_record = placed if ray_state is None else placed.updated(ray_state=ray_state)
    settings, auto = _resolve_quality(request, scene, progress)
    frame = partial(render_image, request, scene, settings, auto=auto, model=model_record,
                    placement=placement_record)
    if request.frames is None:
        if beside:   # the inside-solid pass beside the fallback's views
            request, settings, still, placement_record = _settled_beside(request, scene, placed, model_record, progress)
        else:
            still = frame(None, progress)
        _warn_unlit(scene, still.image)
        done = Still(request, scene, settings, still, output,
                     placement_record.units_per_mm if placement_record.units_per_mm is not None else 1.0, progress)
        try:
            write_outputs(done)   # each adds its entry to the record
        finally:
            if still.depth is not None:   # read by a step, or an error before: no POV-Ray left running
                still.depth.cancel()
        still = done.image
        timings = (still.record.timings or Timings()).updated(total_seconds=round(time.perf_counter() - started, 4))
        still = replace(still, record=still.record.with_(timings=timings, passes=tuple(passes)))
        write_image(output, still.image, still.record)
        _warn_record(still.record)
        return still.record.to_json()
    companions = None
    if (quilt := request.display.quilt) is not None:   # a Looking Glass preset: each frame's quilt (and native image)
        def companions(staged: Path, image: RenderedImage) -> tuple[Sidecar, list[Path]]:
            entry = write_device_outputs(staged, image.image, request.render_array, quilt, image.views)
            names = [entry.file, *([entry.native] if entry.native is not None else [])]
            return image.record.with_(quilt=entry), [staged.with_name(n) for n in names]
    report = render_sequence(request.frames, output, frame, uses_clock=scene.uses_clock, progress=progress,
                             video=request.video, fps=request.fps, companions=companions)
    _warn_unlit(scene)
    return {**report, "passes": [p.to_json() for p in passes]}


def check_outputs_against(request: RenderRequest, output: Path, inputs: tuple[Path, ...]) -> None:
    """Refuse, before any POV-Ray run, an output that is one of ``inputs`` (the scene and every file it
    reads: an include, an ``image_map``) or holds one: the image, its sidecar, an animation's frames
    (``image.io.check_output``), and every optional output (``outputs.steps``: quilt, folders)."""
    from ..image.io import check_output
    from .animation import frame_path

    if request.frames is None:
        check_output(output, inputs)
    else:   # OUT_nnnn.png and .json: an input, or a JSON already there, of a frame's name
        named = re.compile(re.escape(output.stem) + r"_(\d+)\.(?:png|json)", re.IGNORECASE)
        digits = max(4, len(str(request.frames.last)))   # render_sequence's
        there = (output.parent if str(output.parent) else Path(".")).glob(f"{glob.escape(output.stem)}_*.json")
        for name in {p.name for p in inputs} | {p.name for p in there}:
            found = named.fullmatch(name)
            if found and len(found[1]) == digits and int(found[1]) in request.frames.numbers:
                check_output(frame_path(output, int(found[1]), digits), inputs)
    outputs_against(request, output, inputs)


def vendor_cameras(request: RenderRequest) -> bool:
    """A Looking Glass preset rendered through the vendor's perspective cameras (``renderer.methods.vendor_views``)."""
    return (request.display.quilt or {}).get("camera_model") == "perspective"


#: An image whose 99th percentile is under this share of full scale (sRGB: linear 0.21) looks dark: POV-Ray's
#: default ambient 0.1 shows at 0.35.
_DARK = 0.5


def _warn_record(record: Sidecar) -> None:
    """The warnings a still's record holds (the placement's, the volume's), given through the one
    channel (``errors.warn``) once the image is written: the command line prints them, a Python caller
    sees them as ``Povh3dWarning``s, and the sidecar keeps them."""
    volume = record.extra.get("volume")
    volume_warnings = volume.get("warnings", []) if isinstance(volume, Mapping) else []
    placed = record.placement.warnings if record.placement is not None else None
    for message in [*(volume_warnings if isinstance(volume_warnings, list) else []), *(placed or ()),
                    *(record.warnings or ())]:
        warn(str(message))


def _warn_unlit(scene: Scene, image: np.ndarray | None = None) -> None:
    # After the render: a scene that fails says only why it failed.  Objects that light themselves
    # (finish { ambient 1 }, emission) render bright without a light_source: the image decides.
    # A lit scene is asked first: the quantile of a whole image costs 0.1 s of CPU (and imports numpy.ma).
    if scene.lit:
        return
    if image is not None and image.size:
        full = np.iinfo(image.dtype).max if np.issubdtype(image.dtype, np.integer) else 1.0
        if _quantile(image, 0.99) >= _DARK * full:
            return
    if not scene.lit:
        warn(f"{scene.path.name} has no light_source (and no emission): its objects show only their "
             "ambient colour, nearly black; add a light_source")


def _quantile(values: np.ndarray, q: float) -> float:
    """``np.quantile(values, q)`` (linear), by a partial sort: NumPy's own loads ``numpy.ma`` (7-13 ms of a
    render's start-up) through ``np.unique``."""
    flat = values.reshape(-1)
    pos = q * (flat.size - 1)
    lo = int(pos)
    hi = min(lo + 1, flat.size - 1)
    part = np.partition(flat, (lo, hi))
    return float(part[lo]) + (pos - lo) * (float(part[hi]) - float(part[lo]))


# Bytes a render holds per panel pixel at least: a ray (centre, direction: 5 float64), the
# image in linear light (3 float64) and its encoded copies; measured peaks are higher.
BYTES_PER_PIXEL = 96


def check_memory(request: RenderRequest) -> None:
    """Refuse, before any allocation, a panel whose arrays cannot fit in the memory available."""
    w, h = request.image_size
    rw, rh = request.render_array.panel.width, request.render_array.panel.height
    need = max(w * h, rw * rh) * BYTES_PER_PIXEL
    check_memory_budget(f"a {rw}x{rh} pixel render", need, f"use fewer lenses ({param('lenses')}) or pixels per lens ({param('ppl')})")
    if request.frames is not None:  # every frame is a PNG of at most 3 (8-bit) or 6 bytes a pixel, staged
        count = request.frames.last - request.frames.first + 1
        check_disk(Path(request.output).parent, f"{count} frames of {w}x{h} pixels", count * w * h * 3,
                   f"render fewer frames ({param('frames')} FIRST:LAST) or free some space")


def load_content(request: RenderRequest) -> tuple[Scene, JSONObject | None]:
    """The scene to render: the request's own, or a mesh model staged for the display (converted
    once, cached by content) or a volume's surfaces or medium (``renderer.content.volume``); and the model's or
    volume's record for the sidecar (None for a scene)."""
    if request.is_volume:
        from .content.volume import prepare_volume_stage

        stage, volume_record = prepare_volume_stage(
            request.source, request.render_array, request.volume, depth=request.model.depth,
            max_triangles=request.model.max_triangles, cache_dir=request.settings.cache_dir)
        return load_scene(stage, request.include_dirs), volume_record
    if not request.is_model:
        return load_scene(request.source, request.include_dirs), None
    m = request.model
    stage, model_record = prepare_stage(request.source, request.render_array, depth=m.depth, shading=m.shading,
                                        max_triangles=m.max_triangles, cache_dir=request.settings.cache_dir,
                                        up=m.up, rotate=m.rotate, unit=m.unit)
    return load_scene(stage, request.include_dirs), model_record


def _resolve_quality(request: RenderRequest, scene: Scene,
                     progress: Progress | None = None) -> tuple[RenderSettings, AutoChoice | None]:
    """``--quality auto`` chosen once for the whole request (on the first frame's clock)."""
    from .methods.auto import resolve_auto  # here: it keeps the module-level import chain within 8 levels

    first_clock = None
    if request.frames is not None and scene.uses_clock:
        first_clock = request.frames.clock(request.frames.first)
    probe = replace(request.settings, clock=first_clock)
    chosen, auto = resolve_auto(scene, request.render_array, request.method, probe, progress,
                                **request.method_options)
    return replace(chosen, clock=None), auto


class _MeshAfterAll(Exception):
    """The inside-solid pass run beside the fallback's views found the request's own method right."""


def _settled_beside(request: RenderRequest, scene: Scene, placed: PlacementRecord, model: JSONObject | None,
                    progress: Progress | None) -> tuple[RenderRequest, RenderSettings, RenderedImage, PlacementRecord]:
    """A still whose default mesh-camera method the inside-solid pass may trade for ``FALLBACK``
    (``fallback_beside_pass``): the pass runs beside the fallback's views, which are exact either way; where it
    finds the request's own method right, the views stop (or are set aside) and that method renders.  The
    request, settings, image and placement as rendered, the same as when the pass runs first."""
    mesh_right = threading.Event()

    def settle(should_stop: Callable[[], bool], _progress: Progress) -> tuple[RenderRequest, JSONObject | None]:
        stoppable = replace(request, settings=replace(request.settings, should_stop=stop_either(
            should_stop, request.settings.should_stop)))
        chosen, record = settle_method(stoppable, scene)
        if chosen.method == request.method:
            mesh_right.set()
        return replace(chosen, settings=request.settings), record

    decision = BesidePass(settle)
    views = replace(request, method=FALLBACK, method_options={})
    settings, _ = _resolve_quality(views, scene, progress)

    def settled() -> JSONObject:
        chosen, record = decision.result()
        if chosen.method != FALLBACK or record is None:
            raise _MeshAfterAll
        return record
    try:
        still = render_image(views, scene, replace(settings, should_stop=stop_either(mesh_right.is_set, settings.should_stop)),
                             None, progress, model=model, placement=placed, settled=settled)
        return views, settings, still, placed.updated(ray_state=settled())
    except (_MeshAfterAll, RenderCancelled):
        if not mesh_right.is_set():   # a caller's own cancel, not the pass's finding
            decision.cancel()
            raise
    except BaseException:
        decision.cancel()
        raise
    chosen, record = decision.result()
    settings, auto = _resolve_quality(chosen, scene, progress)
    placement = placed if record is None else placed.updated(ray_state=record)
    return chosen, settings, render_image(chosen, scene, settings, None, progress, auto=auto, model=model,
                                          placement=placement), placement


def _run_with_depth(request: RenderRequest, scene: Scene, settings: RenderSettings, clock: float | None,
                    sequence: ClockSequence | None, placement: PlacementRecord | None,
                    progress: Progress | None) -> tuple[MethodResult, BesidePass[np.ndarray] | None]:
    """The request's method run at ``clock``, and the depth pass its outputs read (``depth_beside``) started
    beside it as soon as the method knows where its rays start; the pass is stopped if the render fails."""
    kind = depth_beside(request, settings, clock)
    units = placement.units_per_mm if placement is not None and placement.units_per_mm is not None else 1.0
    depth: BesidePass[np.ndarray] | None = None

    def start_depth(front_clearance: float) -> None:
        nonlocal depth
        if kind is not None:
            depth = BesidePass(partial(request_depth, kind, request, scene, settings, front_clearance, units))
    try:
        result = run_method(request.method, scene, request.render_array,
                            replace(settings, clock=clock, sequence=sequence), progress, crop=request.crop,
                            method_options=request.method_options, on_clearance=start_depth)
    except BaseException:
        if depth is not None:
            depth.cancel()
        raise
    return result, depth


def render_image(request: RenderRequest, scene: Scene, settings: RenderSettings, clock: float | None,
                 progress: Progress | None = None, *, sequence: ClockSequence | None = None, auto: AutoChoice | None = None,
                 model: JSONObject | None = None, placement: PlacementRecord | None = None,
                 settled: Callable[[], JSONObject] | None = None) -> RenderedImage:
    """Render one image of ``request`` at POV-Ray clock ``clock`` (None: POV-Ray's default); ``sequence``:
    the animation frames from this one to the last, which the engine may render alongside it.  ``settled()``:
    the inside-solid check's record (``placement.ray_state``) where it ran beside the render, asked for once
    the method has run (it raises where the check found another method)."""
    array = request.render_array
    start = time.perf_counter()
    depth = None
    if auto is not None and auto.image is not None and request.frames is None:
        result = auto.image   # --quality auto rendered the full image while choosing it
    elif vendor_cameras(request):   # a Looking Glass preset's views through the vendor's cameras
        from .methods.vendor_views import run_vendor_views

        result = run_vendor_views(scene, array, replace(settings, clock=clock, sequence=sequence),
                                  dict(request.display.quilt or {}), placement.to_json() if placement else None,
                                  progress)  # a quilt preset
    else:
        result, depth = _run_with_depth(request, scene, settings, clock, sequence, placement, progress)
    seconds = auto.seconds if auto is not None and result is auto.image else time.perf_counter() - start
    if settled is not None and placement is not None:
        try:
            placement = placement.updated(ray_state=settled())
        except BaseException:
            if depth is not None:   # the depth pass beside a render set aside: stopped with it
                depth.cancel()
            raise
    h3d = result.h3d
    expected = (array.panel.height, array.panel.width)
    if h3d.shape[:2] != expected:  # a bug, never the user's doing
        raise RuntimeError(f"{request.method} produced {h3d.shape[:2]}, expected {expected}")

    timings = Timings.from_json({"render_seconds": round(seconds, 4), **result.stats.as_record()})
    quality = quality_record(settings, result.quality).updated(
        bit_depth=settings.bit_depth, front_clearance_mm=result.front_clearance,
        front_clearance_reason=result.front_clearance_reason)
    if auto is not None:
        quality = quality.updated(level="auto", auto=auto.as_record())
    display = request.display.as_record()   # the sidecar's lens_array and display entries
    record = base_record(
        "h3d", method=request.method, scene=str(scene.path),
        scene_sha256=scene.digest, quality=quality,
        output_gamma="sRGB", povray_version=result.stats.povray_version,
        sandbox=describe_sandbox(), scheduler=settings.scheduler, timings=timings,
    )
    display_entry = dict(display["display"])
    if request.viewing_distance is not None or request.display.viewing_distance_mm is not None:
        display_entry["viewing_distance"] = request.viewing()[1]   # what the rows were rendered for
    record = record.with_(lens_array=display["lens_array"], display=display_entry, method_chosen=request.method_chosen)
    ray_state = (placement.ray_state if placement is not None else None) or {}
    note = ray_state.get("method_note")
    if note:
        record = record.with_(method_note=note, method_fallback=ray_state["method_fallback"])
    if vendor_cameras(request):   # the method named no part of it: the record says the cameras
        record = record.with_(camera_model=result.record)
    elif result.record is not None:
        record = record.with_(**{request.method.replace("-", "_"): result.record})
    if result.crop is not None:
        record = record.with_(crop=result.crop)
    if model is not None:
        record = record.with_(**{request.content_kind: model})
    if placement is not None:
        cut = foreground_cut(placement, result.front_clearance, request.method)
        record = record.with_(placement=placement.updated(warnings=(*(placement.warnings or ()), *cut)))
    bank = h3d[array.bank_region] if array.views is not None else h3d   # hex, fractional PPL: all of it
    first = request.frames is None or clock is None or clock == request.frames.clock(request.frames.first)
    if first and bank.size and int(bank.max()) == int(bank.min()):
        # One flat colour: most likely no ray hit anything (a placement that misses the scene, a model in odd
        # units); said once per request, not per animation frame.
        w, h = array.panel.size_mm
        warn(f"every pixel of {request.output.name} is the same colour, as if no ray hit anything; check the "
             f"placement ({param('placement.mode')}, {param('placement.center')} ...) or the model's units and orientation ({param('unit')}, {param('up')}); a scene without a "
             f"camera is modelled in mm around z = 0, viewer on -z, the display spanning {w:.4g} x {h:.4g} mm")
    views = result.views
    if views is None and request.views_dir is not None:
        views = extract(h3d[array.bank_region], array.require_views())
    mapping = request.display.mapping
    if mapping is not None:
        h3d = mapping.apply(h3d, request.image_size)
        record = record.with_(kind="panel", mapping=mapping.name, size_px=list(request.image_size))
    return RenderedImage(h3d, record, views, from_cache=timings.shots_from_cache == timings.shots, depth=depth)


def foreground_cut(placement: PlacementRecord, front_clearance: float, method: str) -> list[str]:
    """A warning when the measured scene reaches out past where the rays start (mm): that part of the
    foreground is not in the image."""
    depth = placement.depth or {}
    near = depth.get("near_mm")
    if depth.get("empty") or not isinstance(near, (int, float)) or near >= -front_clearance * (1 - 1e-9):
        return []
    start = -front_clearance or 0.0
    limit = placement.front_clearance_limit_mm
    if limit is not None:
        why = (f"the scene's camera stands {limit / 0.9:.3g} mm out and nothing behind it may enter the image"
               f"{'; single-stage moves its lenses in steps' if method == 'single-stage' else ''}")
        fix = (f"{param('placement.fit_depth')} auto shrinks the scene onto the display" if not depth.get("fit") else
               f"a smaller {param('placement.fit_depth')} MM shrinks it further")
        fix += f", {param('method')} multi-ortho starts rays at any distance" if method == "single-stage" else ""
    else:
        why = f"{param('method')} {method} starts them there"
        fix = f"{param('front_clearance')} {-near:.3g} starts them farther out"
    return [f"the scene reaches z = {near:.3g} mm, but rays start at z = {start:.3g} mm ({why}): the foreground "
            f"nearer than that is cut; {fix}"]


def quality_record(settings: RenderSettings, rendered: Quality) -> QualityRecord:
    """The quality asked for and as rendered (a method without sub-views antialiases instead)."""
    level = settings.quality if isinstance(settings.quality, str) else "custom"
    return QualityRecord(level=level, setting=rendered.label, povray_options=tuple(rendered.options),
                         subviews=rendered.subviews, footprint_samples=rendered.footprint,
                         max_trace_level=rendered.max_trace_level,   # written even when null:
                         order=("level", "setting", "povray_options", "subviews", "footprint_samples",
                                "max_trace_level"))
