"""A Looking Glass render: the device's views at its tile size, its quilt, and its native panel image.

``povh3d render SCENE --preset looking-glass-portrait`` renders the camera bank of
``quilt_array``: one lenticular "lens" per tile pixel over the physical panel, as many
views as the device's quilt holds, and a focal length that makes those views span the
device's view cone (``2 atan(pitch / 2 f)``, the cone the preset's focal length spans).
The views are the oblique orthographic views of the ray definition (docs/geometry.md);
the vendor's tools render off-axis perspective cameras instead (docs/displays.md
measures the difference on the device).  ``write_device_outputs`` tiles them into the
vendor's quilt (``stem_qs8x6a0.75.png`` at the device's quilt size, padded at the right
and top as the vendor's ``viewPortion`` expects) and, given the unit's ``visual.json``,
the panel image its shader would show (``mappings.looking_glass_shader.quilt_to_native``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..devices.looking_glass import Calibration, Device, read_visual
from ..errors import ConfigError
from ..geometry.lens_array import LensArray, Panel
from ..image.io import check_writable
from ..image.quilt import bank_to_quilt_order, quilt_name, views_to_quilt
from .records import base_record, write_image


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


def quilt_outputs(output: Path, device: Device, native: bool) -> tuple[Path, Path | None]:
    """The quilt's path beside ``output`` (named the vendor's way) and the native image's; both
    checked writable before any work."""
    quilt = output.with_name(quilt_name(output.stem, *device.grid, device.aspect))
    panel = output.with_name(f"{output.stem}_native.png") if native else None
    for path in (quilt, panel):
        if path is not None:
            check_writable(path)
    return quilt, panel


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


def write_device_outputs(output: Path, h3d: np.ndarray, array: LensArray, spec: dict[str, Any]) -> dict[str, Any]:
    """Write the quilt (and with a calibration the native panel image) of a device render beside
    ``output``; return the sidecar's ``quilt`` entry."""
    from ..devices.looking_glass import device
    from ..mappings.looking_glass_shader import quilt_to_native

    dev = device(spec["device"])
    cal = device_calibration(dev, spec.get("calibration"))
    quilt_path, native_path = quilt_outputs(output, dev, spec.get("calibration") is not None)
    quilt = device_quilt(h3d, array, dev)
    entry: dict[str, Any] = {"device": dev.name, "file": quilt_path.name, "grid": list(dev.grid),
                             "quilt_size": list(dev.quilt_size), "tile_size": list(dev.tile_size),
                             "aspect": dev.aspect, "view_cone_deg": cal.view_cone}
    source = {"source": str(output.resolve())}
    write_image(quilt_path, quilt, base_record("quilt", grid=list(dev.grid), aspect=dev.aspect, views=dev.views,
                                               **source))
    if native_path is not None:
        native = quilt_to_native(quilt, dev.grid, cal, views=dev.views)
        write_image(native_path, native, base_record("panel", mapping="looking-glass-shader",
                                                     calibration=str(Path(spec["calibration"]).resolve()),
                                                     size_px=[cal.screen_w, cal.screen_h], **source))
        entry["native"] = native_path.name
    return entry


def check_device_render(spec: dict[str, Any], output: Path, animated: bool) -> None:
    """Before any work: a still, the quilt (and native image) writable, the calibration the model's."""
    from ..devices.looking_glass import device

    if animated:
        raise ConfigError("a Looking Glass preset writes the quilt of a still; drop --frames, or render the "
                          "view-space image with --mapping slanted")
    dev = device(spec["device"])
    device_calibration(dev, spec.get("calibration"))
    quilt_outputs(output, dev, spec.get("calibration") is not None)
