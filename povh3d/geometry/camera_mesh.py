"""The mesh camera value and the front clearance every camera starts its rays at.

Pure: NumPy arrays and numbers.  A ``CameraMesh`` is what ``templates/multi_ortho.pov.j2``
writes as a POV-Ray ``mesh_camera``; ``geometry.cameras`` and ``geometry.view_bank`` build
them.  This module imports no other geometry module, so the two builders stay shallow.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError, param

if TYPE_CHECKING:
    from .lens_array import LensArray

# POV-Ray 3.7 ignores surfaces nearer than 1e-4 mm or further than 1e7 mm along a
# ray from its start (measured with a plane: missed at 0.95e-4 mm, seen at
# 1.05e-4 mm; views vanish once the path to the screen passes 1e7 mm).  Both are
# absolute, so they decide which scene scales povh3d's cameras can render.
POVRAY_MIN_DEPTH = 1e-4
POVRAY_MAX_DEPTH = 1e7
#: The least front clearance, mm: a hundred times POV-Ray's nearest depth, so a
#: tiny panel (scene scaled to micrometres) still sees its screen.
MIN_FRONT_CLEARANCE = 100 * POVRAY_MIN_DEPTH


def default_front_clearance(lens_array: LensArray) -> float:
    """How far in front of the screen rays start, mm: four panel widths, at least 0.01 mm.

    Far enough for any object a display can show in front of its screen, near
    enough that POV-Ray's single-precision mesh vertices (mesh camera) keep the
    sample grid within about 1e-6 panel widths.  The floor keeps the screen
    beyond POV-Ray's nearest intersection depth on panels under 2.5 um wide.
    """
    width, height = lens_array.panel.size_mm
    return max(4.0 * max(width, height), MIN_FRONT_CLEARANCE)


def ray_stretch(lens_array: LensArray) -> float:
    """Path length per mm of depth of the most oblique pixel ray, ``max |d| / d_z``.

    Bounded with the largest pixel offset from a lens centre: half the pitch
    (hex: the cell's circumradius ``px / sqrt(3)``; lenticular: ``v = 0``; lattice:
    the parallelogram's longer half-diagonal).
    """
    f = lens_array.focal
    if lens_array.grid == "hex":
        hx, hy = lens_array.pitch_x / np.sqrt(3), 0.0
    elif lens_array.grid == "lattice":
        a1, a2 = np.array(lens_array.basis)
        hx, hy = max(abs(a1 + a2) / 2, abs(a1 - a2) / 2, key=lambda h: float(h @ h))
    else:
        hx = lens_array.pitch_x / 2
        hy = 0.0 if lens_array.grid == "lenticular" else lens_array.pitch_y / 2
    return float(np.sqrt(hx * hx + hy * hy + f * f) / f)


def clearance_range(lens_array: LensArray, units_per_mm: float = 1.0) -> tuple[float, float]:
    """The front clearances (mm) POV-Ray can trace: ``(least, most)``.

    POV-Ray's depth limits are in scene units (``units_per_mm`` per display mm): the
    screen at least ``MIN_FRONT_CLEARANCE`` scene units from where rays start, the
    most oblique ray's path to it (``front_clearance * ray_stretch``) under half of
    ``POVRAY_MAX_DEPTH`` scene units, leaving as much again for the scene behind.
    Both bounds hold in mm too (the builders check in mm), so the range is never
    wider than the one at one unit per mm.
    """
    units = float(units_per_mm)
    least = MIN_FRONT_CLEARANCE * max(1.0, 1.0 / units)
    most = POVRAY_MAX_DEPTH / 2 / ray_stretch(lens_array) / max(1.0, units)
    return least, most


def check_front_clearance(lens_array: LensArray, front_clearance: float, units_per_mm: float = 1.0,
                          accepted: tuple[float, float] | None = None) -> None:
    """Refuse a front clearance POV-Ray cannot trace (ConfigError naming the range that works).

    Rays start ``front_clearance`` mm in front of the screen (``clearance_range``; the
    checks are in scene units, ``units_per_mm`` per mm).  ``accepted``: the range of
    requests that a method which rounds the clearance (view banks) turns into one that
    passes, for the advice; the range itself by default.
    """
    least, most = clearance_range(lens_array, units_per_mm)
    lo, hi = accepted if accepted is not None else (least, most)
    units = float(units_per_mm)
    unit = "scene units" if units > 1 else "mm"   # whichever bound binds
    near_unit = "scene units" if units < 1 else "mm"
    scale = "" if units == 1 else f" ({units:g} scene units per mm)"
    if most < least or hi < lo:  # no clearance works: the display itself is out of POV-Ray's reach
        w, h = lens_array.panel.size_mm
        raise ConfigError(
            f"a {w:.4g} x {h:.4g} mm display with rays this oblique is beyond POV-Ray's {POVRAY_MAX_DEPTH:g} {unit} "
            f"ray length{scale} whatever the front clearance; check {param('pixel_pitch')} and {param('focal')} (mm), or "
            "model the scene and the display in larger units (smaller numbers)")
    if not front_clearance >= least:
        raise ConfigError(
            f"the front clearance {front_clearance:g} mm is under {least:g} mm{scale}: POV-Ray ignores surfaces "
            f"nearer than {POVRAY_MIN_DEPTH:g} {near_unit} to where a ray starts; use {param('front_clearance')} {lo:.6g} or more")
    if front_clearance > most:
        path = front_clearance * ray_stretch(lens_array) * max(units, 1.0)
        raise ConfigError(
            f"rays starting {front_clearance:.6g} mm in front of the screen travel {path:.4g} {unit} to reach it{scale}, "
            f"over half of POV-Ray's {POVRAY_MAX_DEPTH:g} {unit} ray length, so the scene behind it would vanish; "
            f"use {param('front_clearance')} between {lo:.6g} and {hi:.6g} mm (or model the scene in smaller units)")


# -- the same bank in one pass: a mesh camera ----------------------------------------

@dataclass(frozen=True)
class CameraMesh:
    """A ``mesh_camera`` mesh whose UV lookup yields every panel pixel's ray.

    POV-Ray 3.7's ``mesh_camera { 1 3 mesh { M } smooth }`` looks image pixel
    ``(col, row)`` up at ``(col/W, 1 - row/H)`` in the mesh's UV space (measured;
    not the pixel centre) and shoots a ray from the interpolated position along
    the interpolated normal.  Image row 0 is looked up at ``1 - 0.5/H`` instead,
    and the last image column half a pixel off too (both measured), so the
    render has one extra row on top and one extra column on the right, both cut
    off: panel pixel ``(c, r)`` is image pixel ``(c, r + 1)``.  Lens faces meet at pixel borders, half a pixel from any
    lookup, so no point sample lands on an edge; antialiasing samples that cross
    a border get the neighbouring lens, as the physical pixel area would.

    POV-Ray stores vertices and normals in single precision.  ``scale`` is
    a transform of the mesh (``scale <sx, sy, sz>``, applied in double
    precision: POV-Ray moves origins by it and directions by its inverse, as
    surface normals): view banks are written in lens-pitch units, where every
    corner is a multiple of 1/GRID (``footprint.GRID``) and so stored exactly.

    Attributes
    ----------
    vertices : (n, 3) float            ray origins at z = -front_clearance, in mm / ``scale``
    normals : (n, 3) float              ray directions ``(u, v, f)`` times ``scale``
    uvs : (n, 2) float                  lookup coordinates
    faces : (m, 3) int
    image_size : (int, int)             ``(W + 1, H + 1)`` to render
    scale : (3,) float                  mm per vertex unit along x, y, z
    """

    vertices: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray
    faces: np.ndarray
    image_size: tuple[int, int]
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    margin: tuple[int, int] = (0, 0)  # (columns, rows) of canvas around the panel, cut off after
    # x, y map K (2 x 2, row-major) after ``scale``: origins by K, directions by K^-T (``lattice_mesh``).
    shear: tuple[float, float, float, float] | None = None
    # View banks with gutters (``view_bank_shots``): the image columns and rows that hold
    # pixels, counted after the extra first row and last column are cut; None: all of them.
    kept: tuple[np.ndarray, np.ndarray] | None = None
    # A footprint sample's angle on a lens mesh (``sampled_corners``): every ray direction
    # (dx, dy, dz) becomes (dx + a dz, dy + b dz, dz), written as the mesh ``matrix``
    # <1, 0, -a, 0, 1, -b, 0, 0, 1, 0, 0, 0> (directions go by its inverse transpose).
    direction_shear: tuple[float, float] | None = None

    def crop(self, image: np.ndarray) -> np.ndarray:
        """The panel out of a rendered frame (extra first row and last column already cut)."""
        mx, my = self.margin
        if not (mx or my):
            return image
        w, h = self.image_size
        return image[my:h - 1 - my, mx:w - 1 - mx]

    def without_gutters(self, image: np.ndarray) -> np.ndarray:
        """A rendered frame (extra first row and last column already cut) without its gutters."""
        if self.kept is None:
            return image
        cols, rows = self.kept
        return image[np.ix_(rows, cols)]


# How far lens quads are moved off pixel centres that lie on lens borders, in
# pixels: well above the error of POV-Ray's float32 UV lookup (about 1e-4 pixel
# on a 2000-pixel panel), well below anything a ray could resolve.


def _quad_mesh(origin_x: np.ndarray, origin_y: np.ndarray, u: np.ndarray, v: np.ndarray,
               col: np.ndarray, row: np.ndarray, size: tuple[int, int], front_clearance: float,
               focal: float, scale: tuple[float, float, float] = (1.0, 1.0, 1.0),
               z: np.ndarray | float | None = None) -> CameraMesh:
    """A CameraMesh from ``(quads, 4)`` corner values, corners counter-clockwise.

    ``col``/``row`` are fractional pixel positions of the corners in a
    ``W x H`` image; POV-Ray's lookup rules (extra first row and last column,
    see ``CameraMesh``) turn them into UV here and only here.
    """
    W, H = size
    shape = np.broadcast_shapes(origin_x.shape, origin_y.shape, u.shape, v.shape, col.shape, row.shape)
    def full(*values):
        return [np.broadcast_to(np.asarray(a, dtype=np.float64), shape) for a in values]

    uv = np.stack(full(col / (W + 1), 1.0 - (row + 1.0) / (H + 1)), axis=-1)
    vertices = np.stack(full(origin_x, origin_y, -front_clearance if z is None else z), axis=-1).reshape(-1, 3)
    normals = np.stack(full(u, v, focal), axis=-1).reshape(-1, 3)
    # A convex polygon per lens (quads; hexagons) as a fan of triangles from corner 0.
    n = shape[1]
    base = n * np.arange(shape[0])[:, None]
    faces = np.concatenate([base + [0, t, t + 1] for t in range(1, n - 1)], axis=1).reshape(-1, 3)
    return CameraMesh(vertices, normals, uv.reshape(-1, 2), faces.astype(np.int64), (W + 1, H + 1),
                      (float(scale[0]), float(scale[1]), float(scale[2])))


def tiled_views_mesh(slopes: np.ndarray, views: tuple[int, int], cells: tuple[int, int],
                     pitch: tuple[float, float], front_clearance: float) -> CameraMesh:
    """Orthographic views tiled into one mesh camera: view ``n = l Nx + k`` of slopes ``(a, b)`` (``slopes``
    ``(Ny Nx, 2)``) fills image tile ``(l, k)`` of ``cols x rows`` pixels, and its pixel ``(i, j)`` is the
    ray of direction ``(a, b, 1)`` through ``(x_j, y_i, 0)``, the centre of cell ``(j, i)`` of a
    ``cols x rows`` grid of ``pitch`` centred on the origin (row 0 on top), started ``front_clearance``
    mm before the screen: the rays of an ``orthographic`` camera along ``(a, b, 1)`` backed off by the
    clearance over that grid, one quad per view (the origin is linear in the pixel, the direction constant).

    Vertices are in grid pitches (x, y) and mm (z), scaled by ``(px, py, 1)``: the quads' borders,
    multiples of 1/2, are exact in POV-Ray's single precision (see ``CameraMesh``).
    """
    (ny, nx), (cols, rows), (px, py) = views, cells, pitch
    a, b = (np.asarray(slopes, dtype=np.float64).reshape(ny * nx, 2)[:, n:n + 1] for n in range(2))
    view = np.arange(ny * nx)[:, None]
    col0, row0 = (view % nx) * cols, (view // nx) * rows
    # Corners counter-clockwise from bottom left, on the grid's outer borders.
    x = np.array([[-cols / 2, cols / 2, cols / 2, -cols / 2]])
    y = np.array([[-rows / 2, -rows / 2, rows / 2, rows / 2]])
    col = col0 + np.array([[-0.5, cols - 0.5, cols - 0.5, -0.5]])
    row = row0 + np.array([[rows - 0.5, rows - 0.5, -0.5, -0.5]])
    return _quad_mesh(x - a * front_clearance / px, y - b * front_clearance / py, a * px, b * py, col, row,
                      (nx * cols, ny * rows), front_clearance, 1.0, (px, py, 1.0))
