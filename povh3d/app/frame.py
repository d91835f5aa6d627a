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

import json
import time
from dataclasses import dataclass
from typing import Any

from .._version import __version__
from ..engine.cache import content_key, default_cache_dir
from ..errors import ConfigError
from ..geometry.frame import EXPLICIT_OPTIONS, NATIVE, DisplayFrame, camera_frame, explicit_frame
from ..geometry.lens_array import LensArray
from ..image.io import atomic_path
from ..scene.camera import CameraError, camera_from_log, camera_statements, evaluation_script, tokens
from ..scene.scene import Scene

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
    """

    mode: str = "auto"
    center: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None
    up: tuple[float, float, float] | None = None
    width: float | None = None
    fit_depth: str | float | None = None   # 'auto' (the depth budget) or mm: scale the frame to fit

    def __post_init__(self) -> None:
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


def resolve_frame(options: FrameOptions, scene: Scene, lens_array: LensArray, *,
                  cache_dir: Any = None, use_cache: bool = True) -> tuple[DisplayFrame, dict[str, Any]]:
    """The frame to render with and its sidecar record (``warnings`` listed there)."""
    width_mm = lens_array.panel.size_mm[0]
    if options.explicit:
        frame = explicit_frame(options.center, options.normal, float(options.width), width_mm, options.up)
        return frame, {**frame.as_record(), "warnings": []}
    if options.mode == "native":
        return NATIVE, {**NATIVE.as_record(), "warnings": []}
    text = scene.path.read_bytes().decode("latin-1")
    script = evaluation_script(text)
    if script is None:
        _check_included_cameras(scene)
        if options.mode == "camera":
            raise ConfigError(f"--display-frame camera: the scene {scene.path.name} has no camera; "
                              f"place the display with {EXPLICIT_OPTIONS}")
        note = "the scene has no camera: mm around the screen z = 0"
        return NATIVE, {**NATIVE.as_record(), "note": note, "warnings": []}
    camera, seconds, cached = _evaluate(scene, script.script, lens_array, script.cameras, cache_dir, use_cache)
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
    return frame, record


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
