"""Where a method's rays start: its front clearance (mm) for a request, worked out the same way
before the render (``app.ray_state`` checks those origins) as in it (``methods.run_method``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..geometry.lens_array import LensArray
from ..geometry.rays import depth_scaled_rays
from .quality import AUTO, RenderSettings

if TYPE_CHECKING:  # only for annotations: methods imports this module
    from .methods import Method


def limited_front_clearance(method: Method, lens_array: LensArray, settings: RenderSettings, asked: float,
                            rounded: float, options: Mapping[str, Any]) -> tuple[float, str]:
    """Where rays start (mm) and why: the clearance asked for (or the method's default), rounded up to
    the method's step; under ``settings.front_clearance_limit`` rounded down instead (a method whose
    rounding up passed the scene camera let a wall behind the camera fill the image)."""
    why = "--front-clearance" if settings.front_clearance else "the method's default"
    limit = settings.front_clearance_limit
    if limit is None or rounded <= limit * (1 + 1e-12):
        step = "" if rounded == asked else f" {asked:.4g} mm, rounded up (whole view shifts)"
        return rounded, f"{why}{step}"
    step = method.front_clearance_step(lens_array, options)
    used = step * math.floor(limit / step * (1 + 1e-12)) if step > 0 else limit
    return used, f"{settings.front_clearance_reason or 'limited'} ({limit:.4g} mm); {why} was {rounded:.4g} mm"


def planned_front_clearance(method: Method, lens_array: LensArray, settings: RenderSettings) -> float:
    """The clearance (mm) ``run_method`` will trace ``method`` from, for ``settings`` (quality resolved)."""
    rays = depth_scaled_rays(lens_array, settings.depth_scale)
    asked = settings.front_clearance or method.default_front_clearance(rays)
    rounded = method.round_front_clearance(rays, asked)
    # --quality auto is chosen later, with the method: its supersampling (a step under a limit) taken as 1.
    known = method.supersamples is not None and settings.quality != AUTO
    options = {"supersample": method.supersamples(settings.spec)} if known else {}
    used, _ = limited_front_clearance(method, rays, settings, asked, rounded, options)
    if used <= 0 and method.crops:   # under one view-bank step: the lens mesh from the limit itself
        used = settings.front_clearance_limit or used
    return used
