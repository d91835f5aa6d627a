"""The rendering methods, registered by name.

- ``multi-ortho``: the multi-orthographic camera bank traced in one POV-Ray
  pass through a mesh camera (one face per lens); the default, about as fast
  as a plain 2D render of the panel.
- ``multi-ortho-views``: the same bank as one orthographic camera per view
  (the BBC method as the thesis ran it), views interleaved in NumPy.
- ``pinhole``: one perspective camera per lens, the traditional baseline.
- ``single-stage``: a virtual array of CSG lenslets with an index of
  refraction, rendered by one orthographic camera (thesis 3.3): a physical
  simulation, compared with the others by an error figure
  (``povh3d/single_stage.py``).

All three trace the ray of a pixel of CONVENTIONS.md; point-sampled they agree.
A method is two pure halves around the renderer: what frames to ask POV-Ray
for, and how to assemble the returned images into the H3D image.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .colour import mean_in_linear_light
from .cameras import (bank_back_off, camera_mesh, check_clearance, default_back_off, ortho_view_frames,
                      pinhole_frames, stack_frames, view_bank_frames)
from .errors import ConfigError
from .crop import CropSettings
from .crop_render import render_cropped_tiles
from .features import quality_settings, scene_features
from .geometry import LensArray
from .interleave import interleave, tile_elemental_images, untile_views
from .render import (FrameBatch, Progress, Quality, RenderSettings, RenderStats, cpu_count, mesh_camera_batch,
                     render_frames)
from .scene import Scene
from .single_stage import SingleStagePlan, default_depth, lenslet_for


def _multi_ortho_batch(lens_array: LensArray, back_off: float, samples: np.ndarray) -> FrameBatch:
    if lens_array.grid == "hex":
        lens_array.require_views()  # raises "render hex with single-stage"
    if not lens_array.views:  # fractional PPL: one quad per lens
        return mesh_camera_batch("multi_ortho.pov.j2", [camera_mesh(lens_array, back_off)])
    # Whole PPL: one quad per view (views tiled), one bank per footprint sample, a few banks a frame.
    return mesh_camera_batch("multi_ortho.pov.j2", view_bank_frames(lens_array, back_off, samples))


def _multi_ortho_assemble(lens_array: LensArray, images: list[np.ndarray]) -> np.ndarray:
    image = stack_frames(images)
    return _banks_to_h3d(lens_array, image) if lens_array.views else image


def _banks_to_h3d(lens_array: LensArray, image: np.ndarray) -> np.ndarray:
    """The H3D image of tiled view banks stacked one per footprint sample (averaged in linear light)."""
    ny, nx = lens_array.require_views()
    banks = image.shape[0] // (ny * lens_array.lenses_y)
    bank = mean_in_linear_light(image.reshape(banks, -1, *image.shape[1:])) if banks > 1 else image
    return interleave(untile_views(bank, (ny, nx)))


def _views_batch(lens_array: LensArray, back_off: float, samples: np.ndarray) -> FrameBatch:
    lens_array.require_views()
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


def _single_stage_plan(lens_array: LensArray, back_off: float, lenslet: str = "conic",
                       ior: float | None = None) -> SingleStagePlan:
    return SingleStagePlan.for_clearance(lens_array, lenslet_for(lens_array, lenslet, ior), back_off)


def _single_stage_batch(lens_array: LensArray, back_off: float, samples: np.ndarray,
                        **options: Any) -> FrameBatch:
    return _single_stage_plan(lens_array, back_off, **options).batch()


def _single_stage_assemble(lens_array: LensArray, images: list[np.ndarray], *, back_off: float,
                           **options: Any) -> np.ndarray:
    return _single_stage_plan(lens_array, back_off, **options).assemble(images[0])


@dataclass(frozen=True)
class Method:
    # batch(array, back-off mm, footprint samples (K, 4), **options)
    batch: Callable[..., FrameBatch]
    assemble: Callable[..., np.ndarray]
    # Keyword options the method takes (CLI --lenslet, --ior); a method with
    # options gets them, and back_off, in both batch() and assemble().
    options: tuple[str, ...] = ()
    default_back_off: Callable[[LensArray], float] = default_back_off
    # Whether the method can trace footprint samples (sub-views) for this array;
    # where it cannot, a quality that asks for them falls back to antialiasing.
    takes_samples: Callable[[LensArray], bool] = lambda lens_array: False


METHODS: dict[str, Method] = {
    "multi-ortho": Method(_multi_ortho_batch, _multi_ortho_assemble,
                          takes_samples=lambda lens_array: lens_array.views is not None),
    "multi-ortho-views": Method(_views_batch, _views_assemble),
    "pinhole": Method(_pinhole_batch, _pinhole_assemble),
    "single-stage": Method(_single_stage_batch, _single_stage_assemble, ("lenslet", "ior"), default_depth),
}


def display_header(lens_array: LensArray) -> dict[str, Any]:
    """Display constants the scene header declares (``Povh3d_Panel_Width`` ...)."""
    return {"panel_size": lens_array.panel.size_mm, "lens_pitch": lens_array.pitch_x,
            "focal": lens_array.focal}


@dataclass
class MethodResult:
    h3d: np.ndarray          # (H, W, C) uint8 or uint16
    stats: RenderStats
    back_off: float
    quality: Quality         # as rendered (after any fallback to antialiasing)
    crop: dict[str, Any] | None = None  # what the crop did (multi-ortho), for the sidecar


def run_method(name: str, scene: Scene, lens_array: LensArray, settings: RenderSettings,
               progress: Progress | None = None, crop: CropSettings | None = None,
               **options: Any) -> MethodResult:
    """Render ``scene`` with method ``name`` and return the H3D image.

    ``options`` are the method's own (``single-stage``: ``lenslet``, ``ior``);
    None values count as not given.  ``crop`` (multi-ortho only): trace each view
    only where objects can be, fill the rest with the background
    (``crop_render``); None renders everything.
    """
    method = METHODS[name]
    options = {k: v for k, v in options.items() if v is not None}
    unknown = sorted(set(options) - set(method.options))
    if unknown:
        raise ConfigError(f"method {name!r} takes no option {', '.join(unknown)}; "
                          f"drop it or pick a method that does")
    back_off = settings.back_off or method.default_back_off(lens_array)
    if name == "multi-ortho" and lens_array.views:
        back_off = bank_back_off(lens_array, back_off)  # where its rays really start (the sidecar's figure)
    extra = {"back_off": back_off, **options} if method.options else {}
    quality = settings.spec if method.takes_samples(lens_array) else settings.spec.point_sampled()
    if quality != settings.spec:
        settings = replace(settings, quality=quality)
    samples = quality.samples()
    header = display_header(lens_array)
    settings_needed = quality_settings(scene_features(scene), quality)
    if settings_needed:
        header["global_settings"] = settings_needed
    h3d, crop_info = None, None
    if name == "multi-ortho" and crop is not None:
        tiles = render_cropped_tiles(scene, lens_array, back_off, settings, crop, header, progress, samples)
        crop_info = tiles.info
        if tiles.tiled is not None:
            h3d, stats = _banks_to_h3d(lens_array, tiles.tiled), tiles.stats
    if h3d is None:
        batch = method.batch(lens_array, back_off, samples, **options)
        images, stats = render_frames(scene, batch, settings, method=name, header=header, progress=progress)
        h3d = method.assemble(lens_array, images, **extra)
    panel_shape = (lens_array.panel.height, lens_array.panel.width)
    if h3d.shape[:2] != panel_shape:
        # A camera bank covers the lens array; the panel margin outside it stays black.
        canvas = np.zeros(panel_shape + h3d.shape[2:], h3d.dtype)
        canvas[lens_array.bank_region] = h3d
        h3d = canvas
    return MethodResult(h3d, stats, back_off, quality, crop_info)
