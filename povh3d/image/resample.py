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

import math
from dataclasses import replace

import numpy as np

from ..geometry.lens_array import LensArray, Panel
from .colour import decode, encode, from_linear, to_linear
from .elemental import lens_index_map
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


# -- any lens array: each pixel's own ray, read on the same physical panel ---------------------------
def resampled_array(lens_array: LensArray, ppl_out: tuple[float, float]) -> LensArray:
    """The lens array of a resample to ``ppl_out = (My, Mx)`` pixels per lens: the same lenses
    (centres, pitches, focal, turn), on the same physical panel, with pixels ``pitch / M`` wide.

    A lenticular sheet keeps its rows (``My`` is 1); a hex array keeps its pixels' shape (the
    one number ``Mx``); square and lattice arrays take ``pitch_y / My``.  The panel is the
    whole number of new pixels nearest the old one's size in mm, at least the array's extent,
    and with whole ``M`` on an upright square or lenticular array an even margin, so it keeps
    a camera bank."""
    la = lens_array
    my, mx = (float(v) for v in ppl_out)
    sx = la.pitch_x / mx
    if la.grid == "lenticular":
        sy = la.panel.pitch_y
    elif la.grid == "hex":
        sy = sx * la.panel.pitch_y / la.panel.pitch_x
    else:
        sy = la.pitch_y / my
    width_mm, height_mm = la.panel.size_mm
    w = max(1, round(width_mm / sx))
    h = la.panel.height if la.grid == "lenticular" else max(1, round(height_mm / sy))
    if la.rotation == 0.0 and la.grid != "lattice":  # an upright array lies within its panel
        array_w = la.lenses_x * la.pitch_x + (la.pitch_x / 2 if la.grid == "hex" and la.lenses_y > 1 else 0)
        w = max(w, math.ceil(array_w / sx - 1e-9))
        h = max(h, math.ceil(la.lenses_y * la.pitch_y / sy - 1e-9))
        if la.grid in ("square", "lenticular") and mx == int(mx) and (w - la.lenses_x * int(mx)) % 2:
            w += 1
        if la.grid == "square" and my == int(my) and (h - la.lenses_y * int(my)) % 2:
            h += 1
    return replace(la, panel=Panel(w, h, sx, sy))


def _taps(pos: np.ndarray, ratio: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Input pixels and weights along one axis for output pixels centred at ``pos`` (input pixel
    widths from the panel's edge; pixel ``c`` spans ``[c, c + 1]``), ``ratio`` input pixels wide:
    the overlap of each input pixel with the output one when shrinking (area), else linear
    between input centres (as ``resample_matrix``)."""
    if ratio > 1 + 1e-9:
        lo, hi = pos - ratio / 2, pos + ratio / 2
        first = np.floor(lo).astype(np.int64)
        return [(first + d, np.clip(np.minimum(hi, first + d + 1) - np.maximum(lo, first + d), 0, None))
                for d in range(math.ceil(ratio) + 1)]
    centre = pos - 0.5
    c0 = np.floor(centre).astype(np.int64)
    f = centre - c0
    return [(c0, 1 - f), (c0 + 1, f)]


def resample_panel(h3d: np.ndarray, lens_in: LensArray, lens_out: LensArray) -> np.ndarray:
    """``h3d`` (an image of ``lens_in``) as an image of ``lens_out``: the same lenses on the same
    physical panel (``resampled_array``), in linear light.

    The ray of a pixel runs through its lens centre ``c`` along ``(X - c, Y - c_y, f)``
    (docs/geometry.md): a new pixel centred at ``(X, Y)`` of lens ``c`` carries the ray of the
    old panel's point ``(X, Y)`` under the same lens.  So each new pixel is the old image over
    its own area (shrinking) or interpolated at its centre (growing), from old pixels of its
    own lens only: neighbouring lenses, which show other directions, never bleed in.  A new
    pixel none of whose taps is its lens's takes the nearest old pixel.  Hex and turned
    arrays, fractional pixels per lens; whole ones give ``resample_micro_images``.

    Returns
    -------
    (H', W', C) array of ``h3d.dtype``; pixels outside every lens are black.
    """
    pin, pout = lens_in.panel, lens_out.panel
    if h3d.shape[:2] != (pin.height, pin.width):
        raise ValueError(f"the image is {h3d.shape[1]}x{h3d.shape[0]}, its lens array's panel "
                         f"{pin.width}x{pin.height}")
    lin = decode(h3d)
    in_map, out_map = lens_index_map(lens_in), lens_index_map(lens_out)
    inside = out_map >= 0
    x, y = pout.pixel_centres()
    rows, cols = np.nonzero(inside)
    lens = out_map[inside]
    tx = _taps(x[cols] / pin.pitch_x + pin.width / 2, pout.pitch_x / pin.pitch_x)
    ty = _taps(pin.height / 2 - y[rows] / pin.pitch_y, pout.pitch_y / pin.pitch_y)
    acc = np.zeros((lens.size, lin.shape[2]))
    total = np.zeros(lens.size)
    for r, wr in ty:
        for c, wc in tx:
            ok = (r >= 0) & (r < pin.height) & (c >= 0) & (c < pin.width)
            rc, cc = np.clip(r, 0, pin.height - 1), np.clip(c, 0, pin.width - 1)
            w = np.where(ok & (in_map[rc, cc] == lens), wr * wc, 0.0)
            acc += w[:, None] * lin[rc, cc]
            total += w
    near_r = np.clip(np.floor(pin.height / 2 - y[rows] / pin.pitch_y).astype(np.int64), 0, pin.height - 1)
    near_c = np.clip(np.floor(x[cols] / pin.pitch_x + pin.width / 2).astype(np.int64), 0, pin.width - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        value = np.where((total > 1e-12)[:, None], acc / total[:, None], lin[near_r, near_c])
    out = np.zeros((pout.height, pout.width, h3d.shape[2]), h3d.dtype)
    out[inside] = encode(value, h3d.dtype)
    return out
