"""The index maps a pixel mapping is described by: the view-space source it reads and,
for every panel subpixel, which source subpixel it shows."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Source:
    """The unmapped view-space H3D image a mapping reads: ``rows x lenses*views`` RGB."""

    rows: int
    lenses: int
    views: int

    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.rows, self.lenses * self.views, 3)


@dataclass(frozen=True)
class Sampling:
    """An index map and, for blended views, a second one with its weight.

    index : (H, W, 3) intp
        Flat index into the source ``(rows, lenses*views, 3)`` for every panel subpixel.
    black : (H, W, 3) bool or None
        Subpixels that show nothing (outside every lens).
    index2, weight : (H, W, 3) intp and float32, or None
        Blended fractional views: ``(1 - weight) * src[index] + weight * src[index2]``.
    """

    index: np.ndarray
    black: np.ndarray | None = None
    index2: np.ndarray | None = None
    weight: np.ndarray | None = None


def flat_index(src: Source, i: np.ndarray, j: np.ndarray, v: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Flat index of channel ``c`` of view ``v`` under lens ``j`` in view row ``i``."""
    return ((i * src.lenses + j) * src.views + v) * 3 + c
