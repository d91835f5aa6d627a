"""Micro-image size equaliser (thesis 4.4).

Distortion and vignetting leave micro-images of unequal size.  The thesis takes
a default size from the calibration grid, averaging the micro-image widths
along the middle row of lenses and the heights along the middle column ("the
middle micro-images of both directions carry valid error size distributions"),
then resamples every micro-image to that size.  Here a micro-image's size is
the local lens pitch in the recorded image: the pitch times the distortion's
local magnification along the row (width) or across it (height).
"""

from __future__ import annotations

import numpy as np

from .gridfile import Grid
from .viewpoints import rectify


def micro_image_sizes(grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """Recorded width and height (px) of every micro-image of the table, ``(rows, cols)`` each."""
    ideal = grid.ideal_centres()
    jac = grid.local_jacobian(ideal)  # (rows, cols, 2, 2): d recorded / d ideal
    e1 = grid.a1 / np.linalg.norm(grid.a1)
    e2 = np.array([-e1[1], e1[0]])
    width = np.linalg.norm(jac @ e1, axis=-1) * grid.pitch_px
    height = np.linalg.norm(jac @ e2, axis=-1) * grid.pitch_px
    return width, height


def default_size(grid: Grid) -> tuple[float, float]:
    """Mean width along the middle lens row and mean height along the middle column (px)."""
    width, height = micro_image_sizes(grid)
    rows, cols = grid.table
    ok = grid.complete
    mid_r, mid_c = rows // 2, cols // 2
    w = width[mid_r][ok[mid_r]] if ok[mid_r].any() else width[ok]
    h = height[:, mid_c][ok[:, mid_c]] if ok[:, mid_c].any() else height[ok]
    return float(np.mean(w)), float(np.mean(h))


def equalise(image: np.ndarray, grid: Grid, size: int | None = None) -> tuple[np.ndarray, int]:
    """Every micro-image resampled to ``size`` x ``size`` px (default: the rounded default size).

    Returns the equalised H3D image (upright lens table, as :func:`rectify`) and the size used.
    """
    if size is None:
        size = max(1, int(round(float(np.mean(default_size(grid))))))
    return rectify(image, grid, size), size
