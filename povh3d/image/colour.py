"""sRGB transfer functions, the one copy in povh3d: filtering that mixes pixels
works in linear light, images are sRGB-encoded (docs/geometry.md, "Files")."""

from __future__ import annotations

from functools import lru_cache

import numpy as np


def srgb_to_linear(values: np.ndarray, dtype: np.dtype | type = np.float64) -> np.ndarray:
    """sRGB-encoded values in ``[0, 1]`` to linear light (IEC 61966-2-1), computed in ``dtype``."""
    dtype = np.dtype(dtype).type
    v = np.asarray(values, dtype=dtype)
    return np.where(v <= 0.04045, v / dtype(12.92), ((v + dtype(0.055)) / dtype(1.055)) ** dtype(2.4))


def linear_to_srgb(values: np.ndarray, dtype: np.dtype | type = np.float64) -> np.ndarray:
    """Linear light to sRGB-encoded values in ``[0, 1]`` (clipped), computed in ``dtype``."""
    dtype = np.dtype(dtype).type
    v = np.clip(np.asarray(values, dtype=dtype), 0.0, 1.0)
    return np.where(v <= 0.0031308, v * dtype(12.92), dtype(1.055) * v ** dtype(1 / 2.4) - dtype(0.055))


def decode(image: np.ndarray, dtype: np.dtype | type = np.float64) -> np.ndarray:
    """An sRGB image to linear light in ``dtype``: 8- or 16-bit, or float already in ``[0, 1]``."""
    image, dtype = np.asarray(image), np.dtype(dtype).type
    if image.dtype in (np.uint8, np.uint16):
        # mypy misses that type[Any] is hashable (lru_cache's Hashable arguments)
        return _decode_table(image.dtype.type, dtype)[image]  # type: ignore[arg-type]
    if np.issubdtype(image.dtype, np.integer):
        image = image.astype(dtype) / dtype(np.iinfo(image.dtype).max)
    return srgb_to_linear(image, dtype)


@lru_cache(maxsize=8)
def _decode_table(code: type, dtype: type) -> np.ndarray:
    """Every 8- or 16-bit code's linear value: a lookup is ~10x faster than the power per pixel
    and gives the same numbers (the same formula, per code)."""
    top = np.iinfo(code).max
    table = srgb_to_linear(np.arange(top + 1, dtype=dtype) / dtype(top), dtype)
    table.setflags(write=False)
    return table


def encode(linear: np.ndarray, dtype: np.dtype | type = np.uint8) -> np.ndarray:
    """Linear light to an sRGB image of integer ``dtype`` (uint8 or uint16), rounded to nearest."""
    top = np.iinfo(dtype).max
    work = np.float32 if np.asarray(linear).dtype == np.float32 else np.float64
    return np.rint(linear_to_srgb(linear, work) * top).astype(dtype)


def to_linear(image: np.ndarray, dtype: np.dtype | type = np.float64) -> np.ndarray:
    """An image to linear light in ``dtype``: 8- or 16-bit images are sRGB-decoded,
    float images are taken as linear already (what the processing steps hand on)."""
    image = np.asarray(image)
    if image.dtype in (np.uint8, np.uint16):
        return decode(image, dtype)
    return image.astype(dtype)


def from_linear(linear: np.ndarray, dtype: np.dtype | type = np.uint8) -> np.ndarray:
    """Inverse of :func:`to_linear`: sRGB-encoded when ``dtype`` is uint8/uint16, else a float cast."""
    dtype = np.dtype(dtype)
    if dtype in (np.uint8, np.uint16):
        return encode(linear, dtype)
    return np.asarray(linear).astype(dtype)


def mean_in_linear_light(images: np.ndarray) -> np.ndarray:
    """Average ``(K, ...)`` sRGB images of one integer dtype in linear light.

    Summed one image at a time (as ``mean(axis=0)`` sums, so the same numbers):
    256 footprint banks decoded at once would take gigabytes.
    """
    total = decode(images[0])
    for image in images[1:]:
        total += decode(image)
    return encode(total / len(images), images.dtype)
