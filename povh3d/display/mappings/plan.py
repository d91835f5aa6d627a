"""A mapping's index map compressed for the row gather (``povh3d.image.kernels``).

The reference ``Sampling`` is an ``(H, W, 3)`` int64 map: at 4K that is 200 MB
read on every apply, the reason a plain fancy-indexing gather costs 8-14 copies.
Every mapping here is periodic down the panel: row ``r`` reads what row
``r - P`` reads, shifted by a constant number of source elements (a whole
number of view rows).  ``Plan`` keeps one table row per distinct row pattern
(``P`` of them plus the clipped top and bottom rows) and one base offset per
panel row.  Mappings that move whole pixels (``smart``, margins aside) are
gathered as 3-element pixels, the others subpixel by subpixel.  Black subpixels
(outside every lens) are zeroed after the gather, per table row.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .sampling import Sampling

MAX_PERIOD = 64  # rows; the thesis's mappings repeat within 24 (alioscopy: lcm of 3 rows and 8 subpixels)


@dataclass(frozen=True)
class Plan:
    """``index[r].reshape(Q, unit)[q] = base[r] + table[tid[r], q] + arange(unit)`` (source elements).

    unit : int               elements per gathered item: 3 (whole pixels) or 1 (subpixels)
    base : (H,) int64        source element offset of each panel row
    tid : (H,) intp          table row of each panel row
    table : (T, Q) int32     element offset of each item from its row's base
    black : (T, Q) bool or None   items that show nothing
    """

    unit: int
    base: np.ndarray
    tid: np.ndarray
    table: np.ndarray
    black: np.ndarray | None

    @cached_property
    def span(self) -> tuple[np.ndarray, np.ndarray]:
        """Each table row's smallest and largest offset (the gather's bounds check, kept: at 4K
        computing them costs more than the gather)."""
        return self.table.min(axis=1).astype(np.int64), self.table.max(axis=1).astype(np.int64)

    def apply(self, flat: np.ndarray, out: np.ndarray) -> None:
        """Gather ``flat`` (the source, 1-D contiguous) into ``out`` ``(H, W, 3)`` in place."""
        from ...image.kernels import row_gather

        size = flat.dtype.itemsize
        table = self.table if size == 1 else (self.table.astype(np.int64) * size)
        low, high = self.span
        if not row_gather(flat, self.unit * size, self.base * size, self.tid, table, out,
                          (low * size, high * size)):
            raise AssertionError("row gather refused C-contiguous arrays")  # pragma: no cover
        if self.black is not None:
            items = out.reshape(self.base.size, self.table.shape[1], self.unit)
            for t in np.flatnonzero(self.black.any(axis=1)):
                items[np.ix_(np.flatnonzero(self.tid == t), np.flatnonzero(self.black[t]))] = 0


def _rows_match(u: np.ndarray, black: np.ndarray | None, r: int, p: int) -> int | None:
    """The constant shift from row ``r - p`` to row ``r``, or None when they differ by more than a shift."""
    if black is not None and not np.array_equal(black[r], black[r - p]):
        return None
    d = u[r] - u[r - p]
    if black is not None:
        d = d[~black[r]]
        if d.size == 0:
            return 0
    return int(d[0]) if (d == d[0]).all() else None


def _period(u: np.ndarray, black: np.ndarray | None) -> int:
    """The smallest row period of the interior (0 when there is none up to MAX_PERIOD)."""
    h = u.shape[0]
    mid = h // 2
    # One window for every candidate, longer than the longest period: a short window let
    # smart:4 (period 24) pass as period 1, whose shift holds in 3 rows of 4, and its plan
    # kept 631 table rows (29 MB at 4K) instead of 24.
    rows = range(max(1, mid - MAX_PERIOD), min(h, mid + MAX_PERIOD))
    for p in range(1, min(MAX_PERIOD, h // 2) + 1):
        if all(_rows_match(u, black, r, p) is not None for r in rows if r >= p):
            return p
    return 0


def build_plan(sampling: Sampling) -> Plan:
    """Compress a non-blended ``Sampling`` into a ``Plan`` (exact: tests rebuild the index map from it)."""
    if sampling.index2 is not None:
        raise ValueError("blended samplings mix two sources; they have no plan")
    index = np.asarray(sampling.index)
    h, w, _ = index.shape
    black = sampling.black
    whole = (np.array_equal(index[..., 1], index[..., 0] + 1) and np.array_equal(index[..., 2], index[..., 0] + 2)
             and not (index[..., 0] % 3).any()
             and (black is None or (np.array_equal(black[..., 1], black[..., 0])
                                    and np.array_equal(black[..., 2], black[..., 0]))))
    if whole:
        unit, u = 3, index[..., 0]
        blk = None if black is None else black[..., 0]
    else:
        unit, u = 1, index.reshape(h, 3 * w)
        blk = None if black is None else black.reshape(h, 3 * w)
    if blk is not None and not blk.any():
        blk = None
    p = _period(u, blk)
    base = np.zeros(h, np.int64)
    tid = np.zeros(h, np.intp)
    rows: list[np.ndarray] = []
    black_rows: list[np.ndarray] = []
    for r in range(h):
        d = _rows_match(u, blk, r, p) if p and r >= p else None
        if d is not None:
            tid[r], base[r] = tid[r - p], base[r - p] + d
            continue
        row = u[r] if blk is None else np.where(blk[r], -1, u[r])
        shown = row[row >= 0] if blk is not None else row
        lo = int(shown.min()) if shown.size else 0
        # Black items point at the row's first shown element: in range for the gather, zeroed after it.
        rows.append(np.where(row >= 0, row - lo, 0) if blk is not None else row - lo)
        black_rows.append(blk[r] if blk is not None else np.zeros(u.shape[1], bool))
        tid[r], base[r] = len(rows) - 1, lo
    table = np.stack(rows)
    table = table.astype(np.int32 if table.max(initial=0) < 2**31 else np.int64)
    blacks = np.stack(black_rows) if blk is not None else None
    return Plan(unit, base, tid, table, blacks)
