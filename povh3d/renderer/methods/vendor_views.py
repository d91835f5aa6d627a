"""A Looking Glass's views through the vendor's camera model (``display.quilt.vendor_cameras``).

One POV-Ray perspective camera per view, all from the viewer at distance ``D`` from the
screen: the scene camera's own distance to its ``look_at`` (a camera placement), else the
vendor's default viewer for a scene without one (``display.quilt.default_viewing_distance``).
The views are laid out as the camera bank of ``display.quilt.quilt_array`` (one lens per
tile pixel), so the quilt, the native image and ``--views`` read them as they read the
orthographic model's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from ...display.looking_glass import device
from ...display.quilt import default_viewing_distance, quilt_views, vendor_cameras
from ...geometry.lens_array import LensArray
from ...image.interleave import interleave
from ...image.quilt import quilt_to_bank_order
from ...scene.scene import Scene
from ...jsontext import JSONValue
from ...system import cpu_count
from ..shots.batch import ShotBatch
from ..shots.shots import render_shots
from .quality import Progress, quality_settings
from .registry import MethodResult, display_header


def viewer_distance(placement: Mapping[str, Any] | None, height_mm: float) -> tuple[float, str]:
    """The viewer's distance from the screen (mm) and where it came from: the scene camera's
    distance to its look_at (a camera placement), else the vendor's default viewer."""
    record = placement or {}
    camera = record.get("camera")
    if record.get("source") == "camera" and camera:
        gap = np.asarray(record["centre"], dtype=np.float64) - np.asarray(camera["location"], dtype=np.float64)
        normal = np.asarray(record["normal"], dtype=np.float64)
        return float(np.dot(gap, normal)) / float(record["units_per_mm"]), "the scene camera's distance to its look_at"
    return default_viewing_distance(height_mm), "the vendor's default viewer (a 14 deg vertical field)"


def run_vendor_views(scene: Scene, lens_array: LensArray, settings: Any, spec: Mapping[str, Any],
                     placement: Mapping[str, JSONValue] | None, progress: Progress | None = None) -> MethodResult:
    """Render the device's views with the vendor's cameras; return them as ``quilt_array``'s H3D image."""
    dev = device(spec["device"])
    cone = quilt_views(dev, spec.get("calibration"))
    width, height = lens_array.panel.size_mm
    distance, source = viewer_distance(placement, height)
    cameras = vendor_cameras(dev.views, cone.cone_deg, distance, (width, height))
    quality = settings.spec.point_sampled()   # one ray a pixel of a view: POV-Ray's antialiasing
    settings = replace(settings, quality=quality)
    header = display_header(lens_array)
    if settings.pose is not None:
        header.update(pose_matrix=tuple(settings.pose), pose_transform=" transform { Povh3d_Display_Pose }")
    needed = quality_settings(scene.features, quality)
    if needed:
        header["global_settings"] = needed
    tw, th = dev.tile_size
    common = {k: cameras[0][k] for k in ("right", "up")}
    shots = [{"location": c["location"], "direction": c["direction"]} for c in cameras]
    # One run per core, a few views each: each further view costs a parse, not a start-up.
    processes = min(cpu_count(), len(shots))
    batch = ShotBatch("vendor_views.pov.j2", common, shots, tw, th, shots_per_job=-(-len(shots) // processes),
                      processes=processes)
    images, stats = render_shots(scene, batch, settings, method="looking-glass", header=header, progress=progress)
    bank = quilt_to_bank_order(np.stack(images))          # (1, N, th, tw, C): bank view k = quilt view N-1-k
    h3d = interleave(bank)
    half_cone = math.radians(cone.cone_deg) / 2
    record: dict[str, JSONValue] = {"camera_model": "perspective", "viewer_distance_mm": round(distance, 4),
                                    "viewer_distance_from": source,
                                    "view_cone_deg": cone.cone_deg, "view_cone_from": cone.cone_from, "views": dev.views,
              "camera_offsets_mm": [round(-distance * math.tan(half_cone), 4), round(distance * math.tan(half_cone), 4)],
              "screen_mm": [width, height]}
    return MethodResult(h3d, stats, distance, quality, record=record,
                        front_clearance_reason=f"the viewer's eye, the vendor's cameras: {source}", views=bank)
