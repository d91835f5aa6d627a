"""Where a method's rays start: its front clearance (mm) for a request, worked out the same way
before the render (``renderer.placement.ray_state`` checks those origins) as in it (``methods.run_method``): both
call ``front_clearance``."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from ...geometry.lens_array import LensArray
from ...geometry.rays import depth_scaled_rays
from ..methods.quality import AUTO, RenderSettings
from ...errors import param



class Method(Protocol):
    """What this module reads of a rendering method (``methods.registry.Method``): a protocol, so the
    registry, which imports this module, is not imported back (no cycle, typing imports included)."""

    @property
    def crops(self) -> bool: ...
    @property
    def supersamples(self) -> Callable[[Any], int] | None: ...
    @property
    def default_front_clearance(self) -> Callable[[LensArray], float]: ...
    @property
    def round_front_clearance(self) -> Callable[[LensArray, float], float]: ...
    @property
    def front_clearance_step(self) -> Callable[[LensArray, Mapping[str, Any]], float]: ...


def limited_front_clearance(method: Method, lens_array: LensArray, settings: RenderSettings, asked: float,
                            rounded: float, options: Mapping[str, Any]) -> tuple[float, str]:
    """Where rays start (mm) and why: the clearance asked for (or the method's default), rounded up to
    the method's step; under ``settings.front_clearance_limit`` rounded down instead (a method whose
    rounding up passed the scene camera let a wall behind the camera fill the image)."""
    why = param("front_clearance") if settings.front_clearance else "the method's default"
    limit = settings.front_clearance_limit
    if limit is None or rounded <= limit * (1 + 1e-12):
        rounding = "" if rounded == asked else f" {asked:.4g} mm, rounded up (whole view shifts)"
        return rounded, f"{why}{rounding}"
    step = method.front_clearance_step(lens_array, options)
    used = step * math.floor(limit / step * (1 + 1e-12)) if step > 0 else limit
    return used, f"{settings.front_clearance_reason or 'limited'} ({limit:.4g} mm); {why} was {rounded:.4g} mm"


@dataclass(frozen=True)
class FrontClearance:
    """Where a method's rays start and why.

    Attributes
    ----------
    rounded : float     mm, the clearance asked for (or the method's default) rounded to the method's step:
                        what POV-Ray must be able to trace (``methods._check_clearance``)
    used : float        mm, where the rays start: ``rounded``, or under a limit rounded down to a step
    reason : str        why, for the sidecar and the summary
    lens_mesh : bool    under one view-bank step: traced through a lens mesh from the limit itself
    """

    rounded: float
    used: float
    reason: str
    lens_mesh: bool


def front_clearance(method: Method, rays: LensArray, settings: RenderSettings,
                    options: Mapping[str, Any]) -> FrontClearance:
    """The clearance ``method`` traces ``rays`` (depth scaled) from, for ``settings`` and the plan's
    ``options`` (its supersampling sets a step under a limit): asked, rounded, limited, or a lens mesh."""
    asked = settings.front_clearance or method.default_front_clearance(rays)
    rounded = method.round_front_clearance(rays, asked)
    used, reason = limited_front_clearance(method, rays, settings, asked, rounded, options)
    lens_mesh = used <= 0 and method.crops
    if lens_mesh:   # under one view-bank step: the lens mesh instead, from the limit itself
        used = settings.front_clearance_limit or used
        reason += "; traced through a lens mesh (the view bank starts only at whole steps)"
    return FrontClearance(rounded, used, reason, lens_mesh)


def planned_front_clearance(method: Method, lens_array: LensArray, settings: RenderSettings) -> float:
    """The clearance (mm) ``run_method`` will trace ``method`` from, for ``settings`` (quality resolved)."""
    # --quality auto is chosen later, with the method: its supersampling (a step under a limit) taken as 1.
    supersamples = method.supersamples if settings.quality != AUTO else None
    options = {"supersample": supersamples(settings.spec)} if supersamples is not None else {}
    return front_clearance(method, depth_scaled_rays(lens_array, settings.depth_scale), settings, options).used
