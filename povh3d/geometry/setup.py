"""The geometry of the set-up picture (``povh3d layout``): what the display is, in display mm.

Everything here is in the display's own frame (docs/geometry.md): millimetres,
the screen at ``z = 0``, ``x`` right, ``y`` up, the viewer on ``-z``.  Content
placed by a scene's camera is brought into this frame first (the frame's
``to_display``), so the picture always shows the display at its real size.

- the screen: the panel's rectangle, ``W x H`` mm;
- the lens array's extent: its lenses' cells (turned with a rotated lattice);
- the depth-budget slab: the screen's rectangle from ``z = -N f`` to ``z = +N f``
  (``2 N f`` deep, ``geometry.fit.depth_budget_mm``);
- the viewing cone of one lens: the directions its pixels send light to the
  viewer.  A pixel at offset ``(u, v)`` from its lens centre lights the ray
  ``-(u, v, f)`` towards the viewer (the ray of a pixel, reversed), and the
  pixels under a lens reach ``|u| <= p / 2``, so the cone's half-angles are
  ``atan(px / 2f)`` and ``atan(py / 2f)`` (half the preset's viewing angle).  A
  lenticular sheet has no vertical lens: its cone is a horizontal fan as tall as
  the screen.  Drawn from the screen's centre out to the nearest distance from
  which a viewer on the axis sees every lens within its cone,
  ``D = max(W / (2 tan ax), H / (2 tan ay))``.

Pure NumPy: no files, no plotting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .lens_array import LensArray


@dataclass(frozen=True)
class SetUp:
    """The display's parts, display mm.

    Attributes
    ----------
    screen : (4, 3) float           the panel's corners, counter-clockwise from bottom left, ``z = 0``
    array : (4, 3) float            the lens array's outline (its lenses' cells), ``z = 0``
    budget_mm : float               the depth budget ``2 N f``; the slab is ``z`` in ``[-budget/2, budget/2]``
    half_angles_deg : (2,) float    the viewing cone's horizontal and vertical half-angles
                                    (vertical: nan for a lenticular sheet, which has none)
    view_angles_deg : (2,) float    the outermost views' angles ``atan(u_max / f)``, ``atan(v_max / f)``
                                    (nan when the array has no view bank)
    viewing_distance_mm : float     ``D``: the cone's length (see the module docstring)
    apex : (2, 3) float             the cone's apex, bottom and top end: the screen centre twice
                                    (lenticular: the ends of the screen's vertical centre line)
    cone_end : (4, 3) float         the far end's corners at ``z = -D``, as ``screen``
    """

    screen: np.ndarray
    array: np.ndarray
    budget_mm: float
    half_angles_deg: tuple[float, float]
    view_angles_deg: tuple[float, float]
    viewing_distance_mm: float
    apex: np.ndarray
    cone_end: np.ndarray

    @property
    def slab(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)`` (3,) mm: the box of the depth budget over the screen."""
        half = self.budget_mm / 2
        lo = np.array([self.screen[:, 0].min(), self.screen[:, 1].min(), -half])
        hi = np.array([self.screen[:, 0].max(), self.screen[:, 1].max(), half])
        return lo, hi

    def as_record(self) -> dict[str, Any]:
        lo, hi = self.slab
        return {"screen_mm": [float(hi[0] - lo[0]), float(hi[1] - lo[1])],
                "depth_budget_mm": self.budget_mm, "slab_z_mm": [float(lo[2]), float(hi[2])],
                "cone_half_angles_deg": [_plain(a) for a in self.half_angles_deg],
                "outer_view_angles_deg": [_plain(a) for a in self.view_angles_deg],
                "viewing_distance_mm": self.viewing_distance_mm}


def _plain(value: float) -> float | None:
    return None if math.isnan(value) else float(value)


def _rectangle(half_w: float, half_h: float, cx: float = 0.0, cy: float = 0.0) -> np.ndarray:
    return np.array([[cx - half_w, cy - half_h, 0.0], [cx + half_w, cy - half_h, 0.0],
                     [cx + half_w, cy + half_h, 0.0], [cx - half_w, cy + half_h, 0.0]])


def array_outline(lens_array: LensArray) -> np.ndarray:
    """(4, 3) mm: the box of the lenses' cells in the lattice's frame, turned with the lattice."""
    c = lens_array.lattice_centres().reshape(-1, 2)
    px, py = lens_array.pitch_x, lens_array.pitch_y
    lo, hi = c.min(axis=0) - (px / 2, py / 2), c.max(axis=0) + (px / 2, py / 2)
    box = _rectangle((hi[0] - lo[0]) / 2, (hi[1] - lo[1]) / 2, (hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2)
    x, y = lens_array.from_lattice(box[:, 0], box[:, 1])
    return np.stack([x, y, box[:, 2]], axis=-1)


def set_up(lens_array: LensArray, budget_mm: float) -> SetUp:
    """The display's parts for ``lens_array`` with the depth budget ``budget_mm`` (``2 N f``)."""
    w, h = lens_array.panel.size_mm
    f = lens_array.focal
    ax = math.atan(lens_array.pitch_x / (2 * f))
    lenticular = lens_array.unidirectional
    ay = math.nan if lenticular else math.atan(lens_array.pitch_y / (2 * f))
    distance = w / (2 * math.tan(ax)) if lenticular else max(w / (2 * math.tan(ax)), h / (2 * math.tan(ay)))
    reach_x = distance * math.tan(ax)
    reach_y = h / 2 if lenticular else distance * math.tan(ay)
    far = _rectangle(reach_x, reach_y)
    far[:, 2] = -distance
    apex = np.zeros((2, 3))
    if lenticular:   # a fan: the centre column of the screen, bottom to top
        apex[:, 1] = (-h / 2, h / 2)
    views = (math.nan, math.nan)
    if lens_array.views is not None:
        u, v = lens_array.view_offsets()
        views = (math.degrees(math.atan(float(np.max(np.abs(u))) / f)),
                 math.degrees(math.atan(float(np.max(np.abs(v))) / f)))
    return SetUp(screen=_rectangle(w / 2, h / 2), array=array_outline(lens_array), budget_mm=float(budget_mm),
                 half_angles_deg=(math.degrees(ax), math.degrees(ay)), view_angles_deg=views,
                 viewing_distance_mm=float(distance), apex=apex, cone_end=far)


def depth_points(z: np.ndarray, width_mm: float, height_mm: float) -> np.ndarray:
    """The hit points of a depth map: ``(n, 3)`` mm at each finite pixel's centre.

    ``z`` is ``(H, W)`` mm over a ``width_mm x height_mm`` field centred on the
    screen (``renderer.passes.depth.DepthMap``), row 0 at the top; NaN where nothing was hit.
    """
    rows, cols = z.shape
    x = (np.arange(cols) + 0.5 - cols / 2) * (width_mm / cols)
    y = (rows / 2 - np.arange(rows) - 0.5) * (height_mm / rows)
    xx, yy = np.meshgrid(x, y)
    keep = np.isfinite(z)
    return np.stack([xx[keep], yy[keep], z[keep]], axis=-1)


#: Where a content point lies against the depth budget.
INSIDE, FRONT, BEHIND = 0, 1, 2


def classify(z: np.ndarray, budget_mm: float) -> np.ndarray:
    """Per point: ``INSIDE`` the slab, ``FRONT`` (nearer the viewer than ``-budget/2``) or ``BEHIND``."""
    half = budget_mm / 2
    z = np.asarray(z, dtype=np.float64)
    return np.where(z < -half, FRONT, np.where(z > half, BEHIND, INSIDE)).astype(np.int8)


def depth_figures(z: np.ndarray, budget_mm: float) -> dict[str, Any]:
    """The content's reach in ``z`` and the share of its points outside the depth budget."""
    z = np.asarray(z, dtype=np.float64)
    z = z[np.isfinite(z)]
    if z.size == 0:
        return {"points": 0}
    kind = classify(z, budget_mm)
    return {"points": int(z.size), "near_mm": float(z.min()), "far_mm": float(z.max()),
            "depth_mm": float(z.max() - z.min()), "front_outside": float(np.mean(kind == FRONT)),
            "behind_outside": float(np.mean(kind == BEHIND)), "outside": float(np.mean(kind != INSIDE))}
