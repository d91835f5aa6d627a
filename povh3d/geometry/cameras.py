"""Camera geometry of each rendering method, as plain values for the templates.

Pure: a LensArray in, NumPy arrays and numbers out.  Every camera here traces
the ray of a pixel of docs/geometry.md: through the lens centre ``c`` with
direction ``(u, v, f)``, starting ``back_off`` mm in front of the display plane
so that objects floating in front of the screen are seen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError
from .footprint import CENTRE, GRID
from .lens_array import LensArray

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
        if most < MIN_CLEARANCE:  # no clearance works: the display itself is out of POV-Ray's reach
            w, h = lens_array.panel.size_mm
            raise ConfigError(
                f"a {w:.4g} x {h:.4g} mm display with rays this oblique is beyond POV-Ray's {POVRAY_MAX_DEPTH:g} mm "
                "ray length whatever the front clearance; check --pixel-pitch and --focal (mm), or model the "
                "scene and the display in larger units (smaller numbers)")
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

    POV-Ray stores vertices and normals in single precision.  ``scale`` is
    a transform of the mesh (``scale <sx, sy, sz>``, applied in double
    precision: POV-Ray moves origins by it and directions by its inverse, as
    surface normals): view banks are written in lens-pitch units, where every
    corner is a multiple of 1/GRID (``footprint.GRID``) and so stored exactly.

    Attributes
    ----------
    vertices : (n, 3) float            ray origins at z = -back_off, in mm / ``scale``
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
    # View banks with gutters (``view_bank_frames``): the image columns and rows that hold
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
TIE_SHIFT = 1 / 256


def _borders_on_pixel_centres(lenses: int, ppl: float, pixels: int) -> bool:
    """Whether a lens border of a centred array falls on a pixel centre (in pixels)."""
    borders = (np.arange(lenses + 1) - lenses / 2) * ppl + pixels / 2 - 0.5
    return bool(np.any(np.abs(borders - np.rint(borders)) < 1e-6))


def camera_mesh(lens_array: LensArray, back_off: float, sample=None) -> CameraMesh:
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

    ``sample`` ``(ax, ay, du, dv)``: every ray moved to that footprint sample (``sampled_corners``).
    """
    check_clearance(lens_array, back_off)
    if lens_array.rotation or lens_array.grid == "hex":
        raise ConfigError("a turned or hex lattice has one cell per lens; use lattice_mesh.lens_mesh")
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
    if sample is None:
        return _quad_mesh(origin_x, origin_y, u, v, col, row, (W, H), back_off, f)
    origin_x, origin_y, z, shear = sampled_corners(lens_array, sample, origin_x, origin_y, back_off)
    return replace(_quad_mesh(origin_x, origin_y, u, v, col, row, (W, H), back_off, f, z=z),
                   direction_shear=shear)


def sampled_corners(lens_array: LensArray, sample, origin_x: np.ndarray, origin_y: np.ndarray,
                    back_off: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[float, float]]:
    """A lens mesh's corners moved to footprint sample ``(ax, ay, du, dv)`` (``geometry.footprint``).

    The lookup (which cell a pixel centre falls in) stays, so every sample of a pixel
    goes through the pixel's own lens: ``ax, ay`` lens pitches across its aperture, its
    direction ``du, dv`` pixel pitches across its angular width.  The aperture moves the
    origins; the angle is a shear of every direction by ``(du s, dv s) / f`` per unit of
    depth, done by the mesh's ``direction_shear`` transform, because POV-Ray normalises
    vertex normals before interpolating them, exact only while a face's corner offsets
    keep one length.  The stored vertices are the origins taken back through that
    transform: their z is ``-back_off + a x + b y``.

    Returns origin x, y (mm), the stored z, and the shear ``(a, b)``.
    """
    ax, ay, du, dv = (float(t) for t in np.asarray(sample, dtype=np.float64).reshape(4))
    la = lens_array
    a, b = du * la.panel.pitch_x / la.focal, dv * la.panel.pitch_y / la.focal
    # The aperture sample across the lens cell, in the lattice's own axes.
    step_x, step_y = la.from_lattice(ax * la.pitch_x, ay * la.pitch_y)
    # The ray through c + aperture with the sheared direction starts back_off before z = 0.
    ox = origin_x + step_x - a * back_off
    oy = origin_y + step_y - b * back_off
    return ox, oy, -back_off + a * ox + b * oy, (a, b)


def _quad_mesh(origin_x: np.ndarray, origin_y: np.ndarray, u: np.ndarray, v: np.ndarray,
               col: np.ndarray, row: np.ndarray, size: tuple[int, int], back_off: float,
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
    vertices = np.stack(full(origin_x, origin_y, -back_off if z is None else z), axis=-1).reshape(-1, 3)
    normals = np.stack(full(u, v, focal), axis=-1).reshape(-1, 3)
    # A convex polygon per lens (quads; hexagons) as a fan of triangles from corner 0.
    n = shape[1]
    base = n * np.arange(shape[0])[:, None]
    faces = np.concatenate([base + [0, t, t + 1] for t in range(1, n - 1)], axis=1).reshape(-1, 3)
    return CameraMesh(vertices, normals, uv.reshape(-1, 2), faces.astype(np.int64), (W + 1, H + 1),
                      tuple(float(a) for a in scale))


# How many footprint banks go into one mesh-camera frame.  POV-Ray 3.7 finds a
# ray's face by scanning every face of the mesh (measured with 64 views at 480x272:
# 38 ms a bank with 8 banks a frame, 88 ms with 128, about 2.5e-11 s per face per
# ray), while each further frame of a run costs about 0.25 s (parse, start of frame).
# The banks per frame that minimise the sum: sqrt(FRAME_SECONDS / (rays x faces x SCAN_SECONDS)).
FRAME_SECONDS = 0.25
SCAN_SECONDS = 2.5e-11


def bank_groups(samples: np.ndarray, faces_per_bank: int, rays_per_bank: int) -> list[np.ndarray]:
    """Footprint samples split into equal groups, one mesh-camera frame each.

    All groups have one size (a batch's frames share one image size): the largest
    divisor of the count not above the cheapest size (see ``FRAME_SECONDS``), so a
    small probe takes 64 banks a frame, a 480x272 panel 16 and a 1920x1088 one 4.
    """
    samples = np.asarray(samples, dtype=np.float64).reshape(-1, 4)
    best = math.sqrt(FRAME_SECONDS / (SCAN_SECONDS * max(1, rays_per_bank) * max(1, faces_per_bank)))
    size = max(d for d in range(1, min(max(1, int(best)), len(samples)) + 1) if len(samples) % d == 0)
    return [samples[i:i + size] for i in range(0, len(samples), size)]


def view_bank_frames(lens_array: LensArray, back_off: float, samples: np.ndarray | None = None,
                     plan=None, gutter: int = 0) -> list[CameraMesh]:
    """The meshes of the frames that trace a view bank per footprint sample (``bank_groups``).

    Each mesh is the orthographic camera bank as one mesh camera, one quad per view
    (or, with a ``crop.CropPlan``, per kept column segment times kept row segment):
    the image is the views tiled side by side, ``tiled[l*Ly + i, k*Lx + j] =
    view[l, k][i, j]``, one bank per footprint sample of the group, stacked top to
    bottom.  Within a view the ray origin is linear in the lens index and the
    direction constant, so one quad per view is exact; every corner is exact in
    single precision (``bank_back_off``), so a cropped pixel gets the very ray the
    uncropped mesh gives it.

    ``gutter`` > 0 (a render whose antialiasing samples pixel borders): that many
    pixels between any two quads (``_bank_mesh``), cut off by ``stack_frames``.
    """
    cols, rows, size = _bank_tiles(lens_array, plan)
    samples = np.asarray(CENTRE if samples is None else samples, dtype=np.float64).reshape(-1, 4)
    groups = bank_groups(samples, 2 * len(cols) * len(rows), size[0] * size[1])
    return [_bank_mesh(lens_array, back_off, group, cols, rows, size, gutter) for group in groups]


def _bank_tiles(lens_array: LensArray, plan) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Column and row segments ``(view, first lens, stop lens, image column/row)`` and the
    image size of one bank: whole views, or the tiles a ``crop.CropPlan`` keeps."""
    if plan is not None:
        return plan.col_segments(), plan.row_segments(), plan.size
    ny, nx = lens_array.require_views()
    lx, ly = lens_array.lenses_x, lens_array.lenses_y
    cols = np.array([(k, 0, lx, k * lx) for k in range(nx)])
    rows = np.array([(l, 0, ly, l * ly) for l in range(ny)])
    return cols, rows, (lx * nx, ly * ny)


def bank_back_off(lens_array: LensArray, back_off: float) -> float:
    """The front clearance a view bank uses: ``back_off`` rounded up to a multiple of ``f * lcm(Nx, Ny)``.

    Then every view's origin shift ``u * back_off / f``, in lens pitches, is a
    multiple of 1/2 (times the samples' 1/GRID grid), so the bank's corners,
    written in lens pitches, are exact in POV-Ray's single precision.
    """
    ny, nx = lens_array.require_views()
    unit = lens_array.focal * math.lcm(nx, ny)
    return math.ceil(back_off / unit * (1 - 1e-12)) * unit


def _bank_mesh(lens_array: LensArray, back_off: float, samples: np.ndarray | None, cols: np.ndarray,
               rows: np.ndarray, size: tuple[int, int], gutter: int = 0) -> CameraMesh:
    """Quads over column segments x row segments of the tiled views, one bank per sample.

    ``cols``/``rows`` are ``(n, 4)``: ``(view, first lens, stop lens, image column/row)``.
    Vertices are in lens pitches (x, y) and mm (z), the mesh scaled by ``(px, py, 1)``:
    a corner ``j`` lenses from the array's centre, shifted by the view's origin
    offset, is a multiple of 1/GRID and stored exactly (see ``CameraMesh``).

    ``gutter``: pixels between neighbouring quads (and banks), each quad reaching
    half of it past its outer lenses.  POV-Ray's adaptive antialiasing (``+AM2``)
    traces every pixel's corners, and POV-Ray gives a ray on the edge two quads
    share to the first quad of the mesh: without gutters the first row and column
    of a view took their outer corners from the view above and to the left (a
    quarter of their samples at ``+R3``).  Within a quad the ray is linear in the
    image position, so the corners of its outer pixels, half a pixel out, are the
    rays through the lens border of that same view: inside the pixel's footprint.
    """
    ny, nx = lens_array.require_views()
    back_off = bank_back_off(lens_array, back_off)
    check_clearance(lens_array, back_off)
    px, py, f = lens_array.pitch_x, lens_array.pitch_y, lens_array.focal
    s_x, s_y = lens_array.panel.pitch_x, lens_array.panel.pitch_y
    samples = np.asarray(CENTRE if samples is None else samples, dtype=np.float64).reshape(-1, 4)
    width, height = size
    if gutter:
        # Segment n moves n gutters on (segments are in image order), banks one more each.
        cols, rows = cols.copy(), rows.copy()
        kept_cols = _with_gutters(cols, width, gutter)
        kept_rows = _with_gutters(rows, height, gutter)
        width, height = width + (len(cols) - 1) * gutter, height + (len(rows) - 1) * gutter + gutter
        kept_rows = (np.arange(len(samples))[:, None] * height + kept_rows[None, :]).reshape(-1)
    b = np.repeat(np.arange(len(samples)), len(cols) * len(rows))[:, None]
    r = np.tile(np.repeat(rows, len(cols), axis=0), (len(samples), 1))   # every row segment ...
    c = np.tile(cols, (len(rows) * len(samples), 1))                      # ... times every column segment, per bank
    k, j0, j1, col0 = (c[:, n:n + 1] for n in range(4))
    l, i0, i1, row0 = (r[:, n:n + 1] for n in range(4))
    ax, ay, du, dv = (samples[b, n] for n in range(4))                   # (quads, 1) each
    # Corners counter-clockwise from bottom left, half a lens outside the kept lens
    # centres, in lens pitches (the conventions' centres, on the 1/GRID grid: exact).
    centres = lens_array.lens_centres()
    cx = np.round(centres[0, :, 0] / px * GRID) / GRID
    cy = np.round(centres[:, 0, 1] / py * GRID) / GRID
    reach = gutter / 2   # lens pitches (one image pixel is one lens) past the outer lens borders
    left, right = cx[j0] - 0.5 - reach, cx[j1 - 1] + 0.5 + reach
    top, bottom = cy[i0] + 0.5 + reach, cy[i1 - 1] - 0.5 - reach
    x = np.concatenate([left, right, right, left], axis=1) + ax
    y = np.concatenate([bottom, bottom, top, top], axis=1) + ay
    # The origin shift u * back_off / f in lens pitches: u = (k - (Nx-1)/2 + du) s and
    # px = Nx s, so (k - (Nx-1)/2 + du) * back_off / (f Nx), a whole multiple of the offset.
    units = round(back_off / (f * math.lcm(nx, ny)))
    mx, my = units * math.lcm(nx, ny) // nx, units * math.lcm(nx, ny) // ny
    turn_x = k - (nx - 1) / 2 + du
    turn_y = (ny - 1) / 2 - l + dv
    origin_x, origin_y = x - turn_x * mx, y - turn_y * my
    j = np.concatenate([j0 - reach, j1 + reach, j1 + reach, j0 - reach], axis=1) - 0.5  # lens index of each corner
    i = np.concatenate([i1 + reach, i1 + reach, i0 - reach, i0 - reach], axis=1) - 0.5
    mesh = _quad_mesh(origin_x, origin_y, turn_x * s_x * px, turn_y * s_y * py,
                      col0 + (j - j0), b * height + row0 + (i - i0),
                      (width, height * len(samples) - (gutter if gutter else 0)), back_off, f, (px, py, 1.0))
    return replace(mesh, kept=(kept_cols, kept_rows)) if gutter else mesh


def _with_gutters(segments: np.ndarray, size: int, gutter: int) -> np.ndarray:
    """Move ``segments`` (``(n, 4)``, image position last, in image order) ``gutter``
    pixels apart, in place; the image positions that hold pixels."""
    order = np.argsort(segments[:, 3], kind="stable")
    shift = np.empty(len(segments), dtype=np.int64)
    shift[order] = np.arange(len(segments)) * gutter
    kept = np.arange(size) + np.repeat(shift[order], np.diff(np.append(segments[order, 3], size)))
    segments[:, 3] += shift
    return kept


def stack_frames(images: list[np.ndarray], meshes: list[CameraMesh] | None = None) -> np.ndarray:
    """Rendered mesh-camera frames stacked top to bottom, each without the extra first
    row and last column of ``CameraMesh`` (and without the gutters of its mesh, if given)."""
    cut = [im[1:, :-1] for im in images]
    if meshes is not None:
        cut = [mesh.without_gutters(im) for mesh, im in zip(meshes, cut)]
    return cut[0] if len(cut) == 1 else np.concatenate(cut)


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
