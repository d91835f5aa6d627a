"""Stitching two captures taken a whole number of lenses apart (thesis 4.5).

The camera must move by a whole number of lenses, "otherwise elemental images
will be integrated with false information": then lens ``(i, j)`` of capture B
sees exactly what lens ``(i + di, j + dj)`` of A saw.  The shift is found in
the lens table: the mean of each micro-image is a small image of the scene
that moves with the camera, so the best whole shift minimises their mismatch
over the overlap, and a parabola through the mismatch of the neighbouring
shifts estimates the fraction of a lens left over; a shift that is not whole
(or captures that match at no shift) is refused.

When the shift is a whole number of *pixels* and the grid has no distortion
(renders, integral pitch) the captures are joined pixel for pixel: the result
is exactly the capture a camera with the wider sensor would have taken.
Otherwise both are first rectified (upright ``N x N`` micro-images) and the
lens tables are joined.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..image.colour import to_linear
from .gridfile import Grid
from .viewpoints import rectify


@dataclass(frozen=True)
class Shift:
    """Lens shift of capture B relative to A: B's lens ``(i, j)`` is A's ``(i + di, j + dj)``."""

    di: int
    dj: int
    fraction: tuple[float, float]  # estimated leftover (rows, cols), lenses
    mismatch: float  # RMS difference over the overlap / RMS contrast of A


def lens_means(image: np.ndarray, grid: Grid, ppl: int) -> np.ndarray:
    """``(rows, cols, C)`` mean linear value of each complete micro-image, NaN elsewhere."""
    rect = rectify(to_linear(image), grid, ppl)
    rows, cols = grid.table
    rect = rect.reshape(rows, ppl, cols, ppl, -1).mean(axis=(1, 3))
    rect[~grid.complete] = np.nan
    return rect


def _mismatch(a: np.ndarray, b: np.ndarray, di: int, dj: int, min_overlap: int) -> float:
    rows, cols = a.shape[:2]
    ia = slice(max(0, di), min(rows, rows + di))
    ja = slice(max(0, dj), min(cols, cols + dj))
    ib = slice(max(0, -di), min(rows, rows - di))
    jb = slice(max(0, -dj), min(cols, cols - dj))
    d = a[ia, ja] - b[ib, jb]
    ok = ~np.isnan(d).any(axis=-1)
    if ok.sum() < min_overlap:
        return np.inf
    return float(np.sqrt(np.mean(d[ok] ** 2)))


def find_shift(a: np.ndarray, b: np.ndarray, grid: Grid, *, tolerance: float = 0.2,
               max_mismatch: float = 0.2, min_overlap: float = 0.15) -> Shift:
    """The whole-lens shift between captures ``a`` and ``b``; InputError if it is not whole.

    Hex tables are searched over even row shifts only (an odd one changes the
    half-lens stagger of the rows).
    """
    grid.check_image(a.shape, "capture A")
    grid.check_image(b.shape, "capture B")
    ppl = max(2, int(round(grid.pitch_px)))
    ma = lens_means(a, grid, ppl)
    mb = lens_means(b, grid, ppl)
    rows, cols = grid.table
    need = max(4, int(min_overlap * np.sum(grid.complete)))
    step_i = 2 if grid.lattice == "hex" else 1
    scores = {}
    for di in range(-(rows - 1), rows, 1):
        for dj in range(-(cols - 1), cols):
            if di % step_i == 0:
                scores[(di, dj)] = _mismatch(ma, mb, di, dj, need)
    (di, dj), best = min(scores.items(), key=lambda kv: kv[1])
    if not np.isfinite(best):
        raise InputError("the captures do not overlap by enough lenses to find their shift; "
                         f"they must share at least {need} whole lenses")
    contrast = float(np.nanstd(ma)) + 1e-12

    def vertex(lo: float, mid: float, hi: float) -> float:
        # Mismatch is an RMS (grows like |s|), so fit the parabola to its square.
        if not (np.isfinite(lo) and np.isfinite(hi)):
            return 0.0
        lo, mid, hi = lo**2, mid**2, hi**2
        den = lo - 2 * mid + hi
        return 0.0 if den <= 0 else float(np.clip(0.5 * (lo - hi) / den, -0.5, 0.5))
    frac_j = vertex(scores.get((di, dj - 1), np.inf), best, scores.get((di, dj + 1), np.inf))
    frac_i = vertex(scores.get((di - step_i, dj), np.inf), best, scores.get((di + step_i, dj), np.inf)) * step_i
    shift = Shift(di, dj, (frac_i, frac_j), best / contrast)
    if max(abs(frac_i), abs(frac_j)) > tolerance or shift.mismatch > max_mismatch:
        raise InputError(
            f"capture B is shifted by about ({di + frac_i:.2f}, {dj + frac_j:.2f}) lenses (rows, columns) from A "
            f"(mismatch {shift.mismatch:.3f}); stitching needs a whole number of lenses: "
            "move the camera by whole lenses")
    return shift


def stitch(a: np.ndarray, b: np.ndarray, grid: Grid, shift: Shift | None = None) -> tuple[np.ndarray, Shift, str]:
    """Join captures ``a`` and ``b`` (``b`` ``shift`` lenses from ``a``); ``a`` wins where they overlap.

    Returns the stitched image, the shift and the mode (``'pixels'`` or ``'rectified'``).
    """
    shift = shift or find_shift(a, b, grid)
    step = shift.dj * grid.a1 + shift.di * grid.row_step  # B's pixel x is A's pixel x + step
    whole = np.allclose(step, np.round(step), atol=1e-6)
    if whole and grid.distortion.is_identity:
        sx, sy = (int(v) for v in np.round(step))
        h, w = a.shape[:2]
        x0, y0 = min(0, sx), min(0, sy)
        out = np.zeros((max(h, h + sy) - y0, max(w, w + sx) - x0, *a.shape[2:]), dtype=a.dtype)
        out[sy - y0:sy - y0 + h, sx - x0:sx - x0 + w] = b
        out[-y0:-y0 + h, -x0:-x0 + w] = a
        return out, shift, "pixels"
    ppl = max(1, int(round(grid.pitch_px)))
    ra = rectify(a, grid, ppl)
    rb = rectify(b, grid, ppl)
    rows, cols = grid.table
    di, dj = shift.di, shift.dj
    i0, j0 = min(0, di), min(0, dj)
    out = np.zeros(((max(rows, rows + di) - i0) * ppl, (max(cols, cols + dj) - j0) * ppl, *ra.shape[2:]),
                   dtype=ra.dtype)
    out[(di - i0) * ppl:(di - i0 + rows) * ppl, (dj - j0) * ppl:(dj - j0 + cols) * ppl] = rb
    keep = np.repeat(np.repeat(grid.complete, ppl, 0), ppl, 1)
    region = out[-i0 * ppl:(-i0 + rows) * ppl, -j0 * ppl:(-j0 + cols) * ppl]
    region[keep] = ra[keep]
    return out, shift, "rectified"
