"""Silhouettes of triangle meshes in NumPy: orthographic along ``z``, point-sampled at pixel centres.

Independent of POV-Ray, so the tests compare POV-Ray's render of a converted
mesh with it, and simplification reports what it costs in silhouette.  Each
triangle is tested against the pixel centres inside its bounding box, all
triangles at once (in chunks that bound the memory): no loop over pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_CHUNK = 1 << 22  # pixel tests per chunk (about 200 MB of temporaries at most)


@dataclass(frozen=True)
class Window:
    """The rectangle ``[x0, x1] x [y0, y1]`` (mm) imaged onto ``width x height`` pixels.

    Pixel ``(col, row)``, row 0 at the top, samples
    ``X = x0 + (col + 0.5) * (x1 - x0) / width``, ``Y = y1 - (row + 0.5) * (y1 - y0) / height``:
    what POV-Ray's ``orthographic`` camera with ``right`` = width and ``up`` = height traces.
    """

    x0: float
    x1: float
    y0: float
    y1: float
    width: int
    height: int

    def __post_init__(self) -> None:
        for name in ("x0", "x1", "y0", "y1"):  # plain floats: their repr goes into scripts
            object.__setattr__(self, name, float(getattr(self, name)))
        if not (self.x1 > self.x0 and self.y1 > self.y0):
            raise ValueError(f"window must have x1 > x0 and y1 > y0, got {self}")
        if self.width < 1 or self.height < 1:
            raise ValueError(f"window needs at least 1x1 pixels, got {self.width}x{self.height}")

    @classmethod
    def around(cls, lo: np.ndarray, hi: np.ndarray, width: int, margin: float = 0.05) -> Window:
        """A window with square pixels around the box ``lo..hi`` (x, y), ``width`` pixels wide."""
        lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
        centre, half = (lo[:2] + hi[:2]) / 2, (hi[:2] - lo[:2]) / 2 * (1 + 2 * margin)
        half = np.maximum(half, half.max() * 1e-3)
        height = max(1, int(round(width * half[1] / half[0])))
        half_y = half[0] * height / width  # square pixels
        return cls(centre[0] - half[0], centre[0] + half[0], centre[1] - half_y, centre[1] + half_y, width, height)


def silhouette(vertices: np.ndarray, faces: np.ndarray, window: Window) -> np.ndarray:
    """``(height, width)`` bool: pixel centres covered by a triangle (edges included).

    Parameters
    ----------
    vertices : (n, 3) or (n, 2) float, mm; ``z`` is ignored (projection along ``z``)
    faces : (m, 3) int
    window : Window
    """
    w = window
    # Continuous pixel coordinates in which pixel (col, row) is centred on (col, row).
    u = (vertices[:, 0] - w.x0) * (w.width / (w.x1 - w.x0)) - 0.5
    v = (w.y1 - vertices[:, 1]) * (w.height / (w.y1 - w.y0)) - 0.5
    tu, tv = u[faces], v[faces]  # (m, 3)
    c0 = np.clip(np.ceil(tu.min(axis=1)), 0, w.width).astype(np.int64)
    c1 = np.clip(np.floor(tu.max(axis=1)), -1, w.width - 1).astype(np.int64)
    r0 = np.clip(np.ceil(tv.min(axis=1)), 0, w.height).astype(np.int64)
    r1 = np.clip(np.floor(tv.max(axis=1)), -1, w.height - 1).astype(np.int64)
    bw, bh = np.maximum(c1 - c0 + 1, 0), np.maximum(r1 - r0 + 1, 0)
    counts = bw * bh
    mask = np.zeros((w.height, w.width), dtype=bool)
    todo = np.flatnonzero(counts)
    cumulative = np.cumsum(counts[todo])
    start = 0
    while start < len(todo):
        # Take triangles until the chunk holds _CHUNK pixel tests (at least one triangle).
        base = cumulative[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(cumulative, base + _CHUNK, side="right")))
        tri = todo[start:stop]
        start = stop
        n = counts[tri]
        t = np.repeat(tri, n)
        local = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        col = c0[t] + local % bw[t]
        row = r0[t] + local // bw[t]
        au, av = tu[t, 0], tv[t, 0]
        bu, bv = tu[t, 1], tv[t, 1]
        cu, cv = tu[t, 2], tv[t, 2]
        e0 = (bu - au) * (row - av) - (bv - av) * (col - au)
        e1 = (cu - bu) * (row - bv) - (cv - bv) * (col - bu)
        e2 = (au - cu) * (row - cv) - (av - cv) * (col - cu)
        inside = ((e0 >= 0) & (e1 >= 0) & (e2 >= 0)) | ((e0 <= 0) & (e1 <= 0) & (e2 <= 0))
        area = (bu - au) * (cv - av) - (bv - av) * (cu - au)
        inside &= area != 0  # a triangle seen edge-on covers nothing
        mask[row[inside], col[inside]] = True
    return mask


def iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean masks (1.0 for two empty masks)."""
    union = np.logical_or(a, b).sum()
    return 1.0 if union == 0 else float(np.logical_and(a, b).sum() / union)
