"""The first guess of a lens lattice in a white image (steps 1 and 2 of ``lattice``):
the basis from the Fourier peaks of a central crop, the origin from the crop folded
onto one lattice cell; and the grey image both are found in."""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from ..errors import InputError, param


MIN_PITCH_PX = 3.0
FFT_CROP = 1024
WORK_PX = 400_000  # lens-window pixels measured per pass


# -- 1. lattice basis from the Fourier peaks ------------------------------------
def _crop(img: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    h, w = img.shape
    y0, x0 = (h - size) // 2, (w - size) // 2
    return img[y0:y0 + size, x0:x0 + size], np.array([x0, y0], dtype=np.float64)


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


def _refine_peak(mag: np.ndarray, iy: int | np.integer, ix: int | np.integer) -> tuple[float, float]:
    """Sub-bin peak position by a parabola through the log magnitudes (exact for a Gaussian)."""
    def vertex(a: float, b: float, c: float) -> float:
        a, b, c = np.log(max(a, 1e-30)), np.log(max(b, 1e-30)), np.log(max(c, 1e-30))
        den = a - 2 * b + c
        return 0.0 if den >= 0 else float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    n = mag.shape[0]
    dx = vertex(mag[iy, (ix - 1) % n], mag[iy, ix], mag[iy, (ix + 1) % n])
    dy = vertex(mag[(iy - 1) % n, ix], mag[iy, ix], mag[(iy + 1) % n, ix])
    return ix + dx, iy + dy


def _reduce(b1: np.ndarray, b2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lagrange-Gauss reduction: the two shortest independent lattice vectors."""
    for _ in range(64):
        if b2 @ b2 < b1 @ b1:
            b1, b2 = b2, b1
        mu = round(float(b1 @ b2) / float(b1 @ b1))
        if mu == 0:
            break
        b2 = b2 - mu * b1
    return b1, b2


def _canonical(b1: np.ndarray, b2: np.ndarray, lattice: str) -> np.ndarray:
    """Rows ``a1`` (nearest image +x) and ``a2`` (``a1`` turned 90/60 deg toward +y)."""
    cands = [m * b1 + n * b2 for m in (-1, 0, 1) for n in (-1, 0, 1) if (m, n) != (0, 0)]
    short = min(np.linalg.norm(v) for v in cands)
    cands = [v for v in cands if np.linalg.norm(v) < 1.2 * short]
    a1 = min(cands, key=lambda v: abs(math.atan2(v[1], v[0])))
    turn = math.radians(90 if lattice == "square" else 60)
    ang1 = math.atan2(a1[1], a1[0])

    def miss(v):
        d = math.atan2(v[1], v[0]) - ang1 - turn
        return abs((d + math.pi) % (2 * math.pi) - math.pi)
    a2 = min(cands, key=miss)
    return np.stack([a1, a2])


def fft_basis(img: np.ndarray, lattice: str | None, name: str) -> tuple[str, np.ndarray, float]:
    h, w = img.shape
    size = min(h, w, FFT_CROP)
    crop, _ = _crop(img, size)
    if float(crop.std()) < 1e-3 * max(float(np.abs(crop).mean()), 1e-6):
        raise InputError(f"{name} is uniform and shows no lens lattice; calibrate with a sharp image of a "
                         "white background taken through the lens array")
    win = np.hanning(size)
    data = (crop - crop.mean()) * win[:, None] * win[None, :]
    mag = np.fft.fftshift(np.abs(np.fft.fft2(data)))
    k = np.arange(size) - size // 2
    kr = np.hypot(k[None, :], k[:, None])
    # Below 4 cycles per crop: vignetting, and too few lenses to measure anything.
    mag_hp = np.where(kr >= 4, mag, 0.0)
    floor = float(np.median(mag_hp[kr >= 4])) + 1e-30
    peaks = (mag_hp == ndimage.maximum_filter(mag_hp, size=3, mode="wrap")) & (mag_hp > 0)
    top = float(mag_hp[peaks].max()) if peaks.any() else 0.0
    snr = top / floor
    if snr < 20:
        raise InputError(f"{name} shows no lens lattice (strongest periodic peak only {snr:.1f}x the noise); "
                         "calibrate with a sharp image of a white background taken through the lens array")
    strong = peaks & (mag_hp >= max(0.12 * top, 20 * floor))
    iy, ix = np.nonzero(strong)
    pts = np.array([_refine_peak(mag, y, x) for y, x in zip(iy, ix)]) - size // 2  # (kx, ky) bins
    order = np.argsort(np.hypot(pts[:, 0], pts[:, 1]))
    pts = pts[order] / size  # cycles per pixel
    g1 = pts[0]
    rest = [g for g in pts[1:] if abs(g1[0] * g[1] - g1[1] * g[0]) > 0.5 * np.linalg.norm(g1) * np.linalg.norm(g)]
    if not rest:
        raise InputError(f"{name} shows stripes in one direction only; a square or hex lens array "
                         "is periodic in two (lenticular sheets are not calibrated here)")
    g2 = rest[0]
    real = np.linalg.inv(np.stack([g1, g2]))  # columns: real basis (g_i . a_k = delta_ik)
    b1, b2 = _reduce(real[:, 0], real[:, 1])
    cosang = abs(float(b1 @ b2) / (np.linalg.norm(b1) * np.linalg.norm(b2)))
    ratio = np.linalg.norm(b2) / np.linalg.norm(b1)
    found = "square" if cosang < 0.2 else "hex" if 0.35 < cosang < 0.65 else None
    if found is None or ratio > 1.1:
        raise InputError(f"{name}: the lens lattice is neither square nor hexagonal (angle "
                         f"{math.degrees(math.acos(cosang)):.1f} deg, side ratio {ratio:.3f}); check the image")
    if lattice is not None and lattice != found:
        raise InputError(f"{name} shows a {found} lens lattice, not {lattice}; drop {param('lattice')} or check the image")
    pitch = float(np.linalg.norm(b1))
    if pitch < MIN_PITCH_PX:
        raise InputError(f"{name}: the lens pitch looks like {pitch:.2f} px; at least {MIN_PITCH_PX:g} px are needed")
    return found, _canonical(b1, b2, found), snr


# -- 2. offset: centre of symmetry of the folded cell ------------------------------
def fold_origin(img: np.ndarray, basis: np.ndarray, bins: int = 32) -> np.ndarray:
    h, w = img.shape
    size = min(h, w, 512)
    crop, corner = _crop(img, size)
    yy, xx = np.mgrid[0:size, 0:size]
    pts = np.stack([xx.ravel(), yy.ravel()], axis=1) + corner
    ref = corner + size / 2
    q = (pts - ref) @ np.linalg.inv(basis)  # lattice coordinates
    b = np.floor((q - np.floor(q)) * bins).astype(np.intp) % bins
    flat = b[:, 1] * bins + b[:, 0]
    num = np.bincount(flat, crop.ravel().astype(np.float64), bins * bins)
    cnt = np.bincount(flat, minlength=bins * bins)
    cell = np.where(cnt > 0, num / np.maximum(cnt, 1), np.nan).reshape(bins, bins)  # [n-bin, m-bin]
    cell = np.where(np.isnan(cell), np.nanmean(cell), cell)
    cell = cell - cell.mean()
    conv = np.real(np.fft.ifft2(np.fft.fft2(cell) ** 2))
    py, px = np.unravel_index(int(np.argmax(conv)), conv.shape)
    fx, fy = _refine_peak(np.exp(conv / (np.abs(conv).max() + 1e-30) * 8), py, px)
    # Bin b holds fraction (b + 1/2)/bins, so the symmetry centre c has 2 c bins - 1 = peak.
    base = (np.array([fx, fy]) + 1) / (2 * bins)
    smooth = ndimage.uniform_filter(cell, size=max(3, bins // 8), mode="wrap")
    cands = [base + np.array([dm, dn]) for dm in (0, 0.5) for dn in (0, 0.5)]
    bright = [ndimage.map_coordinates(smooth, [[(c[1] * bins - 0.5) % bins], [(c[0] * bins - 0.5) % bins]],
                                      order=1, mode="grid-wrap")[0] for c in cands]
    best = cands[int(np.argmax(bright))]
    return ref + best @ basis


# -- 3. per-lens centres against a self-made, point-symmetric template -------------------
