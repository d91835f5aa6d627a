"""The ray of every panel pixel (docs/geometry.md, "The ray of a pixel"): the one
definition every renderer, interleaver, mapping and test derives from."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # only its attributes are read: the rays need no more than NumPy
    from .lens_array import LensArray


def nearest_hex_lens(centres: np.ndarray, X: np.ndarray, Y: np.ndarray, px: float,
                     py: float) -> tuple[np.ndarray, np.ndarray]:
    """Row and column ``(i, j)`` of the hex lens whose centre is nearest each point ``(X, Y)`` mm
    (its Voronoi cell), from the array's ``(Ly, Lx, 2)`` lattice centres, unrotated."""
    Ly, Lx = centres.shape[:2]
    i0 = np.rint(Ly / 2 - 0.5 - Y / py).astype(np.int64)
    best_d = np.full(X.shape, np.inf)
    best_i = np.zeros(X.shape, np.int64)
    best_j = np.zeros(X.shape, np.int64)
    for di in (-1, 0, 1):  # the nearest centre lies in the nearest row or one beside it
        i = np.clip(i0 + di, 0, Ly - 1)
        j = np.clip(np.rint(X / px + Lx / 2 - 0.5 - (i % 2) / 2).astype(np.int64), 0, Lx - 1)
        d = (X - centres[i, j, 0]) ** 2 + (Y - centres[i, j, 1]) ** 2
        better = d < best_d
        best_d, best_i, best_j = np.where(better, d, best_d), np.where(better, i, best_i), np.where(better, j, best_j)
    return best_i, best_j


def lens_of_points(lens_array: LensArray, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row ``i`` and column ``j`` of the lens whose cell holds each point ``(X, Y)`` of the lattice's own
    frame (mm; ``LensArray.to_lattice``), and whether any lens holds it (``inside``; ``i``, ``j`` are then
    clipped into the array).  The rule of a pixel's lens (docs/geometry.md), for any point: square and
    lenticular, the pitch rectangle, a point on its border going to the lens on the right or below; hex,
    the true hexagon; lattice, the parallelogram spanned by its vectors."""
    centres = lens_array.lattice_centres()
    Lx, Ly = lens_array.lenses_x, lens_array.lenses_y
    px, py = lens_array.pitch_x, lens_array.pitch_y
    if lens_array.grid == "hex":
        i, j = nearest_hex_lens(centres, X, Y, px, py)
        # Inside the true hexagon (flat sides at |dx| = px/2, slanted sides at
        # |dx|/2 + sqrt(3)/2 |dy| = px/2), not its circumradius disc: the disc pokes
        # out past the slanted sides on the outer rows, where no lens lies.
        dx, dy = np.abs(X - centres[i, j, 0]), np.abs(Y - centres[i, j, 1])
        half = px / 2 * (1 + 1e-9)
        return i, j, (dx <= half) & (dx / 2 + np.sqrt(3) / 2 * dy <= half)
    # A point on a lens border (fractional PPL) belongs to the lens on its right (below); the
    # tolerance keeps rounding from deciding.
    fj = X / px + Lx / 2 + 1e-9
    fi = Ly / 2 - Y / py + 1e-9
    if lens_array.grid == "lattice":  # the parallelogram cell: lattice coordinates, as square
        from .lattice import lattice_coordinates  # here: keeps the rays' imports shallow

        s, t = lattice_coordinates(*lens_array.basis_vectors(), X, Y)
        fj, fi = s + Lx / 2 + 1e-9, Ly / 2 - t + 1e-9
    j, i = np.floor(fj).astype(np.int64), np.floor(fi).astype(np.int64)
    inside = (j >= 0) & (j < Lx) & (i >= 0) & (i < Ly)
    if lens_array.grid == "lenticular" and lens_array.rotation:
        inside = (j >= 0) & (j < Lx)  # a slanted lenticule runs across every row
    return np.clip(i, 0, Ly - 1), np.clip(j, 0, Lx - 1), inside


def pixel_rays(lens_array: LensArray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ray of every panel pixel (docs/geometry.md, "The ray of a pixel").

    A pixel belongs to the lens whose cell holds its centre (square and
    lenticular: the lens's pitch rectangle, a centre on its border going to the
    lens on the right or below; hex: the nearest centre; lattice: the
    parallelogram spanned by its vectors, as square).

    Returns
    -------
    centres : (H, W, 2) float, mm
        Centre ``(cx, cy)`` of the pixel's lens (lenticular: the point of the
        lenticule's axis nearest the pixel centre, so that ``v`` across it is 0).
    directions : (H, W, 3) float
        Unit direction ``normalize(u, v, f)`` with ``(u, v)`` the pixel's offset.
    inside : (H, W) bool
        False for pixels outside every lens (their rays are undefined: NaN).
    """
    panel = lens_array.panel
    X, Y = panel.pixel_centres()
    # A rotated lattice is worked out in its own frame and turned back at the end.
    X, Y = lens_array.to_lattice(*np.meshgrid(X, Y))  # (H, W)
    centres = lens_array.lattice_centres()
    i, j, inside = lens_of_points(lens_array, X, Y)
    c = centres[i, j].copy()
    if lens_array.grid == "lenticular":
        c[..., 1] = Y  # the point of the lenticule's axis beside the pixel (unrotated: its row)
    u = X - c[..., 0]
    v = Y - c[..., 1]
    c = np.stack(lens_array.from_lattice(c[..., 0], c[..., 1]), axis=-1)
    u, v = lens_array.from_lattice(u, v)
    d = np.stack([u, v, np.full(u.shape, lens_array.focal)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.where(inside[..., None], c, np.nan)
    d = np.where(inside[..., None], d, np.nan)
    return c, d, inside


def depth_scaled_rays(lens_array: LensArray, depth_scale: float) -> LensArray:
    """The array whose pixel rays show the scene with its depth compressed by ``depth_scale``.

    Compressing the scene along the display normal, ``(x, y, z) -> (x, y, k z)``,
    is the same, for every pixel ray, as keeping the scene and multiplying the
    ray's lateral slope by ``k``: the ray through the lens centre ``c`` with slope
    ``(u, v) / f`` meets the compressed point ``(x, y, k z)`` where
    ``(x, y) = c + (u, v) k z / f``, which is where the ray with slope
    ``k (u, v) / f`` meets the scene's own point ``(x, y, z)``.  That ray is the
    one a lens of focal length ``f / k`` sends, so every method (mesh camera,
    orthographic views, pinholes, single-stage lenslets, subpixels) traces the
    compressed scene by tracing an array with focal length ``f / k``; the scene
    file stays as it is.  Lateral sizes in the screen plane are kept; shading
    stays the uncompressed scene's, seen along the rays of slope ``k (u, v) / f``.
    """
    if depth_scale == 1:
        return lens_array
    return replace(lens_array, focal=lens_array.focal / depth_scale)


def disparity(depth: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """(Ny, Nx, Ly, Lx) ray distances (mm) -> disparity in lenses per view step (horizontal).

    ``z s / (f p)`` with ``z`` the hit's depth ``d / |(u/f, v/f, 1)|``: a point at depth ``z``
    moves by that many lenses from one view to the next.
    """
    ny, nx = depth.shape[:2]
    s, f, p = lens_array.panel.pitch_x, lens_array.focal, lens_array.pitch_x
    a = (np.arange(nx) + 0.5 - nx / 2) * s / f
    b = (ny / 2 - np.arange(ny) - 0.5) * lens_array.panel.pitch_y / f
    length = np.sqrt(a[None, :] ** 2 + b[:, None] ** 2 + 1.0)
    z = depth / length[:, :, None, None]
    return (z * s / (f * p)).astype(np.float32)


def cell_contains(grid: str, pitch_x: float, pitch_y: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Whether offsets ``(u, v)`` (mm, from a lens centre) lie strictly inside its cell.

    Points on a cell edge count as outside: POV-Ray's ray there grazes two lenslets.
    """
    tight = 1 - 1e-9
    ax, ay = np.abs(u), np.abs(v)
    if grid == "hex":
        return (ax < pitch_x / 2 * tight) & (ax / 2 + np.sqrt(3) / 2 * ay < pitch_x / 2 * tight)
    if grid == "lenticular":
        return ax < pitch_x / 2 * tight
    return (ax < pitch_x / 2 * tight) & (ay < pitch_y / 2 * tight)
