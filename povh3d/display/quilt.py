"""A Looking Glass device's quilt as a lens array: the camera bank whose views are the quilt's tiles.

``quilt_array`` is one lenticular "lens" per tile pixel over the physical panel, as many
views as the device's quilt holds, and a focal length that makes those views span the
device's view cone (``2 atan(pitch / 2 f)``, the cone the preset's focal length spans).
``device_quilt`` tiles a render of it the vendor's way (from the bottom left, padded at the
right and top as the vendor's ``viewPortion`` expects).

``vendor_cameras`` is the vendor's camera model instead (HoloPlay Core's
``setupVirtualCameraForView``, docs/displays.md): view ``i`` of ``N`` from the viewer moved
along its right vector by ``D tan((i / (N - 1) - 0.5) cone)``, the frustum sheared so the
plane at ``D`` (the screen) keeps its frame.  Looking Glass presets render it by default
(``camera_model="perspective"``); ``"orthographic"`` keeps the oblique orthographic views
of the lens array above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..geometry.lens_array import LensArray, Panel
from ..image.quilt import bank_to_quilt_order, views_to_quilt
from ..errors import ConfigError, param, warn
from .looking_glass import Calibration, Device, read_visual

#: The camera models of a Looking Glass render: the vendor's sheared perspective cameras (the
#: default), or the oblique orthographic views of ``quilt_array``.
CAMERA_MODELS = ("perspective", "orthographic")
#: The vendor's vertical field of view for a scene without a camera of its own (HoloPlay Core:
#: "our field of view should be about 14 deg"): the viewer at ``(H / 2) / tan(7 deg)`` from the screen.
VENDOR_FOV_DEG = 14.0


def check_camera_model(model: str) -> str:
    if model not in CAMERA_MODELS:
        raise ConfigError(f"unknown camera model {model!r}; choose one of: {', '.join(CAMERA_MODELS)}")
    return model


def default_viewing_distance(height_mm: float) -> float:
    """The vendor's default viewer distance (mm) for a screen ``height_mm`` tall: its 14 deg vertical field."""
    return 0.5 * height_mm / math.tan(math.radians(VENDOR_FOV_DEG) / 2)


def view_offsets(views: int, cone_deg: float, distance: float) -> np.ndarray:
    """How far along its right vector the camera of each view moves, ``D tan((i / (N - 1) - 0.5) cone)``
    (same unit as ``distance``), view 0 the leftmost; one view stays put."""
    if views < 1 or not distance > 0:
        raise ConfigError(f"vendor cameras need at least one view and a positive distance, got {views}, {distance!r}")
    t = np.arange(views) / (views - 1) - 0.5 if views > 1 else np.zeros(1)
    return distance * np.tan(t * math.radians(cone_deg))


def vendor_cameras(views: int, cone_deg: float, distance_mm: float, size_mm: tuple[float, float]) -> list[dict]:
    """The POV-Ray perspective camera of each view in display mm (screen ``z = 0``, viewer on
    ``-z``, ``x`` right, ``y`` up): ``location``, ``direction``, ``right``, ``up``.

    POV-Ray traces pixel ``(x, y)`` (each in -0.5..0.5) along ``direction + x right + y up``, and
    never makes ``direction`` perpendicular to ``right`` without a ``look_at``; so the eye at
    ``(s, 0, -D)`` with ``direction = (-s, 0, D)``, ``right = (W, 0, 0)``, ``up = (0, H, 0)``
    sends pixel ``(x, y)`` through the screen point ``(x W, y H, 0)`` whatever ``s``: the
    frustum sheared so the screen keeps its frame, as the vendor's projection shift does.
    """
    width, height = size_mm
    return [{"location": (float(s), 0.0, -distance_mm), "direction": (float(-s), 0.0, distance_mm),
             "right": (width, 0.0, 0.0), "up": (0.0, height, 0.0)}
            for s in view_offsets(views, cone_deg, distance_mm)]


def device_calibration(device: Device, path: str | Path | None) -> Calibration:
    """The unit's calibration (its ``visual.json``, checked to be of this model), else the factory
    one; a model with none public (the 27") is refused in one line naming ``--calibration``."""
    if path is None:
        if device.calibration is None:
            raise device.no_calibration()
        return device.calibration
    cal = read_visual(path)
    device.check(cal)
    return cal


@dataclass(frozen=True)
class QuiltViews:
    """What a device's quilt is rendered for: the view cone (degrees), the screen (width, height) mm,
    and where the cone came from (the sidecar says)."""

    cone_deg: float
    size_mm: tuple[float, float]
    cone_from: str


def quilt_views(device: Device, path: str | Path | None) -> QuiltViews:
    """The cone and screen of a quilt render: the unit's calibration, else the factory one, else
    (the 27") the family's default cone over the nominal screen, with a warning."""
    if path is not None or device.calibration is not None:
        cal = device_calibration(device, path)
        return QuiltViews(cal.view_cone, cal.size_mm, "the unit's calibration" if path is not None
                          else "the factory calibration")
    return QuiltViews(device.default_cone, device.nominal_size_mm,
                      f"the Gen3 family's default {device.default_cone:g} deg (no public factory calibration; "
                      "the unit's calibration refines it)")


def warn_default_cone(device: Device, path: str | Path | None) -> None:
    """One warning when a quilt is rendered for the family's default cone, not the unit's."""
    if path is None and device.calibration is None:
        warn(f"the {device.vendor_name} has no public factory calibration: its quilt spans the Gen3 family's "
             f"{device.default_cone:g} deg cone; give the unit's visual.json with {param('calibration')} "
             "for its own cone and the panel image")


def sheet_focal(cal: Calibration) -> float:
    """The effective focal length (mm) of a calibration's sheet: ``lens pitch / (2 tan(cone / 2))``,
    the presets' definition (docs/displays.md)."""
    return cal.lens_pitch_mm / (2 * math.tan(math.radians(cal.view_cone) / 2))


def quilt_array(device: Device, views: QuiltViews) -> LensArray:
    """The lenticular array whose camera bank is the device's quilt: ``tile_w`` lenses across
    the physical panel, ``tile_h`` rows, ``views`` pixels per lens, and the focal length
    that spans the view cone."""
    tw, th = device.tile_size
    n = device.views
    width, height = views.size_mm
    pitch_x, pitch_y = width / tw, height / th
    focal = pitch_x / (2 * math.tan(math.radians(views.cone_deg) / 2))
    return LensArray("lenticular", tw, th, pitch_x, pitch_y, focal, Panel(tw * n, th, pitch_x / n, pitch_y))


def device_quilt(h3d: np.ndarray, array: LensArray, device: Device, views: np.ndarray | None = None) -> np.ndarray:
    """The device's quilt ``(Hq, Wq, C)`` of a render of ``quilt_array``: tiles from the bottom
    left, padding (black) right and top up to the device's quilt size.  ``views``: the render's
    ``(1, N, Ly, Lx, C)`` camera bank views where it has them apart (the same pixels as ``h3d``'s,
    each view whole in memory: a twentieth of the CPU of gathering every view back out of ``h3d``)."""
    ny, n = array.require_views()
    if views is not None:
        bank = views
    else:
        region = h3d[array.bank_region]
        # one row of views: bank view k, pixel (i, j) is region[i, j n + k] (interleave.extract's
        # layout, by a reshape: no compiled gather to load for one image)
        bank = region.reshape(region.shape[0], array.lenses_x, n, region.shape[2]).transpose(2, 0, 1, 3)[None]
    return views_to_quilt(bank_to_quilt_order(bank), *device.grid, size=device.quilt_size)   # each tile copied once, into place
