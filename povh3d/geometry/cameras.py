"""Camera geometry of each rendering method, as plain values for the templates.

Pure: a LensArray in, NumPy arrays and numbers out.  Every camera here traces
the ray of a pixel of docs/geometry.md: through the lens centre ``c`` with
direction ``(u, v, f)``, starting ``front_clearance`` mm in front of the display plane
so that objects floating in front of the screen are seen.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import ConfigError
from .camera_mesh import CameraMesh, _quad_mesh, check_front_clearance
from .lens_array import LensArray


# -- multi-orthographic camera bank, one orthographic camera per view ---------------

def ortho_view_shots(lens_array: LensArray) -> tuple[dict, list[dict]]:
    """The orthographic camera of every view, row-major over ``(l, k)``.

    Returns
    -------
    common : dict
        ``right``, ``up`` (mm vectors spanning the lens array) and image size.
    shots : list of dict
        ``{"view": (l, k), "direction": (u/f, v/f, 1)}``; the template backs the
        camera off along ``direction`` (z component 1, so by exactly ``front_clearance``).
    """
    u, v = lens_array.view_offsets()
    f = lens_array.focal
    shots = [{"view": (l, k), "direction": (float(u[k] / f), float(v[l] / f), 1.0)}
              for l in range(len(v)) for k in range(len(u))]
    common = {
        "right": (lens_array.lenses_x * lens_array.pitch_x, 0.0, 0.0),
        "up": (0.0, lens_array.lenses_y * lens_array.pitch_y, 0.0),
        "width": lens_array.lenses_x,
        "height": lens_array.lenses_y,
    }
    return common, shots


TIE_SHIFT = 1 / 256


def _borders_on_pixel_centres(lenses: int, ppl: float, pixels: int) -> bool:
    """Whether a lens border of a centred array falls on a pixel centre (in pixels)."""
    borders = (np.arange(lenses + 1) - lenses / 2) * ppl + pixels / 2 - 0.5
    return bool(np.any(np.abs(borders - np.rint(borders)) < 1e-6))


def camera_mesh(lens_array: LensArray, front_clearance: float, sample=None) -> CameraMesh:
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
    check_front_clearance(lens_array, front_clearance)
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
        origin_x = cx[:, None] - u * (front_clearance / f)
        origin_y = y
    else:
        c = centres.reshape(-1, 2)
        corner_u = np.array([-hx, hx, hx, -hx]) - shift_x
        corner_v = np.array([-hy, -hy, hy, hy]) + shift_y
        x = c[:, 0:1] + corner_u[None, :]
        y = c[:, 1:2] + corner_v[None, :]
        u = np.broadcast_to(corner_u, x.shape)
        v = np.broadcast_to(corner_v, x.shape)
        origin_x = c[:, 0:1] - u * (front_clearance / f)
        origin_y = c[:, 1:2] - v * (front_clearance / f)

    # Panel position -> fractional image column/row.
    col = x / sx + W / 2 - 0.5
    row = H / 2 - 0.5 - y / sy
    if sample is None:
        return _quad_mesh(origin_x, origin_y, u, v, col, row, (W, H), front_clearance, f)
    origin_x, origin_y, z, shear = sampled_corners(lens_array, sample, origin_x, origin_y, front_clearance)
    return replace(_quad_mesh(origin_x, origin_y, u, v, col, row, (W, H), front_clearance, f, z=z),
                   direction_shear=shear)


def sampled_corners(lens_array: LensArray, sample, origin_x: np.ndarray, origin_y: np.ndarray,
                    front_clearance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[float, float]]:
    """A lens mesh's corners moved to footprint sample ``(ax, ay, du, dv)`` (``geometry.footprint``).

    The lookup (which cell a pixel centre falls in) stays, so every sample of a pixel
    goes through the pixel's own lens: ``ax, ay`` lens pitches across its aperture, its
    direction ``du, dv`` pixel pitches across its angular width.  The aperture moves the
    origins; the angle is a shear of every direction by ``(du s, dv s) / f`` per unit of
    depth, done by the mesh's ``direction_shear`` transform, because POV-Ray normalises
    vertex normals before interpolating them, exact only while a face's corner offsets
    keep one length.  The stored vertices are the origins taken back through that
    transform: their z is ``-front_clearance + a x + b y``.

    Returns origin x, y (mm), the stored z, and the shear ``(a, b)``.
    """
    ax, ay, du, dv = (float(t) for t in np.asarray(sample, dtype=np.float64).reshape(4))
    la = lens_array
    a, b = du * la.panel.pitch_x / la.focal, dv * la.panel.pitch_y / la.focal
    # The aperture sample across the lens cell, in the lattice's own axes.
    step_x, step_y = la.from_lattice(ax * la.pitch_x, ay * la.pitch_y)
    # The ray through c + aperture with the sheared direction starts front_clearance before z = 0.
    ox = origin_x + step_x - a * front_clearance
    oy = origin_y + step_y - b * front_clearance
    return ox, oy, -front_clearance + a * ox + b * oy, (a, b)


# -- per-lens pinhole cameras ---------------------------------------------------------

def pinhole_shots(lens_array: LensArray) -> tuple[dict, list[dict]]:
    """One perspective camera per lens, pinhole at the lens centre, row-major over lenses.

    POV-Ray's perspective pixel ``(k, l)`` looks along
    ``direction + ((k+0.5)/Nx - 0.5) right + (0.5 - (l+0.5)/Ny) up`` =
    ``(u_k, v_l, f)`` with ``right = Nx*s``, ``up = Ny*s``, ``direction = f``.
    """
    ny, nx = lens_array.require_views()
    s_x, s_y = lens_array.panel.pitch_x, lens_array.panel.pitch_y
    centres = lens_array.lens_centres()
    shots = [{"lens": (i, j), "centre": (float(centres[i, j, 0]), float(centres[i, j, 1]), 0.0)}
              for i in range(lens_array.lenses_y) for j in range(lens_array.lenses_x)]
    common = {
        "direction": (0.0, 0.0, lens_array.focal),
        "right": (nx * s_x, 0.0, 0.0),
        "up": (0.0, ny * s_y, 0.0),
        "width": nx,
        "height": ny,
    }
    return common, shots
