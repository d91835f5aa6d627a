"""Object ids read back from a mask render of ``scene.object_ids.mask_scene``."""

from __future__ import annotations

import numpy as np

from ..scene.object_ids import MAX_OBJECTS, UNRESOLVED


def decode_ids(image: np.ndarray, count: int) -> np.ndarray:
    """Object ids ``(H, W)`` uint16 from a 16-bit sRGB mask render ``(H, W, C)``: 0 background,
    ``UNRESOLVED`` where the colour is no id (grey channels disagree or fall between levels)."""
    from ..image.colour import srgb_to_linear

    codes = image[..., :3].astype(np.float64) / 65535.0
    linear = srgb_to_linear(codes)
    level = linear * (MAX_OBJECTS + 1)
    ids = np.rint(level)
    grey = (np.ptp(level, axis=-1) < 0.25) & (np.abs(level - ids).max(axis=-1) < 0.25)
    ident = ids[..., 0].astype(np.int64)
    ok = grey & (ident >= 0) & (ident <= count)
    return np.where(ok, ident, UNRESOLVED).astype(np.uint16)
