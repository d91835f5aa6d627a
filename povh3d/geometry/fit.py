"""Content fitted to the display: the depth budget and the uniform scale that fills the panel.

Depth budget (the depth range the lens array shows sharply).  The thesis gives
no depth-of-field formula, so this is the standard one for integral imaging
with the panel a focal length behind the lenses (the conventions' set-up, the
"depth-priority" mode): a pixel of pitch ``s`` under a lens of pitch ``p`` and
focal length ``f`` sends a beam ``p`` wide (the whole aperture) that spreads
by the pixel's angle ``s / f``.  At distance ``z`` from the screen the beam,
hence the reconstructed point, is ``p + |z| s / f`` wide; it stays within one
more lens pitch (the display's 3D pixel) while ``|z| <= p f / s = N f``, with
``N = p / s`` pixels per lens.  So the sharp range is ``-N f <= z <= N f``,
``2 N f`` deep, straddling the screen (Hoshino et al., JOSA A 15, 1998: the
resolution limit ``f / (|z| s)`` of integral photography meets the lens
Nyquist limit ``1 / p`` there).  Lenticular sheets use the horizontal ``N``;
square arrays the smaller of the two.

``fit_to_display`` places a model's or a volume's box (the default stage of
``renderer/content/model.py`` and ``renderer/content/volume.py``, the set-up picture of ``commands/layout.py``);
``depth_warning`` is what they say when the placed content is deeper than the budget.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError, param
from .lens_array import LensArray

FILL = 0.9  # of the display's width and height: a margin so the model is not cut at the edge


def depth_budget_mm(lens_array: LensArray) -> float:
    """``2 N f``: the depth (mm) the array shows sharply, half in front of the screen, half behind."""
    n = lens_array.ppl_x if lens_array.unidirectional or lens_array.grid == "hex" \
        else min(lens_array.ppl_x, lens_array.ppl_y)
    return 2.0 * n * lens_array.focal


@dataclass(frozen=True)
class Fit:
    """``object { M translate shift scale scale }``: the model centred on the origin, then scaled.

    Attributes
    ----------
    shift : (3,) float, mm          minus the model's box centre
    scale : float                   uniform
    size : (3,) float, mm           the placed model's box size
    limit : {'width', 'height', 'depth'}   which of the display's limits sets the scale
    depth : float, mm               the depth budget used
    """

    shift: tuple[float, float, float]
    scale: float
    size: tuple[float, float, float]
    limit: str
    depth: float


def fit_to_display(lo: np.ndarray, hi: np.ndarray, lens_array: LensArray, *,
                   depth: float | None = None, fill: float = FILL) -> Fit:
    """Scale the box ``lo..hi`` (mm) uniformly to fill the display's panel.

    The model keeps its proportions: the scale is the largest that fits
    ``fill`` of the panel's width and height (and, with ``depth``, that depth
    in mm), and the box is centred on the origin, so the model straddles the
    screen ``z = 0``.  Without ``depth`` a deep model may reach past the depth
    budget: ``Fit.depth`` is the budget, ``size[2]`` what the model takes.
    """
    if depth is not None and not (np.isfinite(depth) and depth > 0):
        raise ConfigError(f"{param('depth')} must be a positive number of mm, got {depth!r}")
    budget = depth if depth is not None else depth_budget_mm(lens_array)
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    size = hi - lo
    width, height = lens_array.panel.size_mm
    limits = {"width": fill * width, "height": fill * height, "depth": depth if depth is not None else np.inf}
    scales = {k: limits[k] / s for k, s in zip(limits, size) if s > 0}
    if not scales:
        raise ConfigError("the model is a single point; it cannot be scaled to the display")
    limit = min(scales, key=scales.__getitem__)
    scale = scales[limit]
    return Fit(tuple((-(lo + hi) / 2).tolist()), float(scale), tuple((size * scale).tolist()), limit, float(budget))


def depth_warning(fit: Fit, what: str) -> list[str]:
    """The warning when ``what`` (``'model'``, ``'volume'``), placed, is deeper than the depth budget; else none."""
    if fit.size[2] > fit.depth * (1 + 1e-9):
        return [f"the {what} is {fit.size[2]:.3g} mm deep at this size, beyond the depth budget of "
                f"{fit.depth:.3g} mm (2 N f): its front and back look blurred; {param('depth')} "
                f"{fit.depth:.3g} fits it"]
    return []


def fit_record(fit: Fit, **extra: Any) -> dict[str, Any]:
    """The sidecar's ``fit``: scale, placed size (mm) and the limit that set the scale, and ``extra``."""
    return {"scale": fit.scale, "size_mm": list(fit.size), "limit": fit.limit, **extra}
