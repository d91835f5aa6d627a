"""Resampling H3D images (thesis appendix C), in linear light.

A 2D resize across a whole H3D image would mix pixels of neighbouring
micro-images and destroy the light field; appendix C resizes every micro-image
on its own (Fig. C.1), e.g. a camera's 30 pixels per lens to a display's 10.
``trade`` is Fig. C.2's other direction: fewer pixels per lens, more lenses
(6 PPL -> 3 lenses of 2 PPL): views are merged in groups (box filter over
angle) and every view image is upsampled across lenses (linear interpolation).
Literally, Fig. C.2 re-reads the same pixels as smaller virtual lenses; on its
own that only changes the lens pitch and focal, which the sidecar records.

Everything that mixes pixels goes through ``to_linear`` / ``from_linear``
(``image.colour``: filtering works in linear light; images are sRGB-encoded).
"""

from __future__ import annotations

import numpy as np

from .colour import from_linear, to_linear
from .interleave import extract, interleave


def resample_matrix(n_in: int, n_out: int) -> np.ndarray:
    """``(n_out, n_in)`` weights resizing ``n_in`` samples to ``n_out`` (rows sum to 1).

    Shrinking averages the input over each output pixel's footprint (area);
    growing interpolates linearly between input centres, clamped at the ends.
    Both keep the first and last pixel edges aligned.
    """
    if n_in < 1 or n_out < 1:
        raise ValueError(f"sizes must be at least 1, got {n_in} -> {n_out}")
    if n_out <= n_in:
        edges = np.arange(n_out + 1) * (n_in / n_out)
        lo, hi = edges[:-1, None], edges[1:, None]
        k = np.arange(n_in)[None, :]
        overlap = np.clip(np.minimum(hi, k + 1) - np.maximum(lo, k), 0, None)
        return overlap / overlap.sum(axis=1, keepdims=True)
    centre = (np.arange(n_out) + 0.5) * (n_in / n_out) - 0.5
    centre = np.clip(centre, 0, n_in - 1)
    left = np.floor(centre).astype(int)
    right = np.minimum(left + 1, n_in - 1)
    t = centre - left
    m = np.zeros((n_out, n_in))
    np.add.at(m, (np.arange(n_out), left), 1 - t)
    np.add.at(m, (np.arange(n_out), right), t)
    return m


def resample_micro_images(h3d: np.ndarray, ppl_in: tuple[int, int], ppl_out: tuple[int, int]) -> np.ndarray:
    """Resize every micro-image from ``ppl_in`` to ``ppl_out`` pixels, in linear light.

    Parameters
    ----------
    h3d : (Ly*Ny, Lx*Nx, C) uint8 or uint16
    ppl_in, ppl_out : (Ny, Nx) and (My, Mx) whole pixels per lens

    Returns
    -------
    (Ly*My, Lx*Mx, C) array of the same dtype.
    """
    views = extract(h3d, ppl_in)  # (Ny, Nx, Ly, Lx, C): micro-image pixel (l, k) of every lens
    ry = resample_matrix(ppl_in[0], ppl_out[0]).astype(np.float32)
    rx = resample_matrix(ppl_in[1], ppl_out[1]).astype(np.float32)
    lin = to_linear(views, np.float32)
    out = np.einsum("ab,de,bexyc->adxyc", ry, rx, lin, optimize=True)
    return interleave(from_linear(out, h3d.dtype))


def trade_views_for_lenses(h3d: np.ndarray, ppl_in: tuple[int, int], ppl_out: tuple[int, int]) -> np.ndarray:
    """Fewer pixels per lens, more lenses (Fig. C.2): the image keeps its size.

    ``ppl_in`` must be a whole multiple of ``ppl_out`` along each axis; the factor
    ``F = ppl_in / ppl_out`` merges every F neighbouring views and makes F lenses
    of each one.  Replay it with lenses 1/F as wide and a focal 1/F as long (the
    view angles stay the same).

    Returns
    -------
    (Ly*Ny, Lx*Nx, C) array of the same dtype and size.
    """
    (ny, nx), (my, mx) = ppl_in, ppl_out
    if ny % my or nx % mx:
        raise ValueError(f"pixels per lens {nx}x{ny} are not a whole multiple of {mx}x{my}")
    fy, fx = ny // my, nx // mx
    views = to_linear(extract(h3d, ppl_in), np.float32)  # (Ny, Nx, Ly, Lx, C)
    _, _, ly, lx, c = views.shape
    merged = views.reshape(my, fy, mx, fx, ly, lx, c).mean(axis=(1, 3))
    sy = resample_matrix(ly, ly * fy).astype(np.float32)
    sx = resample_matrix(lx, lx * fx).astype(np.float32)
    grown = np.einsum("ab,de,uvbec->uvadc", sy, sx, merged, optimize=True)
    return interleave(from_linear(grown, h3d.dtype))
