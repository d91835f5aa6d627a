"""Test-only oracles and helpers that used to live in the package.

Each one is either a plain NumPy reference the package's fast path is checked
against, or a thin convenience over package internals that only the tests call.
"""

from __future__ import annotations

import numpy as np

from povh3d.calibration.distortion import Brown
from povh3d.calibration.gridfile import LATTICES, Grid
from povh3d.errors import ConfigError
from povh3d.geometry.camera_mesh import CameraMesh
from povh3d.geometry.view_bank import _bank_mesh, _bank_tiles
from povh3d.geometry.lens_array import LensArray
from povh3d.geometry.rays import pixel_rays
from povh3d.geometry.optics import Lenslet, sag
from povh3d.image.elemental import lens_index_map, sample_in_lens
from povh3d.display.mappings.plan import Plan

# -- image/interleave: the NumPy references of the compiled row gather ------------------------------

def _with_channels(array: np.ndarray, ndim: int) -> tuple[np.ndarray, bool]:
    """Add a trailing channel axis to a single-channel array; say whether we did."""
    if array.ndim == ndim:
        return array[..., None], True
    assert array.ndim == ndim + 1, array.shape
    return array, False


def interleave_reference(views: np.ndarray) -> np.ndarray:
    """``interleave`` by one NumPy transpose-copy: ``H3D[i*Ny + l, j*Nx + k] = view[l, k][i, j]``."""
    v, squeeze = _with_channels(np.asarray(views), 4)
    ny, nx, ly, lx, c = v.shape
    h3d = np.ascontiguousarray(v.transpose(2, 0, 3, 1, 4)).reshape(ly * ny, lx * nx, c)
    return h3d[..., 0] if squeeze else h3d


def extract_reference(h3d: np.ndarray, ppl: tuple[int, int]) -> np.ndarray:
    """``extract`` by one NumPy reshape-transpose-copy."""
    img, squeeze = _with_channels(np.asarray(h3d), 2)
    ny, nx = ppl
    h, w, c = img.shape
    views = np.ascontiguousarray(img.reshape(h // ny, ny, w // nx, nx, c).transpose(1, 3, 0, 2, 4))
    return views[..., 0] if squeeze else views


# -- mappings/plan ----------------------------------------------------------------------------------

def expand(plan: Plan) -> np.ndarray:
    """The ``(H, Q*unit)`` flat index map a plan encodes (black items hold -1)."""
    idx = plan.base[:, None] + plan.table[plan.tid].astype(np.int64)
    if plan.black is not None:
        idx = np.where(plan.black[plan.tid], -1, idx)
    if plan.unit == 1:
        return idx
    full = idx[..., None] + np.arange(plan.unit)
    return np.where(idx[..., None] < 0, -1, full).reshape(idx.shape[0], -1)


# -- calibration/gridfile ---------------------------------------------------------------------------

def grid_for_lens_array(lens_array: LensArray) -> Grid:
    """The exact grid of an H3D image rendered by povh3d for ``lens_array`` (no distortion).

    Lens ``(i, j)`` of docs/geometry.md is lens ``(i, j)`` of the grid; the pixel
    centre ``(X, Y)`` mm maps to ``x = X / s + W/2 - 0.5``, ``y = H/2 - 0.5 - Y / s``.
    """
    p = lens_array.panel
    if lens_array.grid not in LATTICES:
        raise ConfigError(f"a lens grid is square or hex, not {lens_array.grid!r}")
    c = lens_array.lens_centres()
    x = c[..., 0] / p.pitch_x + p.width / 2 - 0.5
    y = p.height / 2 - 0.5 - c[..., 1] / p.pitch_y
    a1 = np.array([lens_array.pitch_x / p.pitch_x, 0.0])
    if lens_array.grid == "square":
        a2 = np.array([0.0, lens_array.pitch_y / p.pitch_y])
    else:
        a2 = np.array([a1[0] / 2, lens_array.pitch_y / p.pitch_y])
    return Grid(lens_array.grid, (p.width, p.height), np.stack([a1, a2]), np.array([x[0, 0], y[0, 0]]),
                (lens_array.lenses_y, lens_array.lenses_x), Brown.for_image(p.width, p.height))


# -- image/elemental --------------------------------------------------------------------------------

def turn_elemental_images(capture: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """Turn every elemental image by 180 degrees about its lens centre.

    Display pixel ``X`` of lens ``c`` takes the capture at ``2c - X``, which lies
    in the same lens cell (a hexagon and a rectangle are point-symmetric).
    Pixels outside every lens are black.

    Parameters
    ----------
    capture : (H, W, C) array       the camera image through the virtual array
    """
    centres, _, inside = pixel_rays(lens_array)
    X, Y = np.meshgrid(*lens_array.panel.pixel_centres())
    lens_map = lens_index_map(lens_array)
    pts = np.stack([2 * centres[..., 0] - X, 2 * centres[..., 1] - Y], axis=-1)
    if lens_array.grid == "lenticular":
        pts[..., 1] = Y  # a cylinder lens does not turn along its axis
    pts = np.where(inside[..., None], pts, np.stack([X, Y], axis=-1))
    out = sample_in_lens(capture, lens_array, pts[inside], lens_map[inside], lens_map)
    result = np.zeros_like(capture)
    result[inside] = out
    return result


# -- geometry/optics --------------------------------------------------------------------------------

def trace_collimated(lenslet: Lenslet, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Trace collimated rays (flat face first) through the curved face with Snell's law.

    An independent check of the surface: no paraxial formula, only the exact
    surface normal and vector refraction.

    Parameters
    ----------
    h : (n,) float, mm      ray heights (0 < h < aperture radius)

    Returns
    -------
    z_axis : (n,) float, mm     where each ray crosses the axis, from the vertex (NaN: TIR)
    tan_theta : (n,) float      slope of the exit ray toward the axis, ``-dx/dz``
    """
    h = np.asarray(h, dtype=np.float64)
    n, R, K = lenslet.ior, lenslet.radius, lenslet.conic
    s = sag(h, R, K)
    # Surface F(h, z) = h^2 + (1+K) z^2 + 2 R z = 0 at z = -s; the gradient is the normal.
    z = -s
    normal = np.stack([2 * h, 2 * (1 + K) * z + 2 * R], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)  # points out of the glass (+z)
    d = np.array([0.0, 1.0])                                    # (h, z) components
    cos_i = normal @ d
    ratio = n  # glass -> air
    k = 1 - ratio**2 * (1 - cos_i**2)
    with np.errstate(invalid="ignore"):
        t = ratio * d + (np.sqrt(k) - ratio * cos_i)[:, None] * normal
    t = np.where((k >= 0)[:, None], t, np.nan)
    tan_theta = -t[:, 0] / t[:, 1]
    z_axis = z + h / tan_theta
    return z_axis, tan_theta


# -- geometry/cameras: one view-bank mesh, and a mesh in mm -----------------------------------------

def view_bank_mesh(lens_array: LensArray, front_clearance: float, samples: np.ndarray | None = None) -> CameraMesh:
    """The orthographic camera bank as one mesh camera: one quad per view.

    The image is the views tiled side by side, view ``(l, k)`` at rows
    ``l*Ly .. (l+1)*Ly - 1`` and columns ``k*Lx .. (k+1)*Lx - 1``, so that
    ``tiled[l*Ly + i, k*Lx + j] = view[l, k][i, j]``.  Same lookup rules as
    ``cameras.camera_mesh`` (extra first row and last column).  Rays start
    ``cameras.bank_front_clearance`` in front of the screen (``front_clearance``, rounded up).

    ``samples`` (K, 4), optional: footprint samples (``geometry.footprint``); each
    gets a whole bank, the banks stacked top to bottom (bank ``b`` at rows
    ``b*Ny*Ly ..``).  Default: the pixel's own ray.  All banks in one mesh,
    whatever ``view_bank.bank_groups`` would split them into.
    """
    return _bank_mesh(lens_array, front_clearance, samples, *_bank_tiles(lens_array, None))


def mesh_rays(mesh: CameraMesh, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``(n, 6)``: the origin and normal (as written, before ``mesh.scale``) POV-Ray interpolates for panel
    pixels ``(cols, rows)``: barycentric interpolation at each pixel's UV, the lookup rule of
    ``camera_mesh.CameraMesh``; NaN where no face holds it."""
    w, h = mesh.image_size
    uv = np.stack([(cols + 0.0) / w, 1.0 - (rows + 1.0) / h], -1)
    out = np.full((len(uv), 6), np.nan)
    for a, b, c in mesh.faces:
        t = np.linalg.solve(np.array([mesh.uvs[b] - mesh.uvs[a], mesh.uvs[c] - mesh.uvs[a]]).T,
                            (uv - mesh.uvs[a]).T).T
        inside = (t >= -1e-12).all(1) & (t.sum(1) <= 1 + 1e-12)
        wts = np.column_stack([1 - t.sum(1), t])
        p = wts @ np.array([mesh.vertices[a], mesh.vertices[b], mesh.vertices[c]])
        n = wts @ np.array([mesh.normals[a], mesh.normals[b], mesh.normals[c]])
        out[inside] = np.column_stack([p, n])[inside]
    return out


def cropped_view_bank_mesh(lens_array: LensArray, front_clearance: float, plan,
                           samples: np.ndarray | None = None) -> CameraMesh:
    """``view_bank_mesh`` over the columns and rows a ``crop.CropPlan`` keeps.

    One quad per kept column segment times kept row segment; the image is the
    uncropped tiled image with the other columns and rows removed, one such
    bank per footprint sample.
    """
    return _bank_mesh(lens_array, front_clearance, samples, *_bank_tiles(lens_array, plan))


def mesh_in_mm(mesh: CameraMesh) -> CameraMesh:
    """The same camera with the scale applied: vertices in mm, normals the mm directions
    (what POV-Ray does with the mesh's ``scale``)."""
    scale = np.asarray(mesh.scale, dtype=np.float64)
    return CameraMesh(mesh.vertices * scale, mesh.normals / scale, mesh.uvs, mesh.faces, mesh.image_size)
