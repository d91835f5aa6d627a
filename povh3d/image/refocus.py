"""Digital refocusing (thesis 2.3.5.2): shift-and-sum over the views, in linear light.

A point at depth ``z`` (mm, > 0 behind the screen) and lateral position ``p``
is seen by view ``(l, k)`` through the lens centre ``p - z (u_k, v_l) / f``
(the ray of a pixel, docs/geometry.md).  So view ``(l, k)`` shifted by
``(-z u_k / (f px), +z v_l / (f py))`` lenses (columns, rows) lines that plane
up with every other view; averaging the shifted views focuses at ``z`` and
blurs everything else.
"""

from __future__ import annotations

import numpy as np


def _shift_bilinear(image: np.ndarray, dy: float, dx: float) -> np.ndarray:
    """``out[i, j] = image[i + dy, j + dx]`` with linear interpolation, edges clamped."""
    h, w = image.shape[:2]
    y = np.clip(np.arange(h) + dy, 0, h - 1)
    x = np.clip(np.arange(w) + dx, 0, w - 1)
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    y1, x1 = np.minimum(y0 + 1, h - 1), np.minimum(x0 + 1, w - 1)
    ty, tx = (y - y0)[:, None, None], (x - x0)[None, :, None]
    top = image[y0][:, x0] * (1 - tx) + image[y0][:, x1] * tx
    bottom = image[y1][:, x0] * (1 - tx) + image[y1][:, x1] * tx
    return top * (1 - ty) + bottom * ty


def refocus_linear(views_linear: np.ndarray, offsets: tuple[np.ndarray, np.ndarray], pitch: tuple[float, float],
                   focal: float, depth: float) -> np.ndarray:
    """Refocus linear-light views at ``depth`` mm.

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
    u, v = offsets
    ny, nx = views_linear.shape[:2]
    acc = np.zeros(views_linear.shape[2:], np.float64)
    for l in range(ny):  # one shift per view (tens of views), each a whole-image operation
        for k in range(nx):
            acc += _shift_bilinear(views_linear[l, k], depth * v[l] / (focal * pitch[1]),
                                   -depth * u[k] / (focal * pitch[0]))
    return (acc / (nx * ny)).astype(np.float32)


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
