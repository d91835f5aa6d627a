"""The subpixels of a rational slanted sheet, grouped by phase into rectangular tiles.

On a lenticular sheet the position of a (sub)pixel across its lens, in lens
pitches, is affine in its column ``k`` and row ``l``: ``t = t0 + gk k + gl l``
(docs/geometry.md, "The ray of a pixel"; the lens is ``floor(t)``).  Real slanted
panels are rational: the Philips sheet spans 4.5 subpixels a row and moves 0.5
subpixels a row (``gk = 2/9``, ``gl = -1/9``), Alioscopy's 8 and 1.  Then with
``A gk`` and ``B gl`` whole numbers, the subpixels ``(a + A m, b + B i)`` of one
coset ``(a, b)`` all sit at one phase: one direction, a ray origin affine in
``(m, i)`` and a lens index ``floor(t_ab) + m A gk + i B gl``.  So each coset is
one orthographic view sampled on a rectangular grid, and all ``A x B`` of them
tile a mesh-camera image of (almost exactly) the panel's size with one quad each.

POV-Ray's mesh camera finds a pixel's face by testing the faces of a 10 x 10 grid
cell of UV space in turn, so a mesh of thousands of lenticule strips costs more
than the rays themselves (measured: 4.7 s against 2.0 s at 4800 x 1200); a few
dozen tiles cost nothing.  No face edge lies near a pixel centre, not even for a
subpixel centre exactly on a lens border (a tie, decided as ``pixel_rays`` does).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .camera_mesh import CameraMesh, _quad_mesh, check_front_clearance
from .lens_array import LensArray

#: Most cosets per axis tried: the thesis's panels need 9 (Philips) and 8 (Alioscopy).
MAX_PERIOD = 64
#: How far the phase of a coset may drift over its tile, as a ray offset in mm: a
#: sheet this close to rational is traced as if rational (float rounding, not geometry).
DRIFT_MM = 1e-10


@dataclass(frozen=True)
class PhaseTiles:
    """The tile layout of a sheet: coset ``(a, b)`` at image block ``(b, a)`` of ``I x M`` pixels.

    Image pixel ``(b I + i, a M + m)`` is panel pixel ``(row b + B i, column a + A m)``.
    """

    period: tuple[int, int]     # (A, B): columns and rows of a coset's step
    tile: tuple[int, int]       # (M, I): a tile's columns and rows
    panel: tuple[int, int]      # (W, H) of the panel traced

    @property
    def image_size(self) -> tuple[int, int]:
        (a, b), (m, i) = self.period, self.tile
        return (a * m, b * i)

    def panel_index(self) -> tuple[np.ndarray, np.ndarray]:
        """Image row of every panel row ``(H,)`` and image column of every panel column ``(W,)``."""
        (a, b), (m, i) = self.period, self.tile
        w, h = self.panel
        k, l = np.arange(w), np.arange(h)
        return (l % b) * i + l // b, (k % a) * m + k // a

    def to_panel(self, image: np.ndarray) -> np.ndarray:
        """The panel out of a tiled image (its extra first row and last column already cut)."""
        rows, cols = self.panel_index()
        return image[rows[:, None], cols[None, :]]


def _period(g: float, extent: int, pitch: float) -> int | None:
    """Least ``P <= MAX_PERIOD`` making ``P g`` whole, up to a drift of ``DRIFT_MM`` over ``extent / P`` steps."""
    for p in range(1, MAX_PERIOD + 1):
        if abs(p * g - round(p * g)) * math.ceil(extent / p) * pitch <= DRIFT_MM:
            return p
    return None


def _phase_gradient(la: LensArray, shift: float = 0.0) -> tuple[float, float, float]:
    """``t0, gk, gl``: pixel ``(k, l)`` lies ``t0 + gk k + gl l`` lens pitches across the
    sheet (lens ``floor`` of it); the steps worked out, not differenced, to keep them exact.

    ``shift`` (mm): the lenticules' axes lie this far further across (the lattice's ``x``)
    than the centred sheet's (a calibrated sheet's phase, ``display.subpixel``)."""
    X, Y = la.panel.pixel_centres()
    x0, _ = la.to_lattice(np.array(X[0]), np.array(Y[0]))
    turn = math.radians(la.rotation)
    gk = math.cos(turn) * la.panel.pitch_x / la.pitch_x
    gl = -math.sin(turn) * la.panel.pitch_y / la.pitch_x   # a row down is -pitch_y
    return (float(x0) - shift) / la.pitch_x + la.lenses_x / 2, gk, gl


def phase_tiles(lens_array: LensArray) -> PhaseTiles | None:
    """The tile layout of a lenticular sheet whose phases repeat within ``MAX_PERIOD``, else None."""
    la = lens_array
    if la.grid != "lenticular":
        return None
    _, gk, gl = _phase_gradient(la)
    w, h = la.panel.width, la.panel.height
    a = _period(gk, w, la.pitch_x)
    b = _period(gl, h, la.pitch_x)
    if a is None or b is None:
        return None
    return PhaseTiles((a, b), (math.ceil(w / a), math.ceil(h / b)), (w, h))


def uncovered(lens_array: LensArray, shift: float = 0.0) -> np.ndarray | None:
    """``(H, W)`` True where a pixel lies outside every lenticule (no ray: black), or None if none does."""
    la = lens_array
    t0, gk, gl = _phase_gradient(la, shift)
    k, l = np.arange(la.panel.width), np.arange(la.panel.height)
    corners = t0 + np.array([0, k[-1]])[None, :] * gk + np.array([0, l[-1]])[:, None] * gl + 1e-9
    if np.floor(corners.min()) >= 0 and np.floor(corners.max()) < la.lenses_x:  # t is affine: corners bound it
        return None
    j = np.floor(t0 + k[None, :] * gk + l[:, None] * gl + 1e-9)
    return (j < 0) | (j >= la.lenses_x)


def tiles_mesh(lens_array: LensArray, tiles: PhaseTiles, front_clearance: float,
               sample: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0), shift: float = 0.0) -> CameraMesh:
    """The mesh camera of ``tiles``: one quad per coset, the quad edges half a pixel outside its pixels.

    A corner at fractional coset position ``(m, i)`` carries the affine extension of the
    coset's rays: panel point of column ``a + A m``, row ``b + B i``; lens ``n_ab + m nA + i nB``;
    through that lens's axis beside the point, square to it, at the coset's one offset ``u``.

    ``sample`` is a point ``(ax, ay, du, dv)`` of every pixel's footprint (``geometry.footprint``,
    docs/geometry.md "Pixel footprint"): the light of the point ``(du, dv)`` pixel pitches from the
    pixel's centre, which picks the lens and the direction, through the point ``(ax, ay)`` of that
    lens's aperture (lens pitch across, pixel pitch along).  The whole coset shares one phase, so
    its sample still shares one lens offset and one direction: one quad stays exact.

    ``shift`` moves the lenticules across by that many mm (``_phase_gradient``).
    """
    check_front_clearance(lens_array, front_clearance)
    la = lens_array
    (A, B), (M, I) = tiles.period, tiles.tile
    W, H = la.panel.width, la.panel.height
    t0, gk, gl = _phase_gradient(la, shift)
    nA, nB = round(A * gk), round(B * gl)
    ax, ay, du, dv = (float(v) for v in sample)
    dx, dy = la.to_lattice(du * la.panel.pitch_x, dv * la.panel.pitch_y)  # the emitting point's offset
    a, b = (g.ravel()[:, None] for g in np.meshgrid(np.arange(A), np.arange(B)))   # (A B, 1) cosets
    # pixel_rays' rule: a point on a lens border belongs to the lens on its right.
    n = np.floor(t0 + a * gk + b * gl + dx / la.pitch_x + 1e-9)
    m = np.array([-0.5, M - 0.5, M - 0.5, -0.5])[None, :]           # corners: bottom left, counter-clockwise
    i = np.array([I - 0.5, I - 0.5, -0.5, -0.5])[None, :]
    k, l = a + A * m, b + B * i                                       # fractional panel column and row
    X = (k + 0.5 - W / 2) * la.panel.pitch_x
    Y = (H / 2 - l - 0.5) * la.panel.pitch_y
    xl, yl = la.to_lattice(X, Y)
    cx = (n + m * nA + i * nB + 0.5 - la.lenses_x / 2) * la.pitch_x + shift  # the lens axis, lattice frame
    u = xl + dx - cx
    v = np.full_like(u, dy)
    ox, oy = la.from_lattice(cx + ax * la.pitch_x - u * (front_clearance / la.focal),
                             yl + ay * la.pitch_y - v * (front_clearance / la.focal))
    ux, uy = la.from_lattice(u, v)
    col, row = a * M + m, b * I + i
    return _quad_mesh(ox, oy, ux, uy, col, row, tiles.image_size, front_clearance, la.focal)
