"""The one-pass view bank traced only where objects can be: coverage, crop, paste.

``geometry.crop`` decides which lenses of each view to keep; this module runs
the renders that decision needs through the ``trace`` function the method
runner hands it (``renderer.shots.shots.render_shots`` bound to the scene and
settings), so every image is cached and every POV-Ray process goes through
``povray.process``:

1. the coverage, unless a bounding box was given: the same mesh camera at the
   same rays with ``+Q0 +UA -A`` and a transparent background appended after the
   scene.  At quality 0 POV-Ray shades nothing (quick colours, opaque even for
   glass) but intersects everything, so alpha is exactly "this ray met an object
   that is not ``no_image``";
2. the cropped render: one quad per kept tile (per footprint sample, banks
   stacked as in ``view_bank.view_bank_shots``);
3. the paste into a canvas of the background colour, read at the cuts.

Returns None where cropping does not apply, with the reason, so the caller
renders the whole bank.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...geometry.view_bank import stack_shots, view_bank_shots
from ...geometry.crop import (CropSettings, bbox_hits, fill_colour, layout_independent,
    mask_hits, paste, plan_crop)
from ...jsontext import JSONValue
from ...errors import InputError, param
from ...geometry.footprint import CENTRE
from ...geometry.lens_array import LensArray
from ...scene.scene import Scene
from ..shots.batch import ShotBatch, RenderStats, mesh_camera_batch
from .quality import Progress, RenderSettings

# trace(batch, label, progress) -> (images, stats): one batch rendered (``renderer.shots.shots.render_shots``).
Trace = Callable[[ShotBatch, str, Progress | None], tuple[list[np.ndarray], RenderStats]]

COVERAGE_OPTIONS = ("-A", "+Q0", "+UA")


@dataclass
class CroppedTiles:
    """The uncropped tiled image (extra row and column removed) and what the crop did."""

    tiled: np.ndarray | None      # (K*Ny*Ly, Nx*Lx, C), one bank per sample; None: not cropped
    stats: RenderStats | None
    info: dict[str, JSONValue]


def coverage_mask(trace: Trace, lens_array: LensArray, front_clearance: float,
                  samples: np.ndarray = CENTRE) -> tuple[np.ndarray, RenderStats]:
    """(Ny*Ly, Nx*Lx) bool: the tiled image's pixels one of whose ``samples`` meets an object."""
    batch = mesh_camera_batch("coverage.pov.j2", view_bank_shots(lens_array, front_clearance, samples), COVERAGE_OPTIONS)
    images, stats = trace(batch, "multi-ortho coverage", None)
    alpha = stack_shots(images)[..., -1]
    return np.asarray((alpha > 0).reshape(len(samples), -1, alpha.shape[1]).any(axis=0)), stats


def render_cropped_tiles(trace: Trace, scene: Scene, lens_array: LensArray, front_clearance: float,
                         settings: RenderSettings, crop: CropSettings,
                         progress: Progress | None = None, samples: np.ndarray = CENTRE,
                         gutter: int = 0) -> CroppedTiles:
    """Render the one-pass view bank cropped to what the objects can reach.

    ``samples`` are the footprint samples of ``view_bank_shots``; each gets a
    bank, cropped alike, so the reach is that of the pixel's whole footprint.
    ``gutter``: pixels between the kept tiles (``view_bank.view_bank_shots``).

    Raises
    ------
    InputError
        A ``--bbox`` that does not hold every object (seen at the cuts).
    """
    info: dict[str, JSONValue] = {"mode": crop.mode}
    if crop.mode == "off":
        return CroppedTiles(None, None, {**info, "applied": False, "reason": f"{param('crop')} off"})
    if crop.mode == "auto" and crop.bbox is None:
        return CroppedTiles(None, None, {**info, "applied": False,
                                         "reason": f"no {param('bbox')} given ({param('crop')} measure finds it with a pre-pass)"})
    if lens_array.views is None:
        return CroppedTiles(None, None, {**info, "applied": False,
                                         "reason": "fractional pixels per lens: one quad per lens, not cropped"})
    ok, block = layout_independent(settings.options)
    if not ok:
        return CroppedTiles(None, None, {**info, "applied": False,
                                         "reason": "POV-Ray's antialiasing jitter depends on where a pixel sits "
                                                   "in the image; crop gives identical pixels only with -J or -A"})
    features = scene.features
    if not features.background_is_constant:
        used = sorted(features.used & {"fog", "media", "sky_sphere", "rainbow"})
        return CroppedTiles(None, None, {**info, "applied": False,
                                         "reason": f"the scene uses {', '.join(used)}: rays that miss every "
                                                   "object are not one colour, so nothing can be filled"})
    start = time.perf_counter()
    if crop.mode == "auto" and crop.bbox is not None:  # (always given under auto: checked above)
        col_hits, row_hits = bbox_hits(lens_array, crop.bbox, angular=bool(np.any(samples[:, 2:])))
        info["source"] = "bbox"
    else:
        mask, _ = coverage_mask(trace, lens_array, front_clearance, samples)
        col_hits, row_hits = mask_hits(mask, lens_array.views)
        info["source"] = "coverage pre-pass"
        info["coverage_fraction"] = round(float(mask.mean()), 6)
    info["plan_seconds"] = round(time.perf_counter() - start, 4)
    plan = plan_crop(col_hits, row_hits, crop.margin, block)
    info.update(plan.as_record())
    if plan.is_full:
        return CroppedTiles(None, None, {**info, "applied": False, "reason": "objects reach every lens"})

    meshes = view_bank_shots(lens_array, front_clearance, samples, plan, gutter)
    batch = mesh_camera_batch("multi_ortho.pov.j2", meshes)
    images, stats = trace(batch, "multi-ortho", progress)
    tiled = stack_shots(images, meshes)
    banks = tiled.reshape(len(samples), -1, *tiled.shape[1:])
    fills = [fill_colour(bank, plan) for bank in banks]
    first = fills[0]
    fill = first if first is not None and all(f is not None and np.array_equal(f, first) for f in fills) else None
    if fill is None:
        if info["source"] == "bbox" and crop.bbox is not None:
            raise InputError(f"objects reach outside {param('bbox')} {list(crop.bbox[0]) + list(crop.bbox[1])} "
                             "(the pixels at the crop edges are not all background); give a box that "
                             f"holds every object, or {param('crop')} off")
        return CroppedTiles(None, None, {**info, "applied": False,
                                         "reason": "the pixels at the crop edges differ: background not constant"})
    info.update(applied=True, fill=fill.tolist())
    return CroppedTiles(np.concatenate([paste(bank, plan, fill) for bank in banks]), stats, info)
