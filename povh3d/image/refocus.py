"""Digital refocusing (thesis 2.3.5.2): shift-and-sum over the views, in linear light.

A point at depth ``z`` (mm, > 0 behind the screen) and lateral position ``p``
is seen by view ``(l, k)`` through the lens centre ``p - z (u_k, v_l) / f``
(the ray of a pixel, docs/geometry.md).  So view ``(l, k)`` shifted by
``(-z u_k / (f px), +z v_l / (f py))`` lenses (columns, rows) lines that plane
up with every other view; averaging the shifted views focuses at ``z`` and
blurs everything else.  On a hex array (odd lens rows half a pitch right) the views
are the lens-by-lens resampled ones of ``elemental.extract_views``, each pixel standing
at its lens centre, and the shift is interpolated on that offset-row lattice.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..geometry.lens_array import LensArray


def _shift_lattice(image: np.ndarray, dy: float, dx: float, row_shift: float = 0.0) -> np.ndarray:
    """``out[i, j] = image[i + dy, j + dx]`` on a lattice whose odd rows sit ``row_shift`` lens
    pitches right (hex: 1/2, docs/geometry.md), with linear interpolation along each of the two
    nearest rows and between them, edges clamped.

    Pixel ``(i, j)`` stands at lattice position ``(i, j + row_shift (i % 2))``; the sample at
    ``(y, x)`` reads row ``r`` at its own column ``x - row_shift (r % 2)``.  With ``row_shift = 0``
    this is plain bilinear interpolation.
    """
    h, w = image.shape[:2]
    rows = np.arange(h)
    y = np.clip(rows + dy, 0, h - 1)
    y0 = np.floor(y).astype(int)
    y1 = np.minimum(y0 + 1, h - 1)
    ty = (y - y0)[:, None, None]
    x = np.arange(w)[None, :] + dx + row_shift * (rows % 2)[:, None]          # (h, w) lattice columns

    def along(r: np.ndarray) -> np.ndarray:
        c = np.clip(x - row_shift * (r % 2)[:, None], 0, w - 1)
        c0 = np.floor(c).astype(int)
        c1 = np.minimum(c0 + 1, w - 1)
        tc = (c - c0)[..., None]
        return image[r[:, None], c0] * (1 - tc) + image[r[:, None], c1] * tc

    return along(y0) * (1 - ty) + along(y1) * ty


def refocus_linear(views_linear: np.ndarray, offsets: tuple[np.ndarray, np.ndarray], pitch: tuple[float, float],
                   focal: float, depth: float) -> np.ndarray:
    """Refocus linear-light views of a square or lenticular camera bank at ``depth`` mm.

    Parameters
    ----------
    views_linear : (Ny, Nx, Ly, Lx, C) float
    offsets : (u (Nx,), v (Ny,)) mm, the views' pixel offsets (``LensArray.view_offsets``)
    pitch : (px, py) lens pitch, mm
    focal : mm
    depth : mm, > 0 behind the screen

    Returns
    -------
    (Ly, Lx, C) float, linear light.
    """
    return shift_and_add(views_linear, bank_steps(offsets, pitch, focal) * depth)


def bank_steps(offsets: tuple[np.ndarray, np.ndarray], pitch: tuple[float, float], focal: float) -> np.ndarray:
    """``(Ny, Nx, 2)`` lens rows and columns view ``(l, k)`` of a camera bank moves per mm of depth:
    ``(v_l / (f py), -u_k / (f px))`` (module doc)."""
    u, v = offsets
    return np.stack(np.broadcast_arrays(v[:, None] / (focal * pitch[1]), -u[None, :] / (focal * pitch[0])), -1)


def shift_and_add(views_linear: np.ndarray, shifts: np.ndarray, *, row_shift: float = 0.0,
                  used: np.ndarray | None = None) -> np.ndarray:
    """The mean of the views, each moved by its own shift (lens rows, lens columns).

    Parameters
    ----------
    views_linear : (Ny, Nx, Ly, Lx, C) float
    shifts : (Ny, Nx, 2) float            ``(dy, dx)``: view ``(l, k)`` is read at lens ``(i + dy, j + dx)``
    row_shift : float                     odd lens rows' offset, in lens pitches (hex: 1/2)
    used : (Ny, Nx) bool, optional        the views to sum (default all)

    Returns
    -------
    (Ly, Lx, C) float, linear light.
    """
    ny, nx = views_linear.shape[:2]
    used = np.ones((ny, nx), bool) if used is None else np.asarray(used, bool)
    if not used.any():
        raise ValueError("no view to refocus: every view lies outside the lens cell")
    acc = np.zeros(views_linear.shape[2:], np.float64)
    for l, k in zip(*np.nonzero(used)):  # one shift per view (tens of views), each a whole-image operation
        acc += _shift_lattice(views_linear[l, k], shifts[l, k, 0], shifts[l, k, 1], row_shift)
    return (acc / used.sum()).astype(np.float32)


def lens_steps(lens_array: LensArray, views: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, float]:
    """How far each view of ``elemental.extract_views`` moves per mm of depth, for ``shift_and_add``.

    View ``(l, k)`` at lens ``c`` sees the plane at depth ``z`` at ``c + z (u_k, v_l) / f``
    (the ray of a pixel), so it shows the point straight behind lens ``c`` at the lens
    ``c - z (u_k, v_l) / f``: that offset in the lattice's own frame, in lens columns and
    lens rows (rows count down).

    Returns
    -------
    steps : (Ny, Nx, 2) float       ``(rows, columns)`` per mm of depth
    used : (Ny, Nx) bool            the views to sum: on a hex array those whose offset lies a
                                    pixel inside the hexagon (its corners hold none of the
                                    square of view offsets), else all
    row_shift : float               odd rows' offset in lens pitches (hex 1/2, else 0)
    """
    from ..geometry.rays import cell_contains
    from .elemental import view_offsets

    la = lens_array
    u, v = view_offsets(la, views)
    uu, vv = np.meshgrid(u, v)                                   # (Ny, Nx)
    du, dv = la.to_lattice(-uu / la.focal, -vv / la.focal)
    if la.grid == "lattice":  # columns along a1, rows against a2
        from ..geometry.lattice import lattice_coordinates

        cols, up = lattice_coordinates(*la.basis_vectors(), du, dv)
        steps = np.stack([-up, cols], -1)
    else:
        steps = np.stack([-dv / la.pitch_y, du / la.pitch_x], -1)
    used = np.ones(uu.shape, bool)
    if la.grid == "hex":
        # A view offset near the hexagon's edge is read, on some lenses, from the nearest pixel
        # of the lens rather than between four (extract_views): it looks along another direction
        # and focuses at another depth.  The views a pixel inside the cell are read cleanly.
        lu, lv = la.to_lattice(uu, vv)
        inner = cell_contains("hex", la.pitch_x - 2 * la.panel.pitch_x, la.pitch_y, lu, lv)
        used = inner if inner.any() else cell_contains("hex", la.pitch_x, la.pitch_y, lu, lv)
    return steps, used, 0.5 if la.grid == "hex" else 0.0


def gradient_energy(image: np.ndarray) -> float:
    """Mean squared gradient of a linear-light image: higher is sharper."""
    g = np.asarray(image, np.float64).mean(axis=-1) if image.ndim == 3 else np.asarray(image, np.float64)
    return float(sum(np.mean(np.diff(g, axis=a) ** 2) for a in (0, 1) if g.shape[a] > 1))


def contact_sheet(images: list[np.ndarray], cols: int | None = None, gap: int = 2) -> np.ndarray:
    """Tile equally sized ``(h, w, C)`` images left to right, top to bottom, with black gaps."""
    n = len(images)
    cols = cols or int(np.ceil(np.sqrt(n)))
    rows = int(np.ceil(n / cols))
    h, w, c = images[0].shape
    sheet = np.zeros((rows * (h + gap) - gap, cols * (w + gap) - gap, c), images[0].dtype)
    for t, img in enumerate(images):
        r, q = divmod(t, cols)
        sheet[r * (h + gap): r * (h + gap) + h, q * (w + gap): q * (w + gap) + w] = img
    return sheet
