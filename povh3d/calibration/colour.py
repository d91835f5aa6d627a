"""Pixel values <-> linear light (povh3d.colour) for images that may be float, and the
grey image the lattice is found in.

Filtering that mixes pixels works in linear light (CONVENTIONS "Files"); images
are sRGB-encoded, 8- or 16-bit.  Float images are taken as linear already.
"""

from __future__ import annotations

import numpy as np

from ..colour import decode, encode


def to_linear(image: np.ndarray) -> tuple[np.ndarray, np.dtype]:
    """``(H, W[, C])`` uint8/uint16 sRGB or float linear -> float64 linear in ``[0, 1]``, and the dtype."""
    image = np.asarray(image)
    if image.dtype == np.uint8 or image.dtype == np.uint16:
        return decode(image), image.dtype
    return image.astype(np.float64), image.dtype


def from_linear(image: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """Inverse of :func:`to_linear`: back to ``dtype`` (sRGB-encoded when integer)."""
    if dtype == np.uint8 or dtype == np.uint16:
        return encode(image, dtype)
    return image.astype(dtype)


def grey(image: np.ndarray) -> np.ndarray:
    """``(H, W)`` float32 brightness in ``[0, 1]`` for lattice finding.

    Integer images are only scaled, not linearised: the lattice fit models the
    micro-image shape from the image itself, so any monotonic encoding works,
    and skipping the power law keeps calibrating a 21-megapixel image fast.
    """
    image = np.asarray(image)
    if image.ndim == 3:
        image = image[..., :3].mean(axis=2, dtype=np.float32) if image.shape[2] > 1 else image[..., 0]
    if image.dtype == np.uint8 or image.dtype == np.uint16:
        return image.astype(np.float32) * np.float32(1.0 / np.iinfo(image.dtype).max)
    return image.astype(np.float32)
