"""The thesis's mappings for unslanted sheets and barriers (section 5.2).

- ``triangular`` (5.2.2): a lens of P subpixels shows P views; a view pixel's
  R, G, B go to three rows at horizontal offsets 0, +1, -1 subpixel - a triangle
  whose mean offset is 0, so the image is not slanted (no de-slanting; the
  thesis's point).  P = 10 on the 1680 x 1050 barrier gives 504 x 350 3D pixels.
- ``distributed`` (5.2.3): a coarse lens of P pixels (P views) becomes three fine
  lenses of P subpixels; fine lens t shows one channel of every view, the one the
  panel's stripe puts at that position.  When 3 divides P every position has the
  same colour in all three fine lenses, so fine lens t shifts its views by
  (0, +1, -1)[t] subpixels (wrapping inside the lens) to give each view its
  three colours.  The thesis does not say how it handles that case.
- ``distributed-smart:N`` (5.2.5): smart:N's layout of N*P views in N rows
  (pixels), then ``distributed`` on every row (its subpixels over 3 fine lenses).

The exact subpixel figures (5.8, 5.11, 5.25) are images that the text does not
carry, so the offsets above are this module's reading of their captions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import ConfigError, param
from .base import Mapping, centred_margin
from .sampling import Sampling, Source, flat_index
from .slanted import Slanted

TRIANGLE = (0, 1, -1)


def _ppl(name: str, ppl: int) -> int:
    if isinstance(ppl, bool) or not isinstance(ppl, int) or ppl < 1:
        raise ConfigError(f"mapping {name!r} needs whole pixels per lens ({param('ppl')}), got {ppl!r}")
    return ppl


def smart(n: int, ppl: int) -> Slanted:
    """``smart:N`` (Fig. 5.17): view ``(N x - l) mod N*P`` in whole pixels.

    Row l of the figure holds the views ``v`` with ``v = -l (mod N)`` at column
    ``ceil(v / N)`` and every N rows the pattern moves one pixel right: a lattice
    slanted by one pixel per N rows with 3D pixel distance ``s / N``.
    """
    p = _ppl(f"smart:{n}", ppl)
    return Slanted(f"smart:{n}", float(p), n * p, 1.0 / n, 0.0, n, unit="pixel")


@dataclass(frozen=True)
class Triangular(Mapping):
    ppl: int = 10
    name: str = "triangular"

    def __post_init__(self) -> None:
        _ppl(self.name, self.ppl)

    def source(self, panel: tuple[int, int]) -> Source:
        w, h = panel
        if h < 3:
            raise ConfigError("triangular needs at least 3 panel rows")
        return Source(h // 3, math.floor(3 * w / self.ppl), self.ppl)

    def view_pitch(self, pitch: tuple[float, float]) -> tuple[float, float, float]:
        return self.ppl * pitch[0] / 3, pitch[0] / 3, 3 * pitch[1]

    def resolution_3d(self, panel: tuple[int, int]) -> tuple[int, int]:
        src = self.source(panel)
        return (src.lenses, src.rows)

    def _sample(self, panel: tuple[int, int]) -> Sampling:
        w, h = panel
        src = self.source(panel)
        k = np.arange(3 * w, dtype=np.int64)[None, :]
        l = np.arange(h, dtype=np.int64)[:, None]
        virtual = k - np.asarray(TRIANGLE)[l % 3]  # where the subpixel's view pixel sits
        j = np.clip(virtual // self.ppl, 0, src.lenses - 1)
        v = np.where(virtual < 0, 0, np.where(virtual >= src.lenses * self.ppl, self.ppl - 1, virtual % self.ppl))
        i = np.minimum(l // 3, src.rows - 1)
        return Sampling(flat_index(src, i, j, v, k % 3).reshape(h, w, 3))


def distribute_index(width: int, height: int, ppl: int) -> tuple[np.ndarray, int, int]:
    """``distributed``'s map into a ``(H, W, 3)`` H3D image of coarse lenses of ``ppl`` pixels.

    Returns the flat index map ``(H, W, 3)``, the coarse lens count and the first
    column of the (centred) lens region; columns outside it map to themselves.
    """
    count, col0 = centred_margin(width, ppl)
    k = np.arange(3 * width, dtype=np.int64)
    ku = k - 3 * col0
    inside = (ku >= 0) & (ku < 3 * ppl * count)
    coarse, within = np.divmod(np.where(inside, ku, 0), 3 * ppl)
    fine, pos = np.divmod(within, ppl)
    shift = np.asarray(TRIANGLE if ppl % 3 == 0 else (0, 0, 0))[fine]
    view = (pos - shift) % ppl
    col = np.where(inside, col0 + coarse * ppl + view, k // 3)
    row_index = col * 3 + k % 3  # within one row
    l = np.arange(height, dtype=np.int64)[:, None]
    return (l * (3 * width) + row_index[None, :]).reshape(height, width, 3), count, col0


@dataclass(frozen=True)
class Distributed(Mapping):
    ppl: int = 10
    name: str = "distributed"

    def __post_init__(self) -> None:
        _ppl(self.name, self.ppl)

    def source(self, panel: tuple[int, int]) -> Source:
        return Source(panel[1], centred_margin(panel[0], self.ppl)[0], self.ppl)

    def view_pitch(self, pitch: tuple[float, float]) -> tuple[float, float, float]:
        return self.ppl * pitch[0], pitch[0] / 3, pitch[1]  # coarse lens centres, fine-lens directions

    def resolution_3d(self, panel: tuple[int, int]) -> tuple[int, int]:
        return (math.floor(3 * panel[0] / self.ppl), panel[1])  # fine lenses (Table 5.2: 504)

    def _sample(self, panel: tuple[int, int]) -> Sampling:
        w, h = panel
        index, count, col0 = distribute_index(w, h, self.ppl)
        # The source is only the lens region, rows x count*ppl: re-base the columns.
        src_w = count * self.ppl
        col = (index // 3) % w - col0
        row = index // (3 * w)
        black = (col < 0) | (col >= src_w)
        flat = (row * src_w + np.clip(col, 0, src_w - 1)) * 3 + index % 3
        return Sampling(flat, black if black.any() else None)


@dataclass(frozen=True)
class DistributedSmart(Mapping):
    n: int = 4
    ppl: int = 6
    name: str = "distributed-smart"

    def __post_init__(self) -> None:
        _ppl(self.name, self.ppl)

    @property
    def _smart(self) -> Slanted:
        return smart(self.n, self.ppl)

    def source(self, panel: tuple[int, int]) -> Source:
        return self._smart.source(panel)

    def view_pitch(self, pitch: tuple[float, float]) -> tuple[float, float, float]:
        # smart's views are s/N apart in pixels; distributing pixels to subpixels makes it s/(3N)
        # on the fine lenses.  Table 5.12 quotes s/N (0.096/4 = 0.024 mm): the coarse figure.
        return self.ppl * pitch[0], pitch[0] / self.n, self.n * pitch[1]

    def resolution_3d(self, panel: tuple[int, int]) -> tuple[int, int]:
        return self._smart.resolution_3d(panel)

    def render_array(self, panel, focal):
        # The fine lenses are a third of the coarse ones: the same views need a third of the focal.
        la = super().render_array(panel, focal)
        return type(la)(la.grid, la.lenses_x, la.lenses_y, la.pitch_x, la.pitch_y, la.focal * 3, la.panel)

    def _sample(self, panel: tuple[int, int]) -> Sampling:
        w, h = panel
        first = self._smart.sample(panel)
        second, _, _ = distribute_index(w, h, self.ppl)
        index = first.index.reshape(-1)[second]
        black = first.black.reshape(-1)[second] if first.black is not None else None
        return Sampling(index, black)
