"""A Looking Glass device's quilt as a lens array: the camera bank whose views are the quilt's tiles.

``quilt_array`` is one lenticular "lens" per tile pixel over the physical panel, as many
views as the device's quilt holds, and a focal length that makes those views span the
device's view cone (``2 atan(pitch / 2 f)``, the cone the preset's focal length spans).
``device_quilt`` tiles a render of it the vendor's way (from the bottom left, padded at the
right and top as the vendor's ``viewPortion`` expects).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..geometry.lens_array import LensArray, Panel
from ..image.quilt import bank_to_quilt_order, views_to_quilt
from .looking_glass import Calibration, Device, read_visual


def device_calibration(device: Device, path: str | Path | None) -> Calibration:
    """The unit's calibration (its ``visual.json``, checked to be of this model), else the factory one."""
    if path is None:
        return device.calibration
    cal = read_visual(path)
    device.check(cal)
    return cal


def quilt_array(device: Device, cal: Calibration) -> LensArray:
    """The lenticular array whose camera bank is the device's quilt: ``tile_w`` lenses across
    the physical panel, ``tile_h`` rows, ``views`` pixels per lens, and the focal length
    that spans the calibration's view cone."""
    tw, th = device.tile_size
    n = device.views
    width, height = cal.size_mm
    pitch_x, pitch_y = width / tw, height / th
    focal = pitch_x / (2 * math.tan(math.radians(cal.view_cone) / 2))
    return LensArray("lenticular", tw, th, pitch_x, pitch_y, focal, Panel(tw * n, th, pitch_x / n, pitch_y))


def device_quilt(h3d: np.ndarray, array: LensArray, device: Device) -> np.ndarray:
    """The device's quilt ``(Hq, Wq, C)`` of a render of ``quilt_array``: tiles from the bottom
    left, padding (black) right and top up to the device's quilt size."""
    ny, n = array.require_views()
    region = h3d[array.bank_region]
    # one row of views: bank view k, pixel (i, j) is region[i, j n + k] (interleave.extract's
    # layout, by a reshape: no compiled gather to load for one image)
    bank = region.reshape(region.shape[0], array.lenses_x, n, region.shape[2]).transpose(2, 0, 1, 3)[None]
    views = bank_to_quilt_order(bank)
    tiled = views_to_quilt(views, *device.grid)
    wq, hq = device.quilt_size
    if tiled.shape[0] > hq or tiled.shape[1] > wq:   # a bug: the tiles are the quilt divided by the grid
        raise RuntimeError(f"a {tiled.shape[1]}x{tiled.shape[0]} grid of tiles exceeds the {wq}x{hq} quilt")
    return np.pad(tiled, ((hq - tiled.shape[0], 0), (0, wq - tiled.shape[1]), (0, 0)))
