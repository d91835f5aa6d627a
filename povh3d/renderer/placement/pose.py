"""Where the display sits in the user's scene: the pose a render uses, and why.

``resolve_pose`` turns the request's ``PlacementOptions`` into a ``DisplayPose``:

- explicit ``--display-center/normal/up/width``: that pose;
- ``native``: display coordinates themselves (mm, screen ``z = 0``);
- ``camera``, or ``auto`` when the scene has a camera: the pose the scene's
  last camera defines, read from the text where it is one statement of literal values
  (``scene.camera_text``), else evaluated by POV-Ray in one small run
  (``renderer.passes.scene_camera``, cached by the scene's digest and the panel's size);
- ``auto`` without a camera: native.

The scene's camera never silently wins or loses: the record says which pose
was used, from where, and warns about several cameras.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ...errors import ConfigError, PovrayError, PovrayTimeout, param
from ...geometry.pose import EXPLICIT_OPTIONS, NATIVE, DisplayPose, camera_pose, explicit_pose, up_warning
from ...geometry.lens_array import LensArray
from ...scene.camera import CameraError
from ...scene.camera_script import REFUSED_TYPES, camera_script, refused_type, written_camera_types
from ...scene.scene import Scene, source_text

if TYPE_CHECKING:  # only for annotations: keeps the import chain short
    from ..methods.quality import Progress
    from ..passes.scene_camera import Seen

PLACEMENT_MODES = ("auto", "camera", "native")


@dataclass(frozen=True)
class PlacementOptions:
    """How the display is placed in the scene (``--display-*``).

    Attributes
    ----------
    mode : {'auto', 'camera', 'native'}   ignored when ``center`` is given (explicit)
    center, normal, up : (3,) floats or None, scene units
    width : float or None, scene units    the panel's width in the scene
    fit_depth : 'auto', float (mm) or None  scale the pose so the measured depth fits
    depth_scale : float, 'fit' or None   compress depth alone along the normal by this factor (a
                                         distortion); 'fit': the factor --fit-depth chooses
    depth_report : bool                  measure the framed scene's depth (and warn past the budget)
                                         without fitting it (``place.depth_wanted``)
    """

    mode: str = "auto"
    center: tuple[float, float, float] | None = None
    normal: tuple[float, float, float] | None = None
    up: tuple[float, float, float] | None = None
    width: float | None = None
    fit_depth: str | float | None = None   # 'auto' (the depth budget) or mm: scale the pose to fit
    depth_scale: str | float | None = None  # a factor, or 'fit' (with fit_depth: compress depth to fit)
    depth_report: bool = False

    def __post_init__(self) -> None:
        k = self.depth_scale
        if k == "fit" and self.fit_depth is None:
            raise ConfigError(f"{param('depth_scale')} without a factor needs {param('placement.fit_depth')} auto|MM (which then chooses "
                              f"it); or give the factor, e.g. {param('depth_scale')} 0.5")
        if k not in (None, "fit") and self.fit_depth is not None:
            raise ConfigError(f"{param('depth_scale')} {k} and {param('placement.fit_depth')} both set the depth; give {param('placement.fit_depth')} with a "
                              f"bare {param('depth_scale')} to compress depth until it fits, or the factor alone")
        if k not in (None, "fit"):
            from ..methods.quality import DEPTH_SCALE_RANGE

            low, high = DEPTH_SCALE_RANGE
            if isinstance(k, bool) or not isinstance(k, (int, float)) or not low <= k <= high:
                raise ConfigError(f"{param('depth_scale')} must be a number within {low:g}..{high:g} (or nothing, with "
                                  f"{param('placement.fit_depth')}), got {k!r}")
        f = self.fit_depth
        if f is not None and f != "auto" and (isinstance(f, bool) or not isinstance(f, (int, float))
                                              or not (f > 0 and f < float("inf"))):
            raise ConfigError(f"{param('placement.fit_depth')} takes 'auto' or a positive number of mm, got {f!r}")
        if self.mode not in PLACEMENT_MODES:
            raise ConfigError(f"{param('placement.mode')} must be one of {', '.join(PLACEMENT_MODES)}, got {self.mode!r}")
        given = [n for n in ("center", "normal", "width") if getattr(self, n) is not None]
        if given and len(given) < 3:
            raise ConfigError(f"an explicit placement needs all of {EXPLICIT_OPTIONS}")
        if self.up is not None and not given:
            raise ConfigError(f"{param('placement.up')} needs the rest of {EXPLICIT_OPTIONS}")
        if given and self.mode != "auto":
            raise ConfigError(f"{param('placement.mode')} cannot be combined with {param('placement.center')} and the other "
                              "explicit options; give one or the other")

    @property
    def explicit(self) -> bool:
        return self.center is not None


def resolve_pose(options: PlacementOptions, scene: Scene, lens_array: LensArray, *,
                  cache_dir: Any = None, use_cache: bool = True) -> tuple[DisplayPose, dict[str, Any]]:
    """The pose to render with and its sidecar record (``warnings`` listed there)."""
    pose, record, _ = resolve_pose_and_depth(options, scene, lens_array, cache_dir=cache_dir,
                                               use_cache=use_cache)
    return pose, record


def resolve_pose_and_depth(options: PlacementOptions, scene: Scene, lens_array: LensArray, *, cache_dir: Any = None,
                            use_cache: bool = True, front_clearance: float | None = None,
                            timeout: float | None = None, progress: Progress | None = None,
                            ) -> tuple[DisplayPose, dict[str, Any], Seen | None]:
    """``resolve_pose``, and with ``front_clearance`` (mm) for a camera pose, the depth pass along its normal
    made in the same POV-Ray run that evaluated the camera (``Seen``); None otherwise.  ``timeout``: seconds
    allowed to each of those POV-Ray runs (None: no limit, as a render's); ``progress(done, total)``: the
    frames of the run that evaluates the camera and makes the depth pass."""
    import time

    from ..passes.record import note
    from ..passes.scene_camera import (evaluate_and_measure, evaluate_camera, physical_size, probe_size,
                                       uses_image_size)
    from ...scene.camera import camera_from_items
    from ...scene.camera_text import literal_camera

    width_mm = lens_array.panel.size_mm[0]
    if options.explicit:
        assert options.width is not None  # explicit: centre, normal and width all given (__post_init__)
        pose = explicit_pose(options.center, options.normal, float(options.width), width_mm, options.up)
        warning = up_warning(options.normal, options.up)  # an up chosen for the user near the y axis
        return pose, {**pose.as_record(), "warnings": [warning] if warning else []}, None
    if options.mode == "native":
        return NATIVE, {**NATIVE.as_record(), "warnings": []}, None
    text = source_text(scene.path.read_bytes())
    from ..budget import check_memory
    # The camera's reading keeps a token of every word and number: about 200 bytes a byte of text
    # (a 5 MB one-expression scene took 0.96 GB), estimated before it starts.
    check_memory(f"reading the camera of {scene.path.name} ({len(text) / 2**20:.3g} MB of text)", 200 * len(text),
                 f"give the display's place with {param('placement.mode')} native or {param('placement.center')}/{param('placement.normal')}, "
                 f"or raise {param('max_memory')}")
    script = camera_script(text, scene.include_text)
    written = written_camera_types(text, scene.include_text) if script is not None else set()
    refused = refused_type(written)
    if refused:   # refused from the text: its parse may take minutes at the panel's size
        raise CameraError(_unusable_type(refused))
    if script is None:
        if options.mode == "camera":
            raise ConfigError(f"{param('placement.mode')} camera: the scene {scene.path.name} has no camera; "
                              f"place the display with {EXPLICIT_OPTIONS}")
        why = "the scene has no camera: mm around the screen z = 0"
        return NATIVE, {**NATIVE.as_record(), "note": why, "warnings": []}, None
    try:
        found = (evaluate_and_measure(scene, script, lens_array, front_clearance, cache_dir, use_cache, timeout,
                                      progress) if front_clearance is not None else None)
    except PovrayError as exc:
        if isinstance(exc, PovrayTimeout):
            raise
        found = None   # the camera alone, then a pass of its own, say what failed: the camera or the scene
    if found is None and written & set(REFUSED_TYPES) and uses_image_size(scene):
        # Types mixed in a scene that builds from image_width (a mesh camera a pixel): its parse may take
        # many minutes at the panel's size, so which camera it ends with is told at a few rows first.
        w, h = probe_size(lens_array)
        probe, _, _ = evaluate_camera(scene, script.script, lens_array, script.cameras, cache_dir, use_cache,
                                      script.lines, timeout, (w, h))
        if probe["type"] in REFUSED_TYPES:
            raise CameraError(_unusable_type(probe["type"]) + f" (its type told by a parse at {w}x{h} pixels)")
    # The text's image_width and image_height are the evaluation's (``camera_size``: ``physical_size`` where
    # the scene builds from them, else its ratio, which is all a literal camera reads of them otherwise).
    literal = (literal_camera(text, scene.include_text, physical_size(lens_array))
               if found is None and front_clearance is None else None)
    if literal is not None:   # the text alone tells it: no POV-Ray run (scene/camera_text.py)
        start = time.perf_counter()
        camera, distances, cached = camera_from_items(literal).as_record(), None, False
        seconds = time.perf_counter() - start
        note("scene-camera-text", seconds, 0, 0)
    elif found is None:
        camera, seconds, cached = evaluate_camera(scene, script.script, lens_array, script.cameras, cache_dir,
                                                  use_cache, script.lines, timeout)
        distances = None
    else:
        camera, distances, seconds, cached = found
    pose, warnings = _camera_pose(camera, width_mm)
    record = {**pose.as_record(), "camera": camera, "evaluation_seconds": round(seconds, 4),
              "evaluation_from_cache": cached, "warnings": warnings}
    return pose, record, distances


def _camera_pose(camera: dict[str, Any], width_mm: float) -> tuple[DisplayPose, list[str]]:
    """The pose of a perspective scene camera (its evaluated values) and what to say of it."""
    if camera["type"] == "orthographic":
        raise CameraError(f"cannot use the scene's orthographic camera (only a perspective one defines a pose); "
                          f"place the display where it looks: {_orthographic_options(camera)}")
    if camera["type"] != "perspective":
        raise CameraError(_unusable_type(camera["type"]))
    pose = camera_pose(camera["location"], camera["direction"], camera["right"], camera["up"],
                         camera["look_at"], width_mm,
                         note="look_at" if camera["look_at"] is not None else "no look_at: the point of the "
                         "view axis nearest the scene origin")
    warnings = []
    if camera.get("cameras", 1) > 1:
        warnings.append(f"the scene's parse ran {camera['cameras']} camera statements; the last one counts "
                        f"(POV-Ray's rule) and places the display")
    if camera.get("dropped"):
        warnings.append(f"the scene camera's {', '.join(camera['dropped'])} (focal blur, a normal pattern) "
                        f"are not reproduced: every view is a sharp, undistorted render")
    # A mirrored pose (a right-handed camera: a negative right) is no warning: the display's x follows
    # the camera's right as POV-Ray's 2D render does, so the views show what that render shows, the
    # right way round; the record says ``mirrored`` and why.
    if pose.mirrored:
        pose = DisplayPose(pose.centre, pose.axis_x, pose.axis_y, pose.axis_z, pose.units_per_mm, pose.source,
                             pose.note + "; right-handed (a negative right): x follows it, as in the 2D render",
                             pose.camera_distance)
    return pose, warnings


def _unusable_type(kind: str) -> str:
    return (f"cannot use the scene's {kind} camera (only a perspective one defines a pose); place the display "
            f"with {EXPLICIT_OPTIONS}, or {param('placement.mode')} native")


def _orthographic_options(camera: dict[str, Any]) -> str:
    """The ``--display-*`` options that put the display across an orthographic camera's view: centred
    on its look_at (or its location), facing along its direction, as wide as its ``right``."""
    import numpy as np

    centre = camera["look_at"] if camera["look_at"] is not None else camera["location"]
    width = float(np.linalg.norm(camera["right"]))

    def triple(v: Any) -> str:
        return ",".join(f"{float(x):.6g}" for x in v)

    return (f"{param('placement.center')}={triple(centre)} {param('placement.normal')}={triple(camera['direction'])} "
            f"{param('placement.up')}={triple(camera['up'])} {param('placement.width')} {width:.6g}")


def recorded_pose(record: dict[str, Any]) -> tuple[float, ...] | None:
    """The POV-Ray matrix of a sidecar's ``placement`` entry (None: native): what a later pass
    over the same rays takes as ``RenderSettings.pose`` instead of evaluating the scene again."""
    if "matrix" in record:
        return tuple(float(v) for v in record["matrix"])
    if not record or record.get("source") == "native":
        return None
    pose = DisplayPose(tuple(record["centre"]), tuple(record["axis_x"]), tuple(record["axis_y"]),
                         tuple(record["normal"]), float(record["units_per_mm"]))
    return None if pose.is_native else tuple(pose.matrix().ravel().tolist())

