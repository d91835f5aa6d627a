"""Depth values as 16-bit PNG codes and back (``render --depth-maps --depth-format png``).

Code 0 is "nothing hit" (NaN); codes 1..65535 are ``offset + (code - 1) * scale``,
one scale and offset for a whole set of maps; the rounding is at most half a ``scale``.
"""

from __future__ import annotations

import numpy as np

NO_HIT = 0          # the PNG code of a ray that hits nothing
TOP = 65535


def quantise(values: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Float values (NaN: none) -> uint16 codes (0: none, 1..65535 evenly over the finite range),
    the scale and the offset: ``value = offset + (code - 1) * scale``, to within ``scale / 2``."""
    finite = values[np.isfinite(values)]
    offset = float(finite.min()) if finite.size else 0.0
    span = float(finite.max()) - offset if finite.size else 0.0
    scale = span / (TOP - 1) if span > 0 else 1.0
    codes = np.full(values.shape, NO_HIT, np.uint16)
    ok = np.isfinite(values)
    codes[ok] = (np.rint((values[ok] - offset) / scale) + 1).clip(1, TOP).astype(np.uint16)
    return codes, scale, offset


def dequantise(codes: np.ndarray, scale: float, offset: float) -> np.ndarray:
    """uint16 codes -> float64 values, NaN where the code is 0 (the inverse of ``quantise``)."""
    return np.where(codes == NO_HIT, np.nan, offset + (codes.astype(np.float64) - 1) * scale)
