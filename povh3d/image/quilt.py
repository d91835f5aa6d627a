"""Quilts: a grid of views in one image, the layout light-field displays read.

Views are tiled ``cols x rows``, view 0 at the bottom-left, left to right, then
upward; the file name carries the grid and the view aspect: ``name_qs8x6a0.75.png``.
That aspect is the view's *physical* shape, the width over the height of the
display the view fills (a Looking Glass stretches each tile to it), never the
tile's pixel shape: a lenticular view is ``Lx x H`` pixels of ``px x s`` mm.
View 0 of a quilt is the leftmost camera.  In an H3D image the pixel left of the
lens centre (k = 0) shows the scene as seen from the right (docs/geometry.md), so
quilt view q is camera-bank view ``k = Nx - 1 - q``.
"""

from __future__ import annotations

import re

import numpy as np

from ..errors import ConfigError, param

_NAME = re.compile(r"_qs(\d+)x(\d+)a(\d+(?:\.\d+)?)(?=\.[A-Za-z]+$|$)")


def quilt_name(stem: str, cols: int, rows: int, aspect: float) -> str:
    """``stem_qs{cols}x{rows}a{aspect}.png`` (aspect = view width / height, up to 4 decimals)."""
    return f"{stem}_qs{cols}x{rows}a{aspect:.4f}".rstrip("0").rstrip(".") + ".png"


def parse_quilt_name(name: str) -> tuple[int, int, float] | None:
    """``(cols, rows, aspect)`` from a quilt file name, or None."""
    m = _NAME.search(str(name))
    return (int(m.group(1)), int(m.group(2)), float(m.group(3))) if m else None


def views_to_quilt(views: np.ndarray, cols: int, rows: int, size: tuple[int, int] | None = None) -> np.ndarray:
    """Tile ``(n, h, w, C)`` views (quilt order) into a ``(rows*h, cols*w, C)`` quilt, or one of
    ``size = (W, H)`` padded (black) at the right and top, as a device's quilt is.

    Tiles beyond ``n`` stay black.
    """
    n, h, w, c = views.shape
    if n > cols * rows:
        raise ConfigError(f"{n} views do not fit a {cols}x{rows} quilt; give a larger {param('quilt')}")
    width, height = size or (cols * w, rows * h)
    if width < cols * w or height < rows * h:
        raise ConfigError(f"a {cols}x{rows} grid of {w}x{h} tiles exceeds the {width}x{height} quilt")
    quilt = np.zeros((height, width, c), views.dtype)
    # tile t sits in column t % cols of grid row t // cols counted from the bottom; one copy a tile
    for t in range(n):
        bottom = height - (t // cols) * h
        quilt[bottom - h:bottom, (t % cols) * w:(t % cols + 1) * w] = views[t]
    return quilt


def quilt_to_views(quilt: np.ndarray, cols: int, rows: int, count: int | None = None) -> np.ndarray:
    """The exact inverse of ``views_to_quilt``: ``(count, h, w, C)`` views."""
    height, width, c = quilt.shape
    if height % rows or width % cols:
        raise ConfigError(f"a {width}x{height} quilt does not split into {cols}x{rows} equal views; "
                          f"check {param('quilt')}")
    h, w = height // rows, width // cols
    grid = quilt.reshape(rows, h, cols, w, c).transpose(0, 2, 1, 3, 4)[::-1].reshape(rows * cols, h, w, c)
    return np.ascontiguousarray(grid[: count or rows * cols])


def bank_to_quilt_order(views: np.ndarray, rows: str | None = None) -> np.ndarray:
    """``(Ny, Nx, Ly, Lx, C)`` camera-bank views -> ``(n, Ly, Lx, C)`` in quilt order.

    Quilt order is the leftmost camera first, then rightward; with ``rows="all"``
    row by row from the lowest camera upward (the quilt's tiles run upward too).
    Bank view ``(l, k)`` looks along ``(u_k, v_l, f)``: ``k = Nx - 1`` is seen from the
    left and ``l = 0`` (v > 0) from below, so quilt tile ``t`` of ``rows="all"`` is
    ``(l, k) = (t // Nx, Nx - 1 - t % Nx)``.

    rows : None (the bank must hold one row), "centre" (the row nearest the
           horizontal: ``l = Ny // 2``, the lower middle row of an even bank) or "all".
    """
    ny = views.shape[0]
    if rows is None:
        if ny != 1:
            raise ConfigError(f"the image has {ny} rows of views and a quilt holds one row; give {param('rows')} centre "
                              f"(the middle row) or {param('rows')} all")
        rows = "centre"
    if rows == "centre":
        return views[ny // 2, ::-1]
    if rows == "all":
        return views[:, ::-1].reshape(-1, *views.shape[2:])
    raise ConfigError(f"unknown rows {rows!r}; choose centre or all")


def quilt_to_bank_order(views: np.ndarray, ny: int = 1) -> np.ndarray:
    """The inverse of ``bank_to_quilt_order(..., rows="all")`` (``ny = 1``: one row)."""
    n = views.shape[0]
    if n % ny:
        raise ConfigError(f"{n} views do not split into {ny} rows")
    return views.reshape(ny, n // ny, *views.shape[1:])[:, ::-1]


def view_aspect(width_mm: float, height_mm: float) -> float:
    """The aspect written in a quilt's name: the view's physical width over height, mm / mm.

    Every view covers the whole display, so this is the display's (lens array's)
    extent: a 32 x 30 mm lenticular sheet gives 32 / 30 whatever its view count.
    """
    if not (width_mm > 0 and height_mm > 0):
        raise ConfigError(f"a view's size must be positive, got {width_mm!r} x {height_mm!r} mm")
    return width_mm / height_mm


def auto_grid(views: int, tile: tuple[int, int], device_grid: tuple[int, int] | None = None) -> tuple[int, int]:
    """``--quilt auto``: the ``(cols, rows)`` grid for ``views`` tiles of ``tile = (height, width)`` px.

    A device's own layout when it holds exactly these views (a Looking Glass
    Portrait's 48 views: 8 x 6); otherwise the exact factorisation ``cols x rows =
    views`` whose quilt is nearest square (what the vendor's quilts are), more
    columns on a tie.
    """
    if views < 1:
        raise ConfigError(f"a quilt needs at least one view, got {views}")
    if device_grid is not None and device_grid[0] * device_grid[1] == views:
        return device_grid
    h, w = tile
    pairs = [(c, views // c) for c in range(1, views + 1) if views % c == 0]
    return min(pairs, key=lambda p: (abs(np.log(p[0] * w / (p[1] * h))), -p[0]))
