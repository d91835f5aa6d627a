"""sRGB transfer functions: filtering that mixes pixels works in linear light (CONVENTIONS)."""

from __future__ import annotations

import numpy as np


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in ``[0, 1]`` to linear light (IEC 61966-2-1), float64."""
    v = np.asarray(values, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(values: np.ndarray) -> np.ndarray:
    """Linear light in ``[0, 1]`` to sRGB-encoded values, float64 (clipped to ``[0, 1]``)."""
    v = np.clip(np.asarray(values, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * v ** (1 / 2.4) - 0.055)


def decode(image: np.ndarray) -> np.ndarray:
    """An 8- or 16-bit sRGB image to linear light, float64."""
    return srgb_to_linear(image / float(np.iinfo(image.dtype).max))


def encode(linear: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """Linear light to an sRGB image of integer ``dtype``, rounded to nearest."""
    top = np.iinfo(dtype).max
    return np.rint(linear_to_srgb(linear) * top).astype(dtype)


def mean_in_linear_light(images: np.ndarray) -> np.ndarray:
    """Average ``(K, ...)`` sRGB images of one integer dtype in linear light."""
    return encode(decode(images).mean(axis=0), images.dtype)
