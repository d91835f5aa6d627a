"""Camera geometry of each rendering method, as plain values for the templates.

Pure: a LensArray in, NumPy arrays and numbers out.  Every camera here traces
the ray of a pixel of CONVENTIONS.md: through the lens centre ``c`` with
direction ``(u, v, f)``, starting ``back_off`` mm in front of the display plane
so that objects floating in front of the screen are seen.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import ConfigError
from .footprint import CENTRE
from .geometry import LensArray

# POV-Ray 3.7 ignores surfaces nearer than 1e-4 mm or further than 1e7 mm along a
# ray from its start (measured with a plane: missed at 0.95e-4 mm, seen at
# 1.05e-4 mm; views vanish once the path to the screen passes 1e7 mm).  Both are
# absolute, so they decide which scene scales povh3d's cameras can render.
POVRAY_MIN_DEPTH = 1e-4
POVRAY_MAX_DEPTH = 1e7
#: The least front clearance, mm: a hundred times POV-Ray's nearest depth, so a
#: tiny panel (scene scaled to micrometres) still sees its screen.
MIN_CLEARANCE = 100 * POVRAY_MIN_DEPTH


def default_back_off(lens_array: LensArray) -> float:
    """How far in front of the screen rays start, mm: four panel widths, at least 0.01 mm.

    Far enough for any object a display can show in front of its screen, near
    enough that POV-Ray's single-precision mesh vertices (mesh camera) keep the
    sample grid within about 1e-6 panel widths.  The floor keeps the screen
    beyond POV-Ray's nearest intersection depth on panels under 2.5 um wide.
    """
    width, height = lens_array.panel.size_mm
    return max(4.0 * max(width, height), MIN_CLEARANCE)


def ray_stretch(lens_array: LensArray) -> float:
    """Path length per mm of depth of the most oblique pixel ray, ``max |d| / d_z``.

    Bounded with the largest pixel offset from a lens centre: half the pitch
    (hex: the cell's circumradius ``px / sqrt(3)``; lenticular: ``v = 0``).
    """
    f = lens_array.focal
    if lens_array.grid == "hex":
        hx, hy = lens_array.pitch_x / np.sqrt(3), 0.0
    else:
        hx = lens_array.pitch_x / 2
        hy = 0.0 if lens_array.grid == "lenticular" else lens_array.pitch_y / 2
    return float(np.sqrt(hx * hx + hy * hy + f * f) / f)


def check_clearance(lens_array: LensArray, back_off: float) -> None:
    """Refuse a front clearance POV-Ray cannot trace (ConfigError naming the range that works).

    Rays start ``back_off`` mm in front of the screen; the most oblique travels
    ``back_off * ray_stretch`` to reach it.  That must stay above POV-Ray's
    nearest intersection depth and under half its furthest, leaving at least
    as much again for the scene behind the screen.
    """
    if not back_off >= MIN_CLEARANCE:
        raise ConfigError(
            f"the front clearance {back_off:g} mm is under {MIN_CLEARANCE:g} mm: POV-Ray ignores surfaces "
            f"nearer than {POVRAY_MIN_DEPTH:g} mm to where a ray starts; use --front-clearance {MIN_CLEARANCE:g} or more")
    stretch = ray_stretch(lens_array)
    if back_off * stretch > POVRAY_MAX_DEPTH / 2:
        most = POVRAY_MAX_DEPTH / 2 / stretch
        raise ConfigError(
            f"rays starting {back_off:.6g} mm in front of the screen travel {back_off * stretch:.4g} mm to reach it, "
            f"over half of POV-Ray's {POVRAY_MAX_DEPTH:g} mm ray length, so the scene behind it would vanish; "
            f"use --front-clearance between {MIN_CLEARANCE:g} and {most:.6g} mm (or model the scene in smaller units)")


# -- multi-orthographic camera bank, one orthographic camera per view ---------------

def ortho_view_frames(lens_array: LensArray) -> tuple[dict, list[dict]]:
    """The orthographic camera of every view, row-major over ``(l, k)``.

    Returns
    -------
    common : dict
        ``right``, ``up`` (mm vectors spanning the lens array) and image size.
    frames : list of dict
        ``{"view": (l, k), "direction": (u/f, v/f, 1)}``; the template backs the
        camera off along ``direction`` (z component 1, so by exactly ``back_off``).
    """
    u, v = lens_array.view_offsets()
    f = lens_array.focal
    frames = [{"view": (l, k), "direction": (float(u[k] / f), float(v[l] / f), 1.0)}
              for l in range(len(v)) for k in range(len(u))]
    common = {
        "right": (lens_array.lenses_x * lens_array.pitch_x, 0.0, 0.0),
        "up": (0.0, lens_array.lenses_y * lens_array.pitch_y, 0.0),
        "width": lens_array.lenses_x,
        "height": lens_array.lenses_y,
    }
    return common, frames


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

    Attributes
    ----------
    vertices : (n, 3) float, mm        ray origins at z = -back_off
    normals : (n, 3) float              ray directions ``(u, v, f)``
    uvs : (n, 2) float                  lookup coordinates
    faces : (m, 3) int
    image_size : (int, int)             ``(W + 1, H + 1)`` to render
    """

    vertices: np.ndarray
    normals: np.ndarray
    uvs: np.ndarray
    faces: np.ndarray
    image_size: tuple[int, int]


# How far lens quads are moved off pixel centres that lie on lens borders, in
# pixels: well above the error of POV-Ray's float32 UV lookup (about 1e-4 pixel
# on a 2000-pixel panel), well below anything a ray could resolve.
TIE_SHIFT = 1 / 256


def _borders_on_pixel_centres(lenses: int, ppl: float, pixels: int) -> bool:
    """Whether a lens border of a centred array falls on a pixel centre (in pixels)."""
    borders = (np.arange(lenses + 1) - lenses / 2) * ppl + pixels / 2 - 0.5
    return bool(np.any(np.abs(borders - np.rint(borders)) < 1e-6))


def camera_mesh(lens_array: LensArray, back_off: float) -> CameraMesh:
    """One quad per lens (one strip per lens column for lenticular arrays).

    Within a lens, origin and direction are linear in the pixel offset ``(u, v)``,
    so the face interpolation is exact; the corners sit at ``(+-px/2, +-py/2)``,
    all of one length, so interpolating normalised normals is exact too.

    With fractional pixels per lens a lens border can run through pixel
    centres.  Such a pixel belongs to the lens on its right (below)
    (``geometry.pixel_rays``), so then every quad is moved ``TIE_SHIFT`` of a
    pixel left (up): the lookup falls inside that lens's quad, not on an edge
    POV-Ray would settle either way (measured: 12 % of such pixels wrong).  The
    corner lengths then differ, relatively, by at most ``TIE_SHIFT * s / f`` per
    axis: if POV-Ray normalises the normals, a ray's crossing of ``z = 0`` moves
    by about 0.006 pixel (6.5 PPL, f = 1.5 mm, s = 0.1 mm).
    """
    check_clearance(lens_array, back_off)
    panel = lens_array.panel
    W, H = panel.width, panel.height
    sx, sy = panel.pitch_x, panel.pitch_y
    f = lens_array.focal
    centres = lens_array.lens_centres()  # (Ly, Lx, 2)
    hx, hy = lens_array.pitch_x / 2, lens_array.pitch_y / 2
    shift_x = TIE_SHIFT * sx if _borders_on_pixel_centres(lens_array.lenses_x, lens_array.pitch_x / sx, W) else 0.0
    shift_y = (TIE_SHIFT * sy if lens_array.grid != "lenticular"
               and _borders_on_pixel_centres(lens_array.lenses_y, lens_array.pitch_y / sy, H) else 0.0)

    if lens_array.grid == "lenticular":
        # One strip per lens column spanning every row: v = 0, y follows the row.
        cx = centres[0, :, 0]
        y_top, y_bottom = panel.height * sy / 2 + sy, -panel.height * sy / 2 - sy
        corner_u = np.array([-hx, hx, hx, -hx]) - shift_x
        corner_y = np.array([y_bottom, y_bottom, y_top, y_top])
        x = cx[:, None] + corner_u[None, :]                    # panel x of the corner
        y = np.broadcast_to(corner_y, x.shape)
        u = np.broadcast_to(corner_u, x.shape)
        v = np.zeros_like(x)
        origin_x = cx[:, None] - u * (back_off / f)
        origin_y = y
    else:
        c = centres.reshape(-1, 2)
        corner_u = np.array([-hx, hx, hx, -hx]) - shift_x
        corner_v = np.array([-hy, -hy, hy, hy]) + shift_y
        x = c[:, 0:1] + corner_u[None, :]
        y = c[:, 1:2] + corner_v[None, :]
        u = np.broadcast_to(corner_u, x.shape)
        v = np.broadcast_to(corner_v, x.shape)
        origin_x = c[:, 0:1] - u * (back_off / f)
        origin_y = c[:, 1:2] - v * (back_off / f)

    # Panel position -> fractional image column/row.
    col = x / sx + W / 2 - 0.5
    row = H / 2 - 0.5 - y / sy
    return _quad_mesh(origin_x, origin_y, u, v, col, row, (W, H), back_off, f)


def _quad_mesh(origin_x: np.ndarray, origin_y: np.ndarray, u: np.ndarray, v: np.ndarray,
               col: np.ndarray, row: np.ndarray, size: tuple[int, int], back_off: float,
               focal: float) -> CameraMesh:
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
    vertices = np.stack(full(origin_x, origin_y, -back_off), axis=-1).reshape(-1, 3)
    normals = np.stack(full(u, v, focal), axis=-1).reshape(-1, 3)
    base = 4 * np.arange(shape[0])[:, None]
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]], axis=1).reshape(-1, 3)
    return CameraMesh(vertices, normals, uv.reshape(-1, 2), faces.astype(np.int64), (W + 1, H + 1))


def view_bank_mesh(lens_array: LensArray, back_off: float, samples: np.ndarray | None = None) -> CameraMesh:
    """The orthographic camera bank as one mesh camera: one quad per view.

    The image is the views tiled side by side, view ``(l, k)`` at rows
    ``l*Ly .. (l+1)*Ly - 1`` and columns ``k*Lx .. (k+1)*Lx - 1``, so that
    ``tiled[l*Ly + i, k*Lx + j] = view[l, k][i, j]``.  Within a view the ray
    origin is linear in the lens index and the direction is constant, so a
    single quad per view is exact: ``Nx*Ny`` quads instead of one per lens, which
    keeps POV-Ray's per-pixel face lookup as cheap as a plain camera's.
    Same lookup rules as ``camera_mesh`` (extra first row and last column).

    Parameters
    ----------
    samples : (K, 4) float, optional
        Footprint samples (see ``povh3d.footprint``); each gets a whole bank,
        the banks stacked top to bottom (bank ``b`` at rows ``b*Ny*Ly ..``), so
        K samples of every pixel come out of one POV-Ray pass.  Default: the
        pixel's own ray.
    """
    ny, nx = lens_array.require_views()
    check_clearance(lens_array, back_off)
    lx, ly = lens_array.lenses_x, lens_array.lenses_y
    samples = np.asarray(CENTRE if samples is None else samples, dtype=np.float64).reshape(-1, 4)
    W, H = lx * nx, ly * ny * len(samples)
    f = lens_array.focal
    s_x, s_y = lens_array.panel.pitch_x, lens_array.panel.pitch_y
    u, v = lens_array.view_offsets()
    b, l, k = np.meshgrid(np.arange(len(samples)), np.arange(ny), np.arange(nx), indexing="ij")
    b, l, k = b.reshape(-1, 1), l.reshape(-1, 1), k.reshape(-1, 1)
    ax, ay, du, dv = (samples[b, n] for n in range(4))               # (quads, 1) each
    # Corners of each view's tile: half a pitch outside the outer lens centres.
    corner_j = np.array([-0.5, lx - 0.5, lx - 0.5, -0.5])
    corner_i = np.array([ly - 0.5, ly - 0.5, -0.5, -0.5])
    centres = lens_array.lens_centres()
    hx, hy = lens_array.pitch_x / 2, lens_array.pitch_y / 2
    left, right = centres[0, 0, 0] - hx, centres[0, -1, 0] + hx
    top, bottom = centres[0, 0, 1] + hy, centres[-1, 0, 1] - hy
    x = np.array([left, right, right, left]) + ax * lens_array.pitch_x   # on z = 0
    y = np.array([bottom, bottom, top, top]) + ay * lens_array.pitch_y
    uk, vl = u[k] + du * s_x, v[l] + dv * s_y                          # (quads, 1)
    origin_x = x - uk * (back_off / f)
    origin_y = y - vl * (back_off / f)
    col = k * lx + corner_j[None, :]
    row = (b * ny + l) * ly + corner_i[None, :]
    return _quad_mesh(origin_x, origin_y, uk, vl, col, row, (W, H), back_off, f)


def cropped_view_bank_mesh(lens_array: LensArray, back_off: float, plan) -> CameraMesh:
    """``view_bank_mesh`` over the columns and rows a ``crop.CropPlan`` keeps.

    One quad per kept column segment times kept row segment (a segment is a
    run of kept lenses within one view); the image is the uncropped tiled image
    with the other columns and rows removed.  Corner positions come from lens
    indices (CONVENTIONS), as in ``view_bank_mesh``.
    """
    lens_array.require_views()
    lx, ly = lens_array.lenses_x, lens_array.lenses_y
    f = lens_array.focal
    u, v = lens_array.view_offsets()
    cs, rs = plan.col_segments(), plan.row_segments()           # (n, 4): view, start, stop, offset
    c = np.repeat(cs, len(rs), axis=0)                            # every column segment ...
    r = np.tile(rs, (len(cs), 1))                                 # ... times every row segment
    k, j0, j1, col0 = (c[:, n:n + 1] for n in range(4))
    l, i0, i1, row0 = (r[:, n:n + 1] for n in range(4))
    # Corners counter-clockwise from bottom left, half a lens outside the kept centres.
    j = np.concatenate([j0, j1, j1, j0], axis=1) - 0.5            # (quads, 4) lens index
    i = np.concatenate([i1, i1, i0, i0], axis=1) - 0.5
    x = (j + 0.5 - lx / 2) * lens_array.pitch_x
    y = (ly / 2 - i - 0.5) * lens_array.pitch_y
    uk, vl = u[k], v[l]
    origin_x = x - uk * (back_off / f)
    origin_y = y - vl * (back_off / f)
    return _quad_mesh(origin_x, origin_y, uk, vl, col0 + (j - j0), row0 + (i - i0), plan.size, back_off, f)


# -- per-lens pinhole cameras ---------------------------------------------------------

def pinhole_frames(lens_array: LensArray) -> tuple[dict, list[dict]]:
    """One perspective camera per lens, pinhole at the lens centre, row-major over lenses.

    POV-Ray's perspective pixel ``(k, l)`` looks along
    ``direction + ((k+0.5)/Nx - 0.5) right + (0.5 - (l+0.5)/Ny) up`` =
    ``(u_k, v_l, f)`` with ``right = Nx*s``, ``up = Ny*s``, ``direction = f``.
    """
    ny, nx = lens_array.require_views()
    s_x, s_y = lens_array.panel.pitch_x, lens_array.panel.pitch_y
    centres = lens_array.lens_centres()
    frames = [{"lens": (i, j), "centre": (float(centres[i, j, 0]), float(centres[i, j, 1]), 0.0)}
              for i in range(lens_array.lenses_y) for j in range(lens_array.lenses_x)]
    common = {
        "direction": (0.0, 0.0, lens_array.focal),
        "right": (nx * s_x, 0.0, 0.0),
        "up": (0.0, ny * s_y, 0.0),
        "width": nx,
        "height": ny,
    }
    return common, frames
