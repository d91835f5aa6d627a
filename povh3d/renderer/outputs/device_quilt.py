"""A Looking Glass render: the device's views at its tile size, its quilt, and its native panel image.

``povh3d render SCENE --preset looking-glass-portrait`` renders the device's views as the
camera bank of ``display.quilt.quilt_array`` (the device's quilt as a lens array): by default
through the vendor's sheared perspective cameras (``renderer.methods.vendor_views``), with
``--camera-model orthographic`` the oblique orthographic views of the ray definition
(docs/geometry.md; docs/displays.md measures the two).  ``write_device_outputs`` tiles them into the
vendor's quilt (``stem_qs8x6a0.75.png`` at the device's quilt size, padded at the right
and top as the vendor's ``viewPortion`` expects) and, given the unit's ``visual.json``,
the panel image its shader would show (``display.mappings.looking_glass_shader.quilt_to_native``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ...display.looking_glass import Device
from ...display.quilt import device_calibration, device_quilt, quilt_views
from ...errors import ConfigError, param
from ...geometry.lens_array import LensArray
from ...image.io import check_output
from ...image.quilt import quilt_name
from ..records import base_record, write_image
from ...image.sidecar import QuiltRecord


def quilt_outputs(output: Path, device: Device, native: bool) -> tuple[Path, Path | None]:
    """The quilt's path beside ``output`` (named the vendor's way) and the native image's; both
    checked writable before any work."""
    quilt = output.with_name(quilt_name(output.stem, *device.grid, device.aspect))
    panel = output.with_name(f"{output.stem}_native.png") if native else None
    for path in (quilt, panel):
        if path is not None:
            check_output(path)
    return quilt, panel


def write_device_outputs(output: Path, h3d: np.ndarray, array: LensArray, spec: Mapping[str, Any],
                         views: np.ndarray | None = None) -> QuiltRecord:
    """Write the quilt (and with a calibration the native panel image) of a device render beside
    ``output``; return the sidecar's ``quilt`` entry.  ``views``: the render's camera bank views, when
    the method kept them (``MethodResult.views``), which the quilt is tiled from."""
    from ...display.looking_glass import device
    from ...display.mappings.looking_glass_shader import quilt_to_native

    dev = device(spec["device"])
    cone = quilt_views(dev, spec.get("calibration"))
    quilt_path, native_path = quilt_outputs(output, dev, spec.get("calibration") is not None)
    quilt = device_quilt(h3d, array, dev, views)
    entry = QuiltRecord(device=dev.name, file=quilt_path.name, grid=dev.grid, quilt_size=dev.quilt_size,
                        tile_size=dev.tile_size, aspect=dev.aspect, view_cone_deg=cone.cone_deg,
                        view_cone_from=cone.cone_from)
    source = str(output.resolve())
    write_image(quilt_path, quilt, base_record("quilt", grid=list(dev.grid), aspect=dev.aspect, views=dev.views,
                                               source=source))
    if native_path is not None:
        cal = device_calibration(dev, spec["calibration"])
        native = quilt_to_native(quilt, dev.grid, cal, views=dev.views)
        write_image(native_path, native, base_record("panel", mapping="looking-glass-shader",
                                                     calibration=str(Path(spec["calibration"]).resolve()),
                                                     device=dev.name, size_px=[cal.screen_w, cal.screen_h],
                                                     source=source))
        return replace(entry, native=native_path.name)
    return entry


def check_device_render(spec: Mapping[str, Any], output: Path, animated: bool, depth_maps: bool = False,
                        auto_quality: bool = False) -> None:
    """Before any work: the quilt (and native image) writable, the calibration the model's.  An
    animation writes them per frame beside each (``stem_0001_qs8x6a0.75.png``, ``stem_0001_native.png``)."""
    from ...display.looking_glass import device

    if auto_quality and spec.get("camera_model") == "perspective":
        raise ConfigError(f"{param('quality')} auto scores renders of the lens array's rays, not the vendor's perspective "
                          f"cameras; give {param('quality')} draft, normal or high, or add {param('camera_model')} orthographic")
    if depth_maps and spec.get("camera_model") == "perspective":
        raise ConfigError(f"{param('depth_maps')} traces the lens array's rays, not the vendor's perspective cameras; add "
                          f"{param('camera_model')} orthographic for a Looking Glass render with depth maps")
    dev = device(spec["device"])
    quilt_views(dev, spec.get("calibration"))
    quilt_outputs(output, dev, spec.get("calibration") is not None)
