"""Quilt -> native Looking Glass panel image, as the vendor's lenticular shader computes it.

The vendor's shader (Looking Glass Bridge's ``Lenticular_RGBA_With_Aspect``, public in
its Unity plugin's ``LookingGlass/Lenticular`` shader; the uniforms as LKG-Toolkit's
``Calibration.ProcessPitch``/``ProcessSlope`` and the WebXR library's config set them)
does, for each subpixel ``c`` (R, G, B) of the panel pixel at ``uv`` (0..1, y up):

- position ``(x, y)``: ``uv.x + c / (3 W)``, ``uv.y`` on a classic panel; on a Gen3
  panel ``uv + (dx_c / W, dy_c / H)`` with the offsets of the pixel's subpixel cell
  (``subpixelCells``, the cell chosen by ``CellPatternMode`` from the pixel's column/row);
- ``a = (x + y * tilt) * pitch' - center`` with ``pitch' = pitch * W / DPI * cos(atan(1/slope))``
  (lenticules across the panel) and ``tilt = H / (W * slope)``, negated by ``flipImageX``;
- view fraction ``1 - fract(a)`` (``fract(a)`` when ``invView`` is 0), clamped into (0, 1);
- view ``int(fraction * views)``, its tile at column ``view % cols``, row ``view // cols``
  counted from the quilt's bottom; the tile is sampled at ``uv`` (mirrored by ``flipImageX`` /
  ``flipImageY``), and channel ``c`` of that sample lights subpixel ``c``.

This is the shader's nearest-view mode (``filterMode 0``), the one every unit ships with;
``sampling`` picks nearest or bilinear reading *within* the tile.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..looking_glass import Calibration
from ...errors import ConfigError

if TYPE_CHECKING:
    from .slanted import Slanted

# The shader clamps the view fraction into this range before picking a tile.
_LOW, _HIGH = 0.00001, 0.999999


def shader_uniforms(cal: Calibration) -> dict[str, float]:
    """``pitch`` (lenticules across the panel), ``tilt`` and ``subp`` as the vendor sets them."""
    pitch = cal.pitch * cal.screen_w / cal.dpi * math.cos(math.atan(1.0 / cal.slope))
    tilt = cal.screen_h / (cal.screen_w * cal.slope) * (-1.0 if cal.flip_x else 1.0)
    return {"pitch": pitch, "tilt": tilt, "subp": 1.0 / (3 * cal.screen_w), "center": cal.center}


def cell_index(cal: Calibration, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The subpixel cell of each pixel: the shader's ``getCellForPixel`` on its integer
    position ``(int(uv.x W), int(uv.y H))``, ``uv.y`` counted from the bottom."""
    x = cols
    y = cal.screen_h - 1 - rows
    mode = cal.cell_pattern
    if mode == 0:
        return np.zeros(np.broadcast(x, y).shape, np.int64)
    if mode == 1:
        return ((x + y) % 2).astype(np.int64)
    if mode == 2:
        return np.broadcast_to(x % 2, np.broadcast(x, y).shape).astype(np.int64)
    if mode == 3:
        return ((y + (x % 2) * 2) % 4).astype(np.int64)
    return np.broadcast_to(y % 2, np.broadcast(x, y).shape).astype(np.int64)


def view_fractions(cal: Calibration) -> np.ndarray:
    """``(H, W, 3)`` view fraction (0..1) of every subpixel of the panel, row 0 at the top."""
    u = shader_uniforms(cal)
    w, h = cal.screen_w, cal.screen_h
    rows = np.arange(h)[:, None]
    cols = np.arange(w)[None, :]
    x = (cols + 0.5) / w                         # (1, W)
    y = (h - rows - 0.5) / h                     # (H, 1): uv.y points up
    if cal.subpixel_cells:
        cells = np.asarray(cal.subpixel_cells, float)        # (n, 6) pixels
        idx = cell_index(cal, rows, cols)                    # (H, W)
        dx = cells[idx][..., 0::2] / w                       # (H, W, 3)
        dy = cells[idx][..., 1::2] / h
        px = x[..., None] + dx
        py = y[..., None] + dy
    else:
        px = x[..., None] + np.arange(3) * u["subp"]          # (1, W, 3)
        py = y[..., None]                                     # (H, 1, 1)
    a = (px + py * u["tilt"]) * u["pitch"] - u["center"]
    frac = a - np.floor(a)
    if cal.inv_view:
        frac = 1.0 - frac
    return np.clip(np.broadcast_to(frac, (h, w, 3)), _LOW, _HIGH)


def quilt_to_native(quilt: np.ndarray, grid: tuple[int, int], cal: Calibration, *,
                    views: int | None = None, sampling: str = "nearest") -> np.ndarray:
    """The native panel image ``(screenH, screenW, C)`` that shows ``quilt`` on the unit ``cal``.

    quilt : (Hq, Wq, C) array, view 0 at the bottom-left, tiles left to right then upward;
            a quilt wider or taller than ``cols x tile`` keeps its padding on the right/top,
            as the vendor's ``viewPortion`` does.
    grid : (cols, rows)
    views : tiles in use (the vendor's ``tileCount``), default cols * rows
    sampling : "nearest" or "bilinear" reading inside the chosen tile
    """
    if quilt.ndim != 3 or quilt.shape[2] < 3:
        raise ConfigError(f"a quilt is an RGB image, got an array of shape {quilt.shape}")
    cols, rows = grid
    if cols < 1 or rows < 1:
        raise ConfigError(f"a quilt grid needs at least one column and row, got {cols}x{rows}")
    n = views or cols * rows
    if not 1 <= n <= cols * rows:
        raise ConfigError(f"{n} views do not fit a {cols}x{rows} quilt")
    if sampling not in ("nearest", "bilinear"):
        raise ConfigError(f"unknown sampling {sampling!r}; choose nearest or bilinear")
    hq, wq = quilt.shape[:2]
    tw, th = wq // cols, hq // rows
    if tw < 1 or th < 1:
        raise ConfigError(f"a {wq}x{hq} quilt is too small for {cols}x{rows} views")
    w, h = cal.screen_w, cal.screen_h
    view = np.minimum((view_fractions(cal) * n).astype(np.int64), n - 1)     # (H, W, 3)
    tile_col = view % cols
    tile_row = view // cols                                                   # from the bottom
    # the tile is read at the pixel's own uv (the shader's tileUV), mirrored by the flips
    tu = (np.arange(w) + 0.5) / w
    tv = (h - np.arange(h) - 0.5) / h
    if cal.flip_x:
        tu = 1.0 - tu
    if cal.flip_y:
        tv = 1.0 - tv
    fx = np.broadcast_to(tu[None, :, None] * tw, view.shape)                 # pixels inside the tile
    fy = np.broadcast_to(tv[:, None, None] * th, view.shape)                 # from the tile's bottom
    channel = np.broadcast_to(np.arange(3), view.shape)
    x0 = tile_col * tw
    top = hq - (tile_row + 1) * th          # the tile's top row in the array (row 0 at the top)

    def read(ix: np.ndarray, iy: np.ndarray) -> np.ndarray:
        ix = np.clip(ix, 0, tw - 1)
        iy = np.clip(iy, 0, th - 1)
        return quilt[top + (th - 1 - iy), x0 + ix, channel]

    if sampling == "nearest":
        out = read(np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64))
        return out.astype(quilt.dtype)
    gx, gy = fx - 0.5, fy - 0.5
    ix, iy = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
    wx, wy = gx - ix, gy - iy
    acc = ((1 - wx) * (1 - wy) * read(ix, iy) + wx * (1 - wy) * read(ix + 1, iy)
           + (1 - wx) * wy * read(ix, iy + 1) + wx * wy * read(ix + 1, iy + 1))
    if np.issubdtype(quilt.dtype, np.integer):
        return np.clip(np.rint(acc), 0, np.iinfo(quilt.dtype).max).astype(quilt.dtype)
    return acc.astype(quilt.dtype)


def slanted_mapping(cal: Calibration, views: int, *, blend: bool = False) -> Slanted:
    """The view-space slanted mapping (``map``, ``render --method subpixel``) of a calibration.

    It shares the shader's view index (tested), but addresses lenses, not tiles, and has no
    flips or subpixel cells: those fields are reported, not silently dropped.
    """
    from ...errors import warn
    from .slanted import looking_glass

    unused = [name for name, on in (("flipImageX", cal.flip_x), ("flipImageY", cal.flip_y),
                                    ("subpixelCells", bool(cal.subpixel_cells))) if on]
    if unused:
        warn(f"the view-space mapping ignores the calibration's {', '.join(unused)}; make the panel image "
             "from a quilt (display.mappings.looking_glass_shader.quilt_to_native), which follows them")
    from ..looking_glass import visual_fields
    return looking_glass(visual_fields(cal), views, blend=blend)
