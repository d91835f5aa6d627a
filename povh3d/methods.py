"""The rendering methods, registered by name.

- ``multi-ortho``: the multi-orthographic camera bank traced in one POV-Ray
  pass through a mesh camera (one face per lens); the default, about as fast
  as a plain 2D render of the panel.
- ``multi-ortho-views``: the same bank as one orthographic camera per view
  (the BBC method as the thesis ran it), views interleaved in NumPy.
- ``pinhole``: one perspective camera per lens, the traditional baseline.

All three trace the ray of a pixel of CONVENTIONS.md; point-sampled they agree.
A method is two pure halves around the renderer: what frames to ask POV-Ray
for, and how to assemble the returned images into the H3D image.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .colour import mean_in_linear_light
from .errors import ConfigError
from .cameras import (camera_mesh, check_clearance, default_back_off, ortho_view_frames, pinhole_frames,
                      view_bank_mesh)
from .geometry import LensArray
from .interleave import interleave, tile_elemental_images, untile_views
from .render import FrameBatch, Progress, RenderSettings, RenderStats, cpu_count, render_frames
from .scene import Scene


def _multi_ortho_batch(lens_array: LensArray, back_off: float, samples: np.ndarray) -> FrameBatch:
    if lens_array.grid == "hex":
        lens_array.require_views()  # raises "render hex with single-stage"
    # Whole PPL: one quad per view (views tiled); otherwise one quad per lens.
    if lens_array.views:
        mesh = view_bank_mesh(lens_array, back_off, samples)
    else:
        _point_sampled_only(samples, "multi-ortho with a non-integral number of pixels per lens")
        mesh = camera_mesh(lens_array, back_off)
    width, height = mesh.image_size
    return FrameBatch("multi_ortho.pov.j2", {"mesh": mesh}, [{}], width, height, processes=1)


def _multi_ortho_assemble(lens_array: LensArray, images: list[np.ndarray]) -> np.ndarray:
    image = images[0][1:, :-1]  # the extra first row and last column (see cameras.CameraMesh)
    if not lens_array.views:
        return image
    ny, nx = lens_array.views
    banks = image.shape[0] // (ny * lens_array.lenses_y)  # one per footprint sample, stacked
    bank = mean_in_linear_light(image.reshape(banks, -1, *image.shape[1:])) if banks > 1 else image
    return interleave(untile_views(bank, (ny, nx)))


def _point_sampled_only(samples: np.ndarray, what: str) -> None:
    if len(samples) != 1 or np.any(samples):
        raise ConfigError(f"{what} traces one ray per pixel; use sub-views and footprint samples "
                          "with multi-ortho on whole pixels per lens")


def _views_batch(lens_array: LensArray, back_off: float, samples: np.ndarray) -> FrameBatch:
    lens_array.require_views()
    _point_sampled_only(samples, "multi-ortho-views")
    check_clearance(lens_array, back_off)
    common, frames = ortho_view_frames(lens_array)
    width, height = common.pop("width"), common.pop("height")
    # Process start-up (~0.7 s) is mostly idle, so more processes than cores
    # overlap it; a few frames per run amortise it further.
    processes = 4 * cpu_count()
    per_job = max(1, -(-len(frames) // processes))
    return FrameBatch("multi_ortho_views.pov.j2", {**common, "back_off": back_off}, frames,
                      width, height, frames_per_job=per_job, processes=processes)


def _views_assemble(lens_array: LensArray, images: list[np.ndarray]) -> np.ndarray:
    ny, nx = lens_array.require_views()
    return interleave(np.stack(images).reshape(ny, nx, *images[0].shape))


def _pinhole_batch(lens_array: LensArray, back_off: float, samples: np.ndarray) -> FrameBatch:
    lens_array.require_views()
    _point_sampled_only(samples, "pinhole")
    common, frames = pinhole_frames(lens_array)
    width, height = common.pop("width"), common.pop("height")
    processes = 2 * cpu_count()
    # Many small frames per run: each extra frame costs a re-parse, not a start-up.
    per_job = max(1, min(500, -(-len(frames) // processes)))
    return FrameBatch("pinhole.pov.j2", common, frames, width, height,
                      frames_per_job=per_job, processes=processes)


def _pinhole_assemble(lens_array: LensArray, images: list[np.ndarray]) -> np.ndarray:
    elemental = np.stack(images).reshape(lens_array.lenses_y, lens_array.lenses_x, *images[0].shape)
    return tile_elemental_images(elemental)


@dataclass(frozen=True)
class Method:
    batch: Callable[[LensArray, float, np.ndarray], FrameBatch]  # (array, back-off mm, footprint samples)
    assemble: Callable[[LensArray, list[np.ndarray]], np.ndarray]


METHODS: dict[str, Method] = {
    "multi-ortho": Method(_multi_ortho_batch, _multi_ortho_assemble),
    "multi-ortho-views": Method(_views_batch, _views_assemble),
    "pinhole": Method(_pinhole_batch, _pinhole_assemble),
}


def display_header(lens_array: LensArray, max_trace_level: int | None = None) -> dict[str, Any]:
    """Display constants the scene header declares (``Povh3d_Panel_Width`` ...)."""
    return {"panel_size": lens_array.panel.size_mm, "lens_pitch": lens_array.pitch_x,
            "focal": lens_array.focal, "max_trace_level": max_trace_level}


@dataclass
class MethodResult:
    h3d: np.ndarray          # (H, W, C) uint8 or uint16
    stats: RenderStats
    back_off: float


def run_method(name: str, scene: Scene, lens_array: LensArray, settings: RenderSettings,
               progress: Progress | None = None) -> MethodResult:
    """Render ``scene`` with method ``name`` and return the H3D image."""
    method = METHODS[name]
    back_off = settings.back_off or default_back_off(lens_array)
    quality = settings.spec
    batch = method.batch(lens_array, back_off, quality.samples())
    images, stats = render_frames(scene, batch, settings, method=name,
                                  header=display_header(lens_array, quality.max_trace_level),
                                  progress=progress)
    h3d = method.assemble(lens_array, images)
    panel_shape = (lens_array.panel.height, lens_array.panel.width)
    if h3d.shape[:2] != panel_shape:
        # A camera bank covers the lens array; the panel margin outside it stays black.
        canvas = np.zeros(panel_shape + h3d.shape[2:], h3d.dtype)
        canvas[lens_array.bank_region] = h3d
        h3d = canvas
    return MethodResult(h3d, stats, back_off)
