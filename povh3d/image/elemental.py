"""Per-lens resampling of elemental images (hex grids, fractional pixels per lens).

With whole pixels per lens on a square or lenticular grid every lens has the
same pixel offsets and views are a reshape (``interleave.extract``).  Otherwise
each lens sits at its own sub-pixel phase, so a view direction ``(u, v)`` falls
between pixels, differently for every lens.  These functions sample an image
at arbitrary panel points, bilinearly and in linear light (docs/geometry.md: filters
that mix pixels work in linear light), from the pixels of one given lens only,
so that neighbouring lenses (other views entirely) never bleed in.
"""

from __future__ import annotations

import numpy as np

from .colour import decode, encode, linear_to_srgb, srgb_to_linear
from ..geometry.lens_array import LensArray
from ..geometry.rays import cell_contains, pixel_rays


def lens_index_map(lens_array: LensArray) -> np.ndarray:
    """The lens of every panel pixel, ``i * Lx + j`` (docs/geometry.md cells), -1 outside every lens.

    Returns
    -------
    (H, W) int64
    """
    centres, _, inside = pixel_rays(lens_array)
    la = lens_array
    if la.grid == "lattice":  # indices from the lattice coordinates of the lens centre
        from ..geometry.lattice import lattice_coordinates

        s, t = lattice_coordinates(*np.array(la.basis), *np.nan_to_num(np.moveaxis(centres, -1, 0)))
        return np.where(inside, np.rint(la.lenses_y / 2 - 0.5 - t).astype(np.int64) * la.lenses_x
                        + np.rint(s + la.lenses_x / 2 - 0.5).astype(np.int64), -1)
    i = np.rint(la.lenses_y / 2 - 0.5 - np.nan_to_num(centres[..., 1]) / la.pitch_y).astype(np.int64)
    if la.grid == "lenticular":
        _, Y = la.panel.pixel_centres()
        i = np.broadcast_to(np.arange(la.panel.height)[:, None], i.shape)
    shift = (i % 2) * 0.5 if la.grid == "hex" else 0.0
    j = np.rint(np.nan_to_num(centres[..., 0]) / la.pitch_x + la.lenses_x / 2 - 0.5 - shift).astype(np.int64)
    return np.where(inside, i * la.lenses_x + j, -1)


def sample_in_lens(image: np.ndarray, lens_array: LensArray, points: np.ndarray, lens: np.ndarray,
                   lens_map: np.ndarray | None = None) -> np.ndarray:
    """Bilinear samples of ``image`` at panel ``points``, from pixels of ``lens`` only.

    Parameters
    ----------
    image : (H, W, C) uint8 or uint16, sRGB-encoded
    lens_array : LensArray                  its panel gives the pixel grid
    points : (..., 2) float, mm             panel positions ``(x, y)``
    lens : (...) int                        the lens each point must be read from
    lens_map : (H, W) int, optional         ``lens_index_map(lens_array)``

    Returns
    -------
    (..., C) array of ``image.dtype``.  A point none of whose four neighbours
    belongs to its lens takes the nearest pixel (hex cell corners).
    """
    panel = lens_array.panel
    H, W = panel.height, panel.width
    lens_map = lens_index_map(lens_array) if lens_map is None else lens_map
    top = np.iinfo(image.dtype).max
    lin = srgb_to_linear(image / top)
    col = points[..., 0] / panel.pitch_x + W / 2 - 0.5
    row = H / 2 - 0.5 - points[..., 1] / panel.pitch_y
    c0, r0 = np.floor(col).astype(np.int64), np.floor(row).astype(np.int64)
    fc, fr = col - c0, row - r0
    acc = np.zeros(points.shape[:-1] + (image.shape[2],))
    total = np.zeros(points.shape[:-1])
    for dr, dc, w in ((0, 0, (1 - fr) * (1 - fc)), (0, 1, (1 - fr) * fc),
                      (1, 0, fr * (1 - fc)), (1, 1, fr * fc)):
        r, c = r0 + dr, c0 + dc
        valid = (r >= 0) & (r < H) & (c >= 0) & (c < W)
        rc, cc = np.clip(r, 0, H - 1), np.clip(c, 0, W - 1)
        w = np.where(valid & (lens_map[rc, cc] == lens), w, 0.0)
        acc += w[..., None] * lin[rc, cc]
        total += w
    nearest = lin[np.clip(np.rint(row).astype(np.int64), 0, H - 1), np.clip(np.rint(col).astype(np.int64), 0, W - 1)]
    with np.errstate(invalid="ignore", divide="ignore"):
        value = np.where((total > 1e-12)[..., None], acc / total[..., None], nearest)
    return np.rint(linear_to_srgb(value) * top).astype(image.dtype)


def view_grid(lens_array: LensArray) -> tuple[int, int]:
    """Views ``(Ny, Nx)`` pulled from a resampled array: whole pixels per lens, rounded."""
    nx = max(1, round(lens_array.ppl_x))
    ny = 1 if lens_array.unidirectional else max(1, round(lens_array.pitch_x / lens_array.panel.pitch_y))
    return ny, nx


def view_offsets(lens_array: LensArray, views: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The offsets ``extract_views`` reads each lens at: ``u`` (Nx,) and ``v`` (Ny,) mm, the
    multi-ortho offsets of ``views = (Ny, Nx)`` (lenticular: ``v = 0``)."""
    ny, nx = views
    u = (np.arange(nx) + 0.5 - nx / 2) * lens_array.panel.pitch_x
    v = (ny / 2 - np.arange(ny) - 0.5) * lens_array.panel.pitch_y
    return u, (np.zeros(1) if lens_array.grid == "lenticular" else v)


def view_points(lens_array: LensArray, views: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Where each view pixel reads the panel: ``(Ny, Nx, Ly, Lx, 2)`` mm and the lens ``(Ny, Nx, Ly, Lx)``.

    View ``(l, k)`` pixel ``(i, j)`` is the point ``c_ij + (u_k, v_l)`` with
    ``u_k = (k + 0.5 - Nx/2) s``, ``v_l = (Ny/2 - l - 0.5) s`` (the multi-ortho offsets),
    read from lens ``(j, i)``'s own pixels; ``views`` default ``view_grid(lens_array)``."""
    ny, nx = views or view_grid(lens_array)
    u, v = view_offsets(lens_array, (ny, nx))
    centres = lens_array.lens_centres()                     # (Ly, Lx, 2)
    ly, lx = centres.shape[:2]
    lens = np.arange(ly * lx).reshape(ly, lx)
    pts = np.empty((ny, nx, ly, lx, 2))
    pts[..., 0] = centres[None, None, :, :, 0] + u[None, :, None, None]
    pts[..., 1] = centres[None, None, :, :, 1] + v[:, None, None, None]
    return pts, np.broadcast_to(lens, pts.shape[:-1])


def extract_views(h3d: np.ndarray, lens_array: LensArray, views: tuple[int, int] | None = None) -> np.ndarray:
    """Viewpoint images of any array: each lens resampled at the view offsets (``view_points``).

    With whole PPL on a square grid the samples land on pixel centres and this equals
    ``interleave.extract``.

    Parameters
    ----------
    h3d : (H, W, C) array
    views : (Ny, Nx), optional       default ``view_grid(lens_array)``

    Returns
    -------
    (Ny, Nx, Ly, Lx, C) array.  Hex cells are narrower than the square of view
    offsets at their corners: those views read the nearest pixel of the lens.
    """
    return sample_in_lens(h3d, lens_array, *view_points(lens_array, views))


def nearest_in_lens(labels: np.ndarray, lens_array: LensArray, points: np.ndarray, lens: np.ndarray,
                    lens_map: np.ndarray | None = None) -> np.ndarray:
    """The value of the pixel of ``lens`` nearest each panel point: what ``sample_in_lens`` weighs
    most, for values that must not be blended (object ids).

    Parameters
    ----------
    labels : (H, W) array                   one value per panel pixel
    points : (..., 2) float, mm
    lens : (...) int                        the lens each point must be read from

    Returns
    -------
    (...) array of ``labels.dtype``.  A point none of whose four neighbours belongs to its
    lens takes the nearest pixel, as ``sample_in_lens`` does.
    """
    panel = lens_array.panel
    H, W = panel.height, panel.width
    lens_map = lens_index_map(lens_array) if lens_map is None else lens_map
    col = points[..., 0] / panel.pitch_x + W / 2 - 0.5
    row = H / 2 - 0.5 - points[..., 1] / panel.pitch_y
    c0, r0 = np.floor(col).astype(np.int64), np.floor(row).astype(np.int64)
    fc, fr = col - c0, row - r0
    # A point halfway between two pixels (whole PPL of a hex array's views) weighs both alike: the one
    # nearer the lens centre wins, so views left and right of it pick alike and never a pixel on the
    # cell's border, whose ray the neighbouring lens may own.
    centre = lens_array.lens_centres().reshape(-1, 2)[np.clip(lens, 0, None)]
    best = np.full(points.shape[:-1], -np.inf)
    out = labels[np.clip(np.rint(row).astype(np.int64), 0, H - 1), np.clip(np.rint(col).astype(np.int64), 0, W - 1)]
    for dr, dc, w in ((0, 0, (1 - fr) * (1 - fc)), (0, 1, (1 - fr) * fc),
                      (1, 0, fr * (1 - fc)), (1, 1, fr * fc)):
        r, c = r0 + dr, c0 + dc
        rc, cc = np.clip(r, 0, H - 1), np.clip(c, 0, W - 1)
        off = np.hypot((c + 0.5 - W / 2) * panel.pitch_x - centre[..., 0],
                       (H / 2 - r - 0.5) * panel.pitch_y - centre[..., 1]) / panel.pitch_x
        w = w - 1e-6 * off
        own = (r >= 0) & (r < H) & (c >= 0) & (c < W) & (lens_map[rc, cc] == lens) & (w > best)
        out = np.where(own, labels[rc, cc], out)
        best = np.where(own, w, best)
    return out


def sample_turned_bank(capture: np.ndarray, lens_array: LensArray, pitch: tuple[float, float],
                       phase: tuple[float, float], gain: float, camera: tuple[float, float],
                       supersample: int = 1) -> np.ndarray:
    """The display image from a capture sampled on a lens-aligned grid (single-stage, any grid).

    Every capture lens ``c'`` is sampled at offsets ``w = ((k + phase_x) sx, (m + phase_y) sy)``,
    the same for every lens.  The display ray at offset ``u`` from lens ``c`` is the capture
    ray of sample ``w = -u`` of lens ``c' = c - u D / f`` (single_stage module doc), i.e. the
    capture pixel at ``c - u gain`` with ``gain = 1 + D / f``.  Display offsets between
    samples are interpolated bilinearly in direction, in linear light, from samples of
    the same lens only (a sample outside the cell belongs to another view entirely);
    where none of the four is in the cell, the nearest sample in it is taken.

    Parameters
    ----------
    capture : (Hc, Wc, C) uint8 or uint16, sRGB-encoded    the camera image
    lens_array : LensArray                      the display array
    pitch : (sx, sy), mm                        capture pixel pitch (lens pitch / samples per lens)
    phase : (phase_x, phase_y)                  0 or 1/2: where samples sit relative to lens centres
    gain : float                                ``1 + D / f``
    camera : (x0, y0), mm                       centre of the capture camera's image
    supersample : int                           ``k``: each display pixel is the mean, in linear
                                                light, of ``k x k`` sub-pixel-centred directions
                                                (``k`` across a lenticular pixel), each one
                                                interpolated from the samples of the pixel's own lens

    Returns
    -------
    (H, W, C) array of ``capture.dtype``; pixels outside every lens are black.
    """

    la = lens_array
    centres, _, inside = pixel_rays(la)
    # The capture grid is aligned to the lattice: work in its own frame (turned back).
    X, Y = la.to_lattice(*np.meshgrid(*la.panel.pixel_centres()))
    cx, cy = la.to_lattice(centres[inside, 0], centres[inside, 1])
    lin = decode(capture)
    lent = la.grid == "lenticular"
    k = supersample
    d = (np.arange(k) + 0.5) / k - 0.5  # sub-pixel centres, in pixels
    total = np.zeros((cx.size, capture.shape[2]))
    for du in d * la.panel.pitch_x:
        for dv in ((0.0,) if lent else d * la.panel.pitch_y):
            u = X[inside] - cx + du
            v = np.zeros_like(u) if lent else Y[inside] - cy + dv
            total += _turned_samples(lin, la, pitch, phase, gain, camera, cx, cy, u, v)
    value = total / (k if lent else k * k)
    out = np.zeros((la.panel.height, la.panel.width, capture.shape[2]), capture.dtype)
    out[inside] = encode(value, capture.dtype)
    return out


def _turned_samples(lin: np.ndarray, la: LensArray, pitch: tuple[float, float], phase: tuple[float, float],
                    gain: float, camera: tuple[float, float], cx: np.ndarray, cy: np.ndarray,
                    u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Linear values ``(P, C)`` at offsets ``(u, v)`` from lens centres ``(cx, cy)`` (``sample_turned_bank``)."""
    hc, wc = lin.shape[:2]
    sx, sy = pitch
    a, b = u / sx - phase[0], v / sy - phase[1]
    k0, m0 = np.floor(a), np.floor(b)
    fa, fb = a - k0, b - m0
    acc = np.zeros((u.size, lin.shape[2]))
    total = np.zeros(u.size)
    best = np.full(u.size, np.inf)
    nearest = np.zeros((u.size, lin.shape[2]))
    for dk in (-1, 0, 1, 2):
        for dm in ((0,) if la.grid == "lenticular" else (-1, 0, 1, 2)):
            ou, ov = (k0 + dk + phase[0]) * sx, (m0 + dm + phase[1]) * sy
            if la.grid == "lenticular":
                ov = np.zeros_like(ou)
            valid = cell_contains(la.grid, la.pitch_x, la.pitch_y, ou, ov)
            col = (cx - ou * gain - camera[0]) / sx + wc / 2 - 0.5
            row = hc / 2 - 0.5 - (cy - ov * gain - camera[1]) / sy
            ci, ri = np.rint(col).astype(np.int64), np.rint(row).astype(np.int64)
            # The capture grid is built lens-aligned: every valid sample is a pixel centre.
            # Along a slanted lenticule the display pixel's point has no capture row of its
            # own: the nearest row is taken, within half a row along the lenticule.
            row_ok = la.grid == "lenticular" and la.rotation != 0.0
            assert np.all(~valid | ((np.abs(col - ci) < 1e-6) & (row_ok | (np.abs(row - ri) < 1e-6)))), \
                "capture grid misaligned"
            assert np.all(~valid | ((ci >= 0) & (ci < wc) & (ri >= 0) & (ri < hc))), "capture too small"
            value = lin[np.clip(ri, 0, hc - 1), np.clip(ci, 0, wc - 1)]
            if dk in (0, 1) and dm in (0, 1):
                w = (fa if dk else 1 - fa) * ((fb if dm else 1 - fb) if la.grid != "lenticular" else 1.0)
                w = np.where(valid, w, 0.0)
                acc += w[:, None] * value
                total += w
            d = np.where(valid, (ou - u) ** 2 + (ov - v) ** 2, np.inf)
            closer = d < best
            best = np.where(closer, d, best)
            nearest = np.where(closer[:, None], value, nearest)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where((total > 1e-12)[:, None], acc / total[:, None], nearest)
