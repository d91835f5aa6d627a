"""Place the display in the scene for a request: the pose, the front clearance, the depth.

``place_display`` resolves the pose (``renderer.placement.pose``), keeps the rays' start in
front of the scene's camera, measures the scene's depth in the pose
(``renderer.passes.depth``: only where something reads it, ``depth_wanted``, and for a pose other
than native or with ``--fit-depth``),
scales the pose when ``--fit-depth`` asks, and returns the request with the
pose in its settings and the record for the sidecar.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..passes.depth import DepthMap, depth_pass
from ..methods.registry import get_method
from ...geometry.camera_mesh import default_front_clearance
from ..methods.quality import DEPTH_SCALE_RANGE, Progress
from ...errors import ConfigError, param
from ...geometry.pose import NATIVE, DisplayPose
from ...scene.scene import Scene
from .pose import resolve_pose_and_depth
from ...geometry.fit import depth_budget_mm
from ...image.sidecar import PlacementRecord

if TYPE_CHECKING:  # only for annotations: keeps the import chain short
    from ..request import RenderRequest


def place_display(request: RenderRequest, scene: Scene,
                  progress: Progress | None = None) -> tuple[RenderRequest, PlacementRecord]:
    """The request with its placement (and clearance) resolved into the settings, and the sidecar's
    ``placement`` record (typed, checked as a sidecar's is read); ``progress(done, total)``: a depth
    pass's shots."""
    placed, record = _place(request, scene, progress)
    return placed, PlacementRecord.from_json(record)


def _place(request: RenderRequest, scene: Scene,
           progress: Progress | None) -> tuple[RenderRequest, dict[str, Any]]:
    """``place_display``, its record as the JSON it assembles."""
    array = request.render_array
    budget = depth_budget_mm(array)
    if request.is_model:  # the stage is built in display mm
        return request, {**NATIVE.as_record(), "note": "a mesh model staged in display mm",
                         "depth_budget_mm": budget, "warnings": []}
    s = request.settings
    if s.pose is not None:  # the Python API gave the matrix itself: use it, and say so
        _check_similarity(s.pose)
        return request, {"source": "matrix", "matrix": list(s.pose), "depth_budget_mm": budget, "warnings": []}
    options = request.placement
    if (request.display.quilt or {}).get("camera_model") == "perspective":
        if options.fit_depth is not None or options.depth_scale is not None:
            raise ConfigError(f"{param('placement.fit_depth')} and {param('depth_scale')} shape the rays of a lens array; the vendor's "
                              "perspective cameras take the scene as its camera sees it: drop them, or add "
                              f"{param('camera_model')} orthographic")
        # The vendor's cameras start at the viewer's eye, wherever the scene is: the pose alone, no depth pass.
        placed, record, _ = resolve_pose_and_depth(options, scene, array, cache_dir=s.cache_dir,
                                                    use_cache=s.use_cache, timeout=s.timeout)
        matrix = None if placed.is_native else tuple(placed.matrix().ravel().tolist())
        return replace(request, settings=replace(s, pose=matrix)), {**record, "depth_budget_mm": budget}
    # The depth pass looks out as far as any method's default (within the scene camera), so that it sees
    # what a method starting nearer (single-stage) would cut.
    default = max(get_method(request.method).default_front_clearance(array), default_front_clearance(array))
    # A camera pose's depth pass is made in the run that evaluates the camera, when it can be, and only
    # where something reads it (``depth_wanted``); else that run evaluates the camera alone.
    wanted = depth_wanted(request, default)
    placed, record, seen = resolve_pose_and_depth(options, scene, array, cache_dir=s.cache_dir,
                                                   use_cache=s.use_cache, timeout=s.timeout,
                                                   front_clearance=(s.front_clearance or default) if wanted else None,
                                                   progress=progress)
    front_clearance = s.front_clearance or _front_clearance(placed, default)
    scale = s.depth_scale if options.depth_scale in (None, "fit") else float(options.depth_scale)
    if wanted and (not placed.is_native or options.fit_depth is not None or scale != 1 or options.depth_report):
        placed, depth, scale = _measure(request, scene, placed, front_clearance, budget, options.fit_depth,
                                        scale, options.depth_scale == "fit",
                                        seen.depth(placed, front_clearance, array) if seen else None, progress)
        record = {**record, **placed.as_record(), "depth": depth}
        if not depth.get("empty") and not depth.get("within_budget", True):
            record["warnings"].append(
                f"the framed scene spans z = {depth['near_mm']:.3g} .. {depth['far_mm']:.3g} mm, beyond the "
                f"depth budget of +-{budget / 2:.3g} mm (2 N f): it looks blurred there; "
                f"{param('placement.fit_depth')} auto scales the pose to fit")
        elif not depth.get("empty") and not depth["field_within_budget"]:
            record["warnings"].append(
                f"something beyond the framed subject (a ground plane or a backdrop?) reaches z = "
                f"{depth['field_near_mm']:.3g} .. {depth['field_far_mm']:.3g} mm, past the depth budget of "
                f"+-{budget / 2:.3g} mm: it looks blurred there")
        if depth.get("empty"):
            record["warnings"].append("the depth pass hit nothing in the middle of the framed field: "
                                      "check the pose")
        elif "reason" in depth:   # blind (inside a solid) or too bright: not an empty scene
            record["warnings"].append(depth["reason"])
    record.update(depth_budget_mm=budget, depth_budget_scene_units=budget * placed.units_per_mm)
    matrix = None if placed.is_native else tuple(placed.matrix().ravel().tolist())
    limit = camera_front_clearance_limit(placed) if s.front_clearance is None else None
    settings = replace(s, pose=matrix, front_clearance_limit=limit, depth_scale=scale,
                       front_clearance_reason="" if limit is None else CAMERA_LIMIT_REASON)
    if scale != 1:
        record["depth_scale"] = scale
        record["depth_scale_note"] = (f"a distortion: depth along the display normal shown {scale:.4g} times as "
                                      "deep, lateral sizes kept (traced as every ray's slope times the factor)")
    if limit is not None:
        record["front_clearance_limit_mm"] = limit
        record["front_clearance_note"] = CAMERA_LIMIT_REASON
    return replace(request, settings=settings), record


def depth_wanted(request: RenderRequest, default: float) -> bool:
    """Whether anything reads the framed scene's depth: ``--fit-depth``, ``--depth-report``, depth maps or a
    dataset (whose users want its budget warnings), or a method that may start its rays nearer than the
    depth pass looks from (``default`` mm), so that the foreground it cuts must be measured to be said.
    Otherwise no depth pass runs: a scene camera is evaluated alone (docs/geometry.md)."""
    options, s = request.placement, request.settings
    if options.fit_depth is not None or options.depth_report or request.depth_maps is not None \
            or request.dataset is not None:
        return True
    own = get_method(request.method).default_front_clearance(request.render_array)
    return s.front_clearance is None and (own < default * (1 - 1e-9) or request.method == "single-stage")


def _check_similarity(matrix: tuple[float, ...]) -> None:
    """A pose matrix must be a rotation (or mirror) times one scale: POV-Ray's mesh camera turns its
    normals as surface normals (inverse transpose), so a shear or a depth-only scale would bend its rays."""
    m = np.asarray(matrix, dtype=np.float64).reshape(4, 3)[:3]
    gram = m @ m.T
    scale = float(np.trace(gram)) / 3
    if not (scale > 0 and np.allclose(gram, scale * np.eye(3), rtol=0, atol=1e-9 * scale)):
        raise ConfigError("the pose matrix must be a rotation times one uniform scale (no shear, "
                          "no depth-only scale); build it with povh3d.geometry.pose.DisplayPose")


#: Why a camera pose's rays start no farther out than ``camera_front_clearance_limit``.
CAMERA_LIMIT_REASON = "within 0.9 of the scene camera's distance: nothing behind the camera enters the image"


def camera_front_clearance_limit(pose: DisplayPose) -> float | None:
    """How far out (mm) rays may start in a camera pose: 0.9 of the scene camera's distance, since
    what lies behind the camera (walls) is no part of its view; None for other poses.  The methods
    round their clearance down to it (``renderer.methods.registry``), whatever their default or step."""
    if pose.source != "camera" or pose.camera_distance is None:
        return None
    return 0.9 * pose.camera_distance / pose.units_per_mm


def _front_clearance(pose: DisplayPose, default: float) -> float:
    """The front clearance (mm) of the depth pass: the method's default, within the camera's limit."""
    limit = camera_front_clearance_limit(pose)
    return default if limit is None else min(default, limit)


def _measure(request: RenderRequest, scene: Scene, pose: DisplayPose, front_clearance: float, budget: float,
             fit: str | float | None, scale: float = 1.0, fit_scale: bool = False,
             seen: DepthMap | None = None, progress: Progress | None = None
             ) -> tuple[DisplayPose, dict[str, Any], float]:
    """The depth summary in ``pose`` as the display shows it (depth times ``scale``); with ``fit``, the
    pose scaled (or, with ``fit_scale``, the depth compressed: the new ``scale``) so the depth fits first.
    ``seen``: the depth map of ``pose`` made in the run that evaluated the scene's camera; else a depth
    pass of its own."""
    array, s = request.render_array, request.settings
    keys = ("near_mm", "far_mm", "depth_mm", "field_near_mm", "field_far_mm")

    def measure(f: DisplayPose) -> dict[str, Any]:
        if seen is not None and f is pose and seen.unmeasured == 0:   # else measured on a hollow copy
            return {**seen.summary(budget), "pass": "in the camera's evaluation run"}
        matrix = None if f.is_native else tuple(f.matrix().ravel().tolist())
        return depth_pass(scene, array, replace(s, pose=matrix), front_clearance, f.units_per_mm,
                          progress).summary(budget)

    def shown(depth: dict[str, Any], factor: float) -> dict[str, Any]:
        # The display shows the measured z times ``factor`` (a depth scale, or 1 / a pose's scale).
        if "near_mm" not in depth or factor == 1:
            return depth
        after = {**depth, **{k: depth[k] * factor for k in keys}}
        # A thousandth of the budget: what --fit-depth fitted exactly may come back a rounding over.
        half, slack = budget / 2, budget * 1e-3
        after["within_budget"] = bool(-half <= after["near_mm"] + slack and after["far_mm"] - slack <= half)
        after["field_within_budget"] = bool(-half <= after["field_near_mm"] + slack
                                            and after["field_far_mm"] - slack <= half)
        return after

    depth = measure(pose)
    if fit is None:
        return pose, ({**shown(depth, scale), "measured": depth} if scale != 1 else depth), scale
    target = budget if fit == "auto" else float(fit)
    if "reason" in depth:
        raise ConfigError(f"{param('placement.fit_depth')} cannot fit: {depth['reason']}")
    if depth.get("empty") or depth["unmeasured_fraction"] > 0.5:
        raise ConfigError(f"{param('placement.fit_depth')} cannot fit: the depth pass measured nothing in the framed field "
                          "(nothing hit, or the viewpoint inside a solid object); place the display with "
                          f"{param('placement.center')}/{param('placement.normal')}/{param('placement.width')} instead")
    reach = max(abs(depth["near_mm"]), abs(depth["far_mm"]))
    if not reach > 0:
        return pose, {**depth, "fit": {"target_mm": target, "factor": 1.0}}, scale
    factor = max(1.0, reach / (target / 2))   # only ever shrink the scene onto the display
    if fit_scale:  # compress depth alone: the pose (lateral sizes) stays
        scale = 1 / factor
        if scale < DEPTH_SCALE_RANGE[0]:
            raise ConfigError(f"{param('placement.fit_depth')} cannot fit by {param('depth_scale')}: the scene reaches {reach:.4g} mm, "
                              f"a compression of {scale:.3g} is under {DEPTH_SCALE_RANGE[0]:g}; drop {param('depth_scale')} "
                              f"to shrink the whole scene, or place the display with {param('display')}-*")
        return pose, {**shown(depth, scale), "before_fit": depth,
                       "fit": {"target_mm": target, "factor": factor, "by": "depth_scale"}}, scale
    # Display z scales as 1 / factor for the same scene points (the pose scales about its centre):
    # the subject measured before fits exactly; a re-measure would see a wider field, not the same subject.
    fitted = pose.scaled(factor) if factor > 1 else pose
    return fitted, {**shown(depth, 1 / factor), "before_fit": depth,
                    "fit": {"target_mm": target, "factor": factor, "by": "units_per_mm"}}, scale


def scene_report(path: Any, lens_array: Any, options: Any = None, include_dirs: tuple = ()) -> dict[str, Any]:
    """``povh3d info SCENE``: the pose the scene would render with and its depth against the budget."""
    from ..methods.quality import RenderSettings
    from ...scene.scene import load_scene
    from .pose import PlacementOptions

    scene = load_scene(path, include_dirs)
    options = options or PlacementOptions()
    default = get_method("multi-ortho").default_front_clearance(lens_array)
    placed, record, seen = resolve_pose_and_depth(options, scene, lens_array, front_clearance=default)
    budget = depth_budget_mm(lens_array)
    front_clearance = _front_clearance(placed, default)
    matrix = None if placed.is_native else tuple(placed.matrix().ravel().tolist())
    depth = seen.depth(placed, front_clearance, lens_array) if seen else None
    if depth is None or depth.unmeasured > 0:   # a viewer inside a solid: a pass of its own, on the hollow copy
        depth = depth_pass(scene, lens_array, RenderSettings(pose=matrix), front_clearance, placed.units_per_mm)
    return {"scene": str(scene.path), "placement": {**record, **placed.as_record()},
            "depth": depth.summary(budget), "depth_budget_mm": budget,
            "depth_budget_scene_units": budget * placed.units_per_mm}
