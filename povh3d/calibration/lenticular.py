"""Calibrate a slanted lenticular sheet from a white image: pitch, slant and phase.

The white image of a lenticular sheet is periodic across the lenticules only,
``I(p) = V(p) g(n . (q(p) - c) - phase)``: ``g`` the lenticule's response (bright
on its axis, dark at its borders) with period ``pitch``, ``n`` the unit normal of
the lenticules, ``q`` the undistorted position (Brown, ``distortion``), ``c`` the
image centre and ``V`` any slowly varying vignetting.  The method:

1. **Wave vector** from the strongest Fourier peak of a central crop (Hann window,
   sub-bin log-parabola), the fundamental checked against a peak at half its
   frequency (a sheet whose second harmonic dominates).
2. **Local phase.** The image is demodulated at that wave vector over tiles a few
   periods wide (a symmetric window): each tile's complex amplitude has the phase
   of the pattern at the tile's centre, whatever the vignetting's level; the
   window suppresses the harmonics and the mirror frequency.
3. **Fit.**  One least-squares fit of the wave vector, the phase and the Brown
   ``k1`` to every tile's phase (weighted by its amplitude), with outlier
   rejection; steps 2 and 3 once more at the fitted wave vector.

Thousands of periods average the noise: pitch, slant and phase come out far
below 0.01 %, 0.01 deg and 0.02 px on the synthetic images of the tests.

Conventions (docs/geometry.md, "Rotated lattices"): the slant is the angle the
lenticules lean from vertical, counter-clockwise as displayed (moving up, a
lenticule moves left); the phase is the signed distance, across the
lenticules, from the image centre ``((W-1)/2, (H-1)/2)`` to the nearest
lenticule axis, in ``[-pitch/2, pitch/2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize

from ..errors import InputError
from .basis import grey
from .distortion import Brown

TILE_PERIODS = 4.0      # tile width in periods: wide enough to suppress the harmonics
MIN_CONTRAST = 8.0      # peak over the median spectrum below which there is no sheet


@dataclass(frozen=True)
class LenticularFit:
    """A fitted lenticular sheet in image pixels (module doc, Conventions)."""

    pitch_px: float
    slant_deg: float
    phase_px: float
    k1: float
    size: tuple[int, int]
    residual_rad: float
    tiles: int

    def looking_glass(self, dpi: float) -> dict[str, Any]:
        """The Looking Glass fields of this sheet over a panel imaged 1:1 (``display.mappings.slanted.looking_glass``).

        Their lenticule coordinate ``a = (x cos t + y sin t) / pitch - center`` (``x``
        from the left, ``y`` up, in pixels) has ``slope = 1 / tan t`` and ``pitch`` in
        lenticules per inch across them.  Their shader reads ``a`` of subpixel ``c`` at
        ``x = col + 1/2 + c/3``, half a pixel right of the subpixel's left edge, and the
        slanted mapping takes that value as the phase of the left edge (van Berkel's
        ``floor``: ``display.mappings.slanted``); so ``center`` is set for ``a`` to be ``0.5``
        modulo 1 half a pixel right of every lenticule axis.  Then ``map --calibration``
        and ``render --method subpixel --calibration`` both address the measured sheet.
        """
        w, h = self.size
        t = math.radians(self.slant_deg)
        centre = (self.phase_px + math.cos(t) * (w + 1) / 2 + math.sin(t) * h / 2) / self.pitch_px - 0.5
        return {"pitch": dpi / self.pitch_px, "slope": 1.0 / math.tan(t) if t else math.inf,
                "center": centre % 1.0, "invView": 0, "DPI": dpi, "screenW": w, "screenH": h}

    def as_record(self, dpi: float | None = None) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": "lenticular", "pitch_px": self.pitch_px, "slant_deg": self.slant_deg,
                               "phase_px": self.phase_px, "k1": self.k1, "image_size": list(self.size),
                               "residual_rad": self.residual_rad, "tiles": self.tiles}
        if dpi is not None and self.slant_deg != 0:
            out.update(self.looking_glass(dpi))
        return out


def _peak(img: np.ndarray) -> tuple[np.ndarray, float]:
    """Wave vector ``(kx, ky)`` rad/px of the strongest periodic component, and its contrast."""
    h, w = img.shape
    n = 2 ** int(math.floor(math.log2(min(h, w, 1024))))
    y0, x0 = (h - n) // 2, (w - n) // 2
    crop = img[y0:y0 + n, x0:x0 + n].astype(np.float64)
    crop = (crop - crop.mean()) * np.outer(np.hanning(n), np.hanning(n))
    mag = np.abs(np.fft.fft2(crop))
    f = np.fft.fftfreq(n)
    fx, fy = np.meshgrid(f, f)
    radius = np.hypot(fx, fy)
    mag[(radius < 1.5 / n * 4) | (radius > 1 / 3.0) | (fx < 0) | ((fx == 0) & (fy < 0))] = 0
    iy, ix = np.unravel_index(int(mag.argmax()), mag.shape)
    floor = np.median(mag[mag > 0]) if (mag > 0).any() else 0.0
    if not mag[iy, ix] > 1e-9 * max(1.0, float(np.abs(crop).sum())):  # a flat image
        return np.zeros(2), 0.0
    contrast = float(mag[iy, ix] / max(floor, 1e-30))

    def vertex(a: float, b: float, c: float) -> float:
        a, b, c = (math.log(max(v, 1e-30)) for v in (a, b, c))
        den = a - 2 * b + c
        return 0.0 if den >= 0 else float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    dx = vertex(mag[iy, (ix - 1) % n], mag[iy, ix], mag[iy, (ix + 1) % n])
    dy = vertex(mag[(iy - 1) % n, ix], mag[iy, ix], mag[(iy + 1) % n, ix])
    k = 2 * math.pi * np.array([f[ix] + dx / n, f[iy] + dy / n])
    # A sheet whose second harmonic is the stronger: a peak at half the frequency.
    hx, hy = int(round((f[ix] + dx / n) / 2 * n)) % n, int(round((f[iy] + dy / n) / 2 * n)) % n
    if mag[hy, hx] > 0.3 * mag[iy, ix]:
        k = k / 2
    return k, contrast


def _tile_phases(img: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Demodulate at ``k`` over tiles: tile centres ``(n, 2)`` px, phases (rad), amplitudes."""
    h, w = img.shape
    period = 2 * math.pi / float(np.linalg.norm(k))
    size = max(8, int(round(TILE_PERIODS * period)))
    size += size % 2  # even tile: its centre is a pixel corner, its window symmetric about it
    win = np.outer(np.hanning(size + 2)[1:-1], np.hanning(size + 2)[1:-1])
    ys, xs = np.mgrid[0:size, 0:size].astype(np.float64)
    pts, phases, amps = [], [], []
    step = size // 2
    for y0 in range(0, h - size + 1, step):
        for x0 in range(0, w - size + 1, step):
            tile = img[y0:y0 + size, x0:x0 + size].astype(np.float64)
            tc = np.array([x0 + (size - 1) / 2, y0 + (size - 1) / 2])
            carrier = np.exp(-1j * (k[0] * (xs + x0 - tc[0]) + k[1] * (ys + y0 - tc[1])))
            a = np.sum(win * (tile - np.sum(win * tile) / np.sum(win)) * carrier)
            pts.append(tc)
            phases.append(np.angle(a))  # = k . (tc - c) + psi: the pattern's phase at the tile centre
            amps.append(np.abs(a))
    return np.array(pts), np.array(phases), np.array(amps)


def _fit(pts: np.ndarray, phases: np.ndarray, amps: np.ndarray, k0: np.ndarray, size: tuple[int, int],
         distortion: bool) -> tuple[np.ndarray, float, float, np.ndarray]:
    """Least-squares ``k``, phase ``psi`` and ``k1`` to the tile phases; residuals (rad)."""
    w, h = size
    centre = np.array([(w - 1) / 2, (h - 1) / 2])
    weight = np.sqrt(amps / amps.max())

    def model(p: np.ndarray, where: np.ndarray) -> np.ndarray:
        k1 = p[3] if distortion else 0.0
        q = where if k1 == 0 else Brown.for_image(w, h, k1=k1).undistort(where)
        return (q - centre) @ p[:2] + p[2]

    def resid(p: np.ndarray, keep: np.ndarray) -> np.ndarray:
        d = phases[keep] - model(p, pts[keep])
        return np.angle(np.exp(1j * d)) * weight[keep]

    keep = amps > 0.2 * np.median(amps)
    p = np.array([k0[0], k0[1], 0.0, 0.0])
    p[2] = float(np.angle(np.sum(weight[keep] * np.exp(1j * (phases[keep] - model(p, pts[keep]))))))
    for _ in range(3):
        p = optimize.least_squares(resid, p, args=(keep,), x_scale=[1e-3, 1e-3, 1e-2, 1e-3],
                                   method="lm" if keep.sum() > 4 else "trf").x
        r = np.angle(np.exp(1j * (phases - model(p, pts))))
        spread = 1.4826 * np.median(np.abs(r[keep])) + 1e-9
        keep = (amps > 0.2 * np.median(amps)) & (np.abs(r) < 5 * spread)
    return p[:2], float(p[2]), float(p[3]), r[keep]


def calibrate_lenticular(image: np.ndarray, *, distortion: bool = True, name: str = "the image") -> LenticularFit:
    """Pitch, slant and phase of the lenticular sheet in a white image (module doc).

    Raises InputError when the image shows no periodic structure.
    """
    img = grey(image)
    h, w = img.shape
    if min(h, w) < 32:
        raise InputError(f"{name} is {w}x{h} pixels; a lenticular calibration needs at least 32x32")
    k, contrast = _peak(img)
    if contrast < MIN_CONTRAST or not np.all(np.isfinite(k)) or not np.any(k):
        raise InputError(f"{name} shows no periodic structure (spectral peak {contrast:.1f}x the background); "
                         "give a white image taken through the lenticular sheet")
    if k[0] < 0 or (k[0] == 0 and k[1] > 0):
        k = -k
    psi, k1, resid = 0.0, 0.0, np.zeros(1)
    for _ in range(2):
        pts, phases, amps = _tile_phases(img, k)
        if len(pts) < 6:
            raise InputError(f"{name} holds too few lenticules ({len(pts)} tiles) to calibrate; "
                             "use a larger white image")
        k, psi, k1, resid = _fit(pts, phases, amps, k, (w, h), distortion)
    if k[0] < 0:
        k, psi = -k, -psi
    norm = float(np.linalg.norm(k))
    pitch = 2 * math.pi / norm
    # n = (cos t, -sin t) in image axes (y down): t counter-clockwise as displayed.
    slant = math.degrees(math.atan2(-k[1], k[0]))
    # Axes where k . (q - c) + psi = 2 pi m: n . (q - c) = -psi / |k| + m pitch.
    phase = (-psi / norm + pitch / 2) % pitch - pitch / 2
    return LenticularFit(pitch, slant, phase, k1, (w, h), float(np.sqrt(np.mean(resid ** 2))), len(resid))
