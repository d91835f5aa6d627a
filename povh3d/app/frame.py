"""Where the display sits in the user's scene: the frame a render uses, and why.

``resolve_frame`` turns the request's ``FrameOptions`` into a ``DisplayFrame``:

- explicit ``--display-center/normal/up/width``: that frame;
- ``native``: the display's own frame (mm, screen ``z = 0``);
- ``camera``, or ``auto`` when the scene has a camera: the frame the scene's
  last camera defines, evaluated by POV-Ray (``scene.camera``) in one small
  run whose result is cached by the scene's digest and the panel's size;
- ``auto`` without a camera: native.

The scene's camera never silently wins or loses: the record says which frame
was used, from where, and warns about several cameras.
"""

from __future__ import annotations

import io
import json
import math
import re
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..engine.cache import content_key, default_cache_dir
from ..errors import ConfigError, PovrayError, PovrayTimeout
from ..geometry.frame import EXPLICIT_OPTIONS, NATIVE, DisplayFrame, camera_frame, explicit_frame
from ..geometry.lens_array import LensArray
from ..image.io import atomic_path
from ..scene.camera import (CameraError, CameraScript, camera_from_log, camera_statements, evaluation_script,
                            parse_log, tokens)
from ..scene.scene import Scene

if TYPE_CHECKING:  # only for annotations: keeps the import chain short
    from ..engine.depth import DepthMap

FRAME_MODES = ("auto", "camera", "native")


@dataclass(frozen=True)
class FrameOptions:
    """How the display is placed in the scene (``--display-*``).

    Attributes
    ----------
    mode : {'auto', 'camera', 'native'}   ignored when ``center`` is given (explicit)
    center, normal, up : (3,) floats or None, scene units
    width : float or None, scene units    the panel's width in the scene
    fit_depth : 'auto', float (mm) or None  scale the frame so the measured depth fits
    depth_scale : float, 'fit' or None   compress depth alone along the normal by this factor (a
                                         distortion); 'fit': the factor --fit-depth chooses
    """

    mode: str = "auto"
    center: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None
    up: tuple[float, float, float] | None = None
    width: float | None = None
    fit_depth: str | float | None = None   # 'auto' (the depth budget) or mm: scale the frame to fit
    depth_scale: str | float | None = None  # a factor, or 'fit' (with fit_depth: compress depth to fit)

    def __post_init__(self) -> None:
        k = self.depth_scale
        if k == "fit" and self.fit_depth is None:
            raise ConfigError("--depth-scale without a factor needs --fit-depth auto|MM (which then chooses "
                              "it); or give the factor, e.g. --depth-scale 0.5")
        if k not in (None, "fit") and self.fit_depth is not None:
            raise ConfigError(f"--depth-scale {k} and --fit-depth both set the depth; give --fit-depth with a "
                              "bare --depth-scale to compress depth until it fits, or the factor alone")
        if k not in (None, "fit"):
            from ..engine.quality import DEPTH_SCALE_RANGE

            low, high = DEPTH_SCALE_RANGE
            if isinstance(k, bool) or not isinstance(k, (int, float)) or not low <= k <= high:
                raise ConfigError(f"--depth-scale must be a number within {low:g}..{high:g} (or nothing, with "
                                  f"--fit-depth), got {k!r}")
        f = self.fit_depth
        if f is not None and f != "auto" and (isinstance(f, bool) or not isinstance(f, (int, float))
                                              or not (f > 0 and f < float("inf"))):
            raise ConfigError(f"--fit-depth takes 'auto' or a positive number of mm, got {f!r}")
        if self.mode not in FRAME_MODES:
            raise ConfigError(f"--display-frame must be one of {', '.join(FRAME_MODES)}, got {self.mode!r}")
        given = [n for n in ("center", "normal", "width") if getattr(self, n) is not None]
        if given and len(given) < 3:
            raise ConfigError(f"an explicit display frame needs all of {EXPLICIT_OPTIONS}")
        if self.up is not None and not given:
            raise ConfigError(f"--display-up needs the rest of {EXPLICIT_OPTIONS}")
        if given and self.mode != "auto":
            raise ConfigError("--display-frame cannot be combined with --display-center and the other "
                              "explicit options; give one or the other")

    @property
    def explicit(self) -> bool:
        return self.center is not None


DisplayFrameOptions = FrameOptions  # the name outside this module: a display frame, not an animation frame


def resolve_frame(options: FrameOptions, scene: Scene, lens_array: LensArray, *,
                  cache_dir: Any = None, use_cache: bool = True) -> tuple[DisplayFrame, dict[str, Any]]:
    """The frame to render with and its sidecar record (``warnings`` listed there)."""
    frame, record, _ = resolve_frame_and_depth(options, scene, lens_array, cache_dir=cache_dir,
                                               use_cache=use_cache)
    return frame, record


def resolve_frame_and_depth(options: FrameOptions, scene: Scene, lens_array: LensArray, *, cache_dir: Any = None,
                            use_cache: bool = True, front_clearance: float | None = None
                            ) -> tuple[DisplayFrame, dict[str, Any], Seen | None]:
    """``resolve_frame``, and with ``front_clearance`` (mm) for a camera frame, the depth pass along its normal
    made in the same POV-Ray run that evaluated the camera (``Seen``); None otherwise."""
    width_mm = lens_array.panel.size_mm[0]
    if options.explicit:
        frame = explicit_frame(options.center, options.normal, float(options.width), width_mm, options.up)
        return frame, {**frame.as_record(), "warnings": []}, None
    if options.mode == "native":
        return NATIVE, {**NATIVE.as_record(), "warnings": []}, None
    text = scene.path.read_bytes().decode("latin-1")
    script = evaluation_script(text)
    if script is None:
        _check_included_cameras(scene)
        if options.mode == "camera":
            raise ConfigError(f"--display-frame camera: the scene {scene.path.name} has no camera; "
                              f"place the display with {EXPLICIT_OPTIONS}")
        note = "the scene has no camera: mm around the screen z = 0"
        return NATIVE, {**NATIVE.as_record(), "note": note, "warnings": []}, None
    try:
        found = (_evaluate_and_measure(scene, script, lens_array, front_clearance, cache_dir, use_cache)
                 if front_clearance is not None else None)
    except PovrayError as exc:
        if isinstance(exc, PovrayTimeout):
            raise
        found = None   # the camera alone, then a pass of its own, say what failed: the camera or the scene
    if found is None:
        camera, seconds, cached = _evaluate(scene, script.script, lens_array, script.cameras, cache_dir, use_cache)
        distances = None
    else:
        camera, distances, seconds, cached = found
    if camera["type"] != "perspective":
        raise CameraError(f"cannot use the scene's {camera['type']} camera (only a perspective one defines "
                          f"a frame); place the display with {EXPLICIT_OPTIONS}, or --display-frame native")
    frame = camera_frame(camera["location"], camera["direction"], camera["right"], camera["up"],
                         camera["look_at"], width_mm,
                         note="look_at" if camera["look_at"] is not None else "no look_at: the point of the "
                         "view axis nearest the scene origin")
    warnings = []
    if script.cameras > 1:
        warnings.append(f"the scene has {script.cameras} cameras; the last one counts (POV-Ray's rule) "
                        f"and places the display")
    if frame.mirrored:
        warnings.append("the scene's camera is mirrored (a negative right): the display frame is a mirror image")
    record = {**frame.as_record(), "camera": camera, "evaluation_seconds": round(seconds, 4),
              "evaluation_from_cache": cached, "warnings": warnings}
    return frame, record, distances


def _check_included_cameras(scene: Scene) -> None:
    """A camera in an included file cannot be isolated: say so rather than drop it."""
    for path in scene.files[1:] if len(scene.files) > 1 else ():
        if path == scene.path or path.suffix.lower() not in (".inc", ".pov"):
            continue
        if camera_statements(tokens(path.read_bytes().decode("latin-1"))):
            raise CameraError(f"cannot use the scene's camera (it is in the included file {path.name}); "
                              f"place the display with {EXPLICIT_OPTIONS}, or --display-frame native")


def _evaluate(scene: Scene, script: str, lens_array: LensArray, cameras: int, cache_dir: Any,
              use_cache: bool) -> tuple[dict[str, Any], float, bool]:
    """The camera's vectors from one POV-Ray run of ``script``, cached by the scene's digest.

    The run has the panel's pixel size, so ``image_width / image_height`` in
    the camera is the H3D image's aspect; it traces one row.
    """
    from ..povray.process import PovrayJob, run_jobs
    from ..povray.sandbox import scene_inputs

    start = time.perf_counter()
    w, h = lens_array.panel.width, lens_array.panel.height
    key = content_key("scene-camera", __version__, scene.digest, w, h)
    path = (cache_dir or default_cache_dir()) / "cameras" / f"{key}.json"
    if use_cache and path.is_file():
        return json.loads(path.read_text(encoding="utf-8")), time.perf_counter() - start, True
    job = PovrayJob(name="scene camera", script=script, width=w, height=h, start_row=0, end_row=1,
                    options=("-A",), threads=1, timeout=120, **scene_inputs(scene))
    logs: list[str] = []
    run_jobs([job], processes=1, on_result=lambda result: logs.append(result.log))
    camera = camera_from_log(logs[0] if logs else "", cameras).as_record()
    if use_cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(camera) + "\n", encoding="utf-8")
    return camera, time.perf_counter() - start, False


def measured_size(scene: Scene, width: int, height: int, target: int) -> tuple[int, int] | None:
    """The image size of the run that evaluates the camera and measures depth through it, or None
    when the camera must be evaluated at the panel's own size in a run of its own.

    The camera is evaluated in the run's ``image_width x image_height``: a scene that uses
    them only as ``image_width / image_height`` gets the panel's exact aspect at the size of
    the depth pass (``target`` pixels wide or less: the panel's size divided by a common divisor);
    one that never names them, ``target`` wide;
    one that uses them otherwise (``#declare IW = image_width``), the panel's size, so
    the depth is measured by a pass of its own.
    """
    text = "\n".join(p.read_bytes().decode("latin-1") for p in scene.files if p.is_file())
    named = re.search(r"\bimage_(width|height)\b", text)
    if re.search(r"\bimage_(width|height)\b", _RATIO.sub("", text)):
        return None
    if not named:
        w = min(target, width)
        return w, max(1, round(w * height / width))
    common = math.gcd(width, height)
    for m in range(1, common + 1):
        if common % m == 0 and width // m <= target:
            return width // m, height // m
    return (width, height) if width <= 2 * target else None


_RATIO = re.compile(r"\bimage_width\s*/\s*image_height\b|\bimage_height\s*/\s*image_width\b")


def _evaluate_and_measure(scene: Scene, script: CameraScript, lens_array: LensArray, front_clearance: float,
                          cache_dir: Any, use_cache: bool) -> tuple[dict[str, Any], Seen, float, bool] | None:
    """The camera's vectors and a depth pass along the normal of the frame it defines, from one
    POV-Ray run: the evaluation script, the rest of the scene and ``templates/camera_depth.pov.j2``,
    which works out the frame and the clearance from the declared values, prints them and renders
    the two fog frames (``engine.depth``).  Cached by the scene's digest, the panel and ``front_clearance``.
    None when the camera needs a run at the panel's own size (``measured_size``)."""
    from ..engine.depth import fog_distances, pass_size
    from ..image.io import read_png
    from ..povray.process import PovrayJob, run_jobs
    from ..povray.sandbox import files_within
    from ..povray.templates import render_template

    start = time.perf_counter()
    w, h = lens_array.panel.width, lens_array.panel.height
    right, up = (lens_array.lenses_x * lens_array.pitch_x, 0.0, 0.0), (0.0, lens_array.lenses_y * lens_array.pitch_y, 0.0)
    target = pass_size(lens_array)[0]
    key = content_key("scene-camera-depth", __version__, scene.digest, w, h, target, right, up, front_clearance,
                      lens_array.panel.size_mm[0])
    folder = (cache_dir or default_cache_dir()) / "cameras"
    path, array_path = folder / f"{key}.json", folder / f"{key}.npy"
    if use_cache and path.is_file() and array_path.is_file():
        saved = json.loads(path.read_text(encoding="utf-8"))
        seen = Seen(np.load(array_path), saved["unmeasured"], tuple(saved["printed"]))
        return saved["camera"], seen, time.perf_counter() - start, True
    size = measured_size(scene, w, h, target)
    if size is None:
        return None
    text = script.script + script.rest + render_template(
        "camera_depth.pov.j2", panel_width=lens_array.panel.size_mm[0], front_clearance=front_clearance, right=right, up=up,
        add_assumed_gamma=not scene.sets_assumed_gamma)
    job = PovrayJob(name="scene camera and depth", script=text, width=size[0], height=size[1], frames=2,
                    include_dirs=tuple(str(d) for d in scene.include_dirs), options=("-A",), bit_depth=16,
                    read_files=files_within(scene.files, scene.include_dirs), timeout=600)
    found: list[tuple[str, list[np.ndarray]]] = []
    run_jobs([job], processes=1, on_result=lambda r: found.append((r.log, [read_png(i) for i in r.images])))
    log, images = found[0] if found else ("", [])
    camera = camera_from_log(log, script.cameras).as_record()
    printed = next((tuple(v) for k, v in parse_log(log) if k == "depth_frame" and isinstance(v, list)), ())
    if len(printed) != 14 or len(images) != 2:
        raise CameraError(f"cannot use the scene's camera (POV-Ray did not finish the depth pass through its "
                          f"frame); place the display with {EXPLICIT_OPTIONS}, or --display-frame native")
    distances, unmeasured = fog_distances(images[:1], images[1:], printed[12] * printed[13])
    seen = Seen(distances[0].astype(np.float32), float(unmeasured[0]), printed)
    if use_cache:
        folder.mkdir(parents=True, exist_ok=True)
        buffer = io.BytesIO()
        np.save(buffer, seen.distances)
        with atomic_path(array_path) as tmp:
            tmp.write_bytes(buffer.getvalue())
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps({"camera": camera, "unmeasured": seen.unmeasured,
                                       "printed": list(printed)}) + "\n", encoding="utf-8")
    return camera, seen, time.perf_counter() - start, False


@dataclass(frozen=True)
class Seen:
    """A depth pass made in the camera's own run: ray lengths (scene units, NaN: none), the share the
    fog did not reach, and the frame and clearance it was made in, as POV-Ray worked them out:
    centre, x, y, normal (3 each), units per mm, front clearance (mm)."""

    distances: np.ndarray
    unmeasured: float
    printed: tuple[float, ...]

    def depth(self, frame: DisplayFrame, front_clearance: float, lens_array: LensArray) -> DepthMap | None:
        """The depth map, if the pass was made in ``frame`` with ``front_clearance``; else None (measure again)."""
        from ..engine.depth import depth_map

        expected = [*frame.centre, *frame.axis_x, *frame.axis_y, *frame.axis_z, frame.units_per_mm, front_clearance]
        size = max(1.0, *(abs(v) for v in frame.centre))
        if not (np.allclose(self.printed[:3], expected[:3], rtol=0, atol=1e-9 * size)
                and np.allclose(self.printed[3:12], expected[3:12], rtol=0, atol=1e-9)
                and np.allclose(self.printed[12:], expected[12:], rtol=1e-9, atol=0)):
            return None
        return depth_map(self.distances, lens_array, front_clearance, frame.units_per_mm, self.unmeasured)
