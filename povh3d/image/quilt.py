"""Quilts: a grid of views in one image, the layout light-field displays read.

Views are tiled ``cols x rows``, view 0 at the bottom-left, left to right, then
upward; the file name carries the grid and the view aspect: ``name_qs8x6a0.75.png``.
View 0 of a quilt is the leftmost camera.  In an H3D image the pixel left of the
lens centre (k = 0) shows the scene as seen from the right (docs/geometry.md), so
quilt view q is camera-bank view ``k = Nx - 1 - q``.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import ConfigError

_NAME = re.compile(r"_qs(\d+)x(\d+)a(\d+(?:\.\d+)?)(?=\.[A-Za-z]+$|$)")


def quilt_name(stem: str, cols: int, rows: int, aspect: float) -> str:
    """``stem_qs{cols}x{rows}a{aspect}.png`` (aspect = view width / height, up to 4 decimals)."""
    return f"{stem}_qs{cols}x{rows}a{aspect:.4f}".rstrip("0").rstrip(".") + ".png"


def parse_quilt_name(name: str) -> tuple[int, int, float] | None:
    """``(cols, rows, aspect)`` from a quilt file name, or None."""
    m = _NAME.search(str(name))
    return (int(m.group(1)), int(m.group(2)), float(m.group(3))) if m else None


def views_to_quilt(views: np.ndarray, cols: int, rows: int) -> np.ndarray:
    """Tile ``(n, h, w, C)`` views (quilt order) into a ``(rows*h, cols*w, C)`` quilt.

    Tiles beyond ``n`` stay black.
    """
    n, h, w, c = views.shape
    if n > cols * rows:
        raise ConfigError(f"{n} views do not fit a {cols}x{rows} quilt; give a larger --quilt")
    grid = np.zeros((rows * cols, h, w, c), views.dtype)
    grid[:n] = views
    # tile t sits in column t % cols of grid row t // cols counted from the bottom
    grid = grid.reshape(rows, cols, h, w, c)[::-1]
    return grid.transpose(0, 2, 1, 3, 4).reshape(rows * h, cols * w, c)


def quilt_to_views(quilt: np.ndarray, cols: int, rows: int, count: int | None = None) -> np.ndarray:
    """The exact inverse of ``views_to_quilt``: ``(count, h, w, C)`` views."""
    height, width, c = quilt.shape
    if height % rows or width % cols:
        raise ConfigError(f"a {width}x{height} quilt does not split into {cols}x{rows} equal views; "
                          "check --quilt")
    h, w = height // rows, width // cols
    grid = quilt.reshape(rows, h, cols, w, c).transpose(0, 2, 1, 3, 4)[::-1].reshape(rows * cols, h, w, c)
    return np.ascontiguousarray(grid[: count or rows * cols])


def bank_to_quilt_order(views: np.ndarray) -> np.ndarray:
    """``(1, Nx, Ly, Lx, C)`` camera-bank views -> ``(Nx, Ly, Lx, C)`` leftmost camera first."""
    if views.shape[0] != 1:
        raise ConfigError("a quilt holds one row of views: use a lenticular (horizontal-only) H3D image")
    return views[0, ::-1]


def quilt_to_bank_order(views: np.ndarray) -> np.ndarray:
    return views[None, ::-1]
