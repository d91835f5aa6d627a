"""De-slanting and viewpoint extraction from a calibrated capture (thesis 3.4, 4.2).

Viewpoint ``(a, b)`` is pixel ``(a, b)`` of every micro-image (thesis Fig. 4.5).
With a calibrated grid the micro-images are rarely whole pixels wide, turned
(slanted arrays) and distorted, so pixel ``(a, b)`` of lens ``(i, j)`` is
*sampled*: at the ideal position

    centre_ij + ((b + 1/2)/N - 1/2) p e1 + ((a + 1/2)/N - 1/2) p e2

(``e1`` along the lens row, ``e2`` perpendicular to it, toward image +y,
``p`` the pitch) mapped through the grid's distortion, with bilinear
interpolation in linear light.  The result is an H3D image with square,
upright, ``N x N``-pixel micro-images on the lens table (the layout
:func:`povh3d.image.interleave.extract` reads); lenses not wholly on the image are black.
Hex tables keep the conventions' offset rows, tiled without the half-lens shift.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from ..image.interleave import extract
from ..image.colour import from_linear, to_linear
from .distortion import sample
from .gridfile import Grid


def micro_image_positions(grid: Grid, ppl: int) -> np.ndarray:
    """Recorded positions ``(rows, cols, N, N, 2)`` px of pixel ``(a, b)`` of every micro-image."""
    if not isinstance(ppl, (int, np.integer)) or ppl < 1:
        raise ConfigError(f"pixels per lens must be a whole number of at least 1, got {ppl!r}")
    e1 = grid.a1 / np.linalg.norm(grid.a1)
    e2 = np.array([-e1[1], e1[0]])
    if e2 @ grid.row_step < 0:
        e2 = -e2
    t = ((np.arange(ppl) + 0.5) / ppl - 0.5) * grid.pitch_px
    offs = t[None, :, None] * e1 + t[:, None, None] * e2  # [a, b] -> offset px
    ideal = grid.ideal_centres()[:, :, None, None, :] + offs
    return grid.distortion.distort(ideal)


def rectify(image: np.ndarray, grid: Grid, ppl: int) -> np.ndarray:
    """``(rows * N, cols * N[, C])`` H3D image with upright ``N x N`` micro-images, same dtype."""
    grid.check_image(image.shape)
    pos = micro_image_positions(grid, ppl)
    lin, dtype = to_linear(image), image.dtype
    out = sample(lin, pos)
    out[~grid.complete] = 0.0
    rows, cols = grid.table
    out = out.transpose(0, 2, 1, 3, *range(4, out.ndim)).reshape(rows * ppl, cols * ppl, *out.shape[4:])
    return from_linear(out, dtype)


def viewpoints(image: np.ndarray, grid: Grid, ppl: int) -> np.ndarray:
    """Viewpoint images ``(N, N, rows, cols, C)``: ``[a, b]`` is pixel ``(a, b)`` of every micro-image."""
    rect = rectify(image, grid, ppl)
    return extract(rect if rect.ndim == 3 else rect[..., None], (ppl, ppl))
