"""Find the micro-lens grid in a white image (thesis 4.2, 4.4: the calibration grid).

The method, chosen so that errors average over thousands of lenses:

1. **Basis** from the Fourier peaks of a central crop (Hann window, sub-bin
   log-parabola): the two shortest independent peaks are the reciprocal basis;
   the reduced real basis tells square (90 deg) from hex (60 deg).
2. **Offset**: fold the crop onto one lattice cell and find its centre of point
   symmetry (the peak of the cell's self-convolution); of the four symmetric
   points the brightest is the lens centre (the others are dark borders).
3. **Refinement**, coarse to fine over growing discs of lenses: each lens's
   centre is the point of symmetry of its micro-image, found by Gauss-Newton
   matching against a *template micro-image built from the image itself* and
   made point-symmetric, with a per-lens gain and offset (vignetting); then
   one least-squares fit of the lattice (``origin``, ``a1``, ``a2``) and the
   Brown radial distortion to all those centres, with outlier rejection.

Only a strided subset of lenses (``max_lenses``) is measured: eight numbers are
fitted, so a few thousand lenses pin them far below 0.01 px and the cost stays
flat in the image size.  The grid reports every lens from the fitted model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize

from ..errors import InputError
from .distortion import Brown
from .gridfile import Grid

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


def _refine_peak(mag: np.ndarray, iy: int, ix: int) -> tuple[float, float]:
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


@dataclass(frozen=True)
class _Start:
    lattice: str
    basis: np.ndarray  # rows a1, a2, px
    origin: np.ndarray  # a lens centre near the image centre, px
    snr: float


def _fft_basis(img: np.ndarray, lattice: str | None, name: str) -> tuple[str, np.ndarray, float]:
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
        raise InputError(f"{name} shows a {found} lens lattice, not {lattice}; drop --lattice or check the image")
    pitch = float(np.linalg.norm(b1))
    if pitch < MIN_PITCH_PX:
        raise InputError(f"{name}: the lens pitch looks like {pitch:.2f} px; at least {MIN_PITCH_PX:g} px are needed")
    return found, _canonical(b1, b2, found), snr


# -- 2. offset: centre of symmetry of the folded cell ------------------------------
def _fold_origin(img: np.ndarray, basis: np.ndarray, bins: int = 32) -> np.ndarray:
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
@dataclass(frozen=True)
class Template:
    """Mean micro-image ``values[y, x]`` at offsets ``(k - K//2) * step`` px from the lens centre."""

    values: np.ndarray
    step: float

    @property
    def radius(self) -> float:
        return (self.values.shape[0] // 2) * self.step

    def sample(self, dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bilinear value and gradient (per px) at offsets ``dx``, ``dy`` (same shape); edge-clamped."""
        v = self.values.ravel().astype(dx.dtype)
        k = self.values.shape[0]
        inv = dx.dtype.type(1 / self.step)
        fx = np.clip(dx * inv + k // 2, 0, k - 1.001)
        fy = np.clip(dy * inv + k // 2, 0, k - 1.001)
        x0 = fx.astype(np.intp)
        y0 = fy.astype(np.intp)
        tx = fx - x0
        ty = fy - y0
        i00 = y0 * k + x0
        v00 = v[i00]
        v01 = v[i00 + 1]
        v10 = v[i00 + k]
        v11 = v[i00 + k + 1]
        top = v00 + (v01 - v00) * tx
        bot = v10 + (v11 - v10) * tx
        val = top + (bot - top) * ty
        gx = ((v01 - v00) + ((v11 - v10) - (v01 - v00)) * ty) * inv
        gy = (bot - top) * inv
        return val, gx, gy


def _patches(img: np.ndarray, centres: np.ndarray, half: int):
    """Square pixel windows around ``centres``: (ok mask, patches (n, m, m), x (n, m), y (n, m))."""
    h, w = img.shape
    ix = np.rint(centres[:, 0]).astype(np.intp)
    iy = np.rint(centres[:, 1]).astype(np.intp)
    ok = (ix - half >= 0) & (ix + half < w) & (iy - half >= 0) & (iy + half < h)
    offs = np.arange(-half, half + 1)
    xs = ix[ok, None] + offs
    ys = iy[ok, None] + offs
    return ok, img[ys[:, :, None], xs[:, None, :]], xs.astype(np.float64), ys.astype(np.float64)


def build_template(img: np.ndarray, centres: np.ndarray, gain: np.ndarray, background: np.ndarray,
                   half: int, step: float = 0.25, unwarp: np.ndarray | None = None) -> Template:
    """Average micro-image around ``centres`` (gain and background removed), made point-symmetric.

    ``unwarp`` ``(n, 2, 2)`` maps each lens's pixel offsets to the ideal frame (the
    inverse local Jacobian of the distortion), so micro-images squeezed by a barrel
    lens average into one undistorted template.
    """
    ok, patch, xs, ys = _patches(img, centres, half)
    c = centres[ok]
    k = int(round((half + 2) / step)) * 2 + 1
    mid = k // 2
    dx, dy = np.broadcast_arrays(xs[:, None, :] - c[:, 0, None, None], ys[:, :, None] - c[:, 1, None, None])
    if unwarp is not None:
        u = unwarp[ok]
        dx, dy = (u[:, 0, 0, None, None] * dx + u[:, 0, 1, None, None] * dy,
                  u[:, 1, 0, None, None] * dx + u[:, 1, 1, None, None] * dy)
    bx = np.rint(dx / step).astype(np.intp) + mid
    by = np.rint(dy / step).astype(np.intp) + mid
    vals = (patch - background[ok, None, None]) / gain[ok, None, None]
    inside = (bx >= 0) & (bx < k) & (by >= 0) & (by < k)
    flat = (by * k + bx)[inside]
    num = np.bincount(flat, vals[inside].astype(np.float64), k * k).reshape(k, k)
    cnt = np.bincount(flat, minlength=k * k).reshape(k, k).astype(np.float64)
    # Few samples per bin leave holes: fill them by smoothing more.
    sigma = 0.6 if vals.size / (k * k) >= 8 else 1.5
    num = ndimage.gaussian_filter(num, sigma, mode="constant")
    cnt = ndimage.gaussian_filter(cnt, sigma, mode="constant")
    t = np.where(cnt > 1e-6, num / np.maximum(cnt, 1e-6), 0.0)
    # The lens centre is the micro-image's point of symmetry: symmetrising pins it,
    # so the template cannot drift with the centres it is built from.
    return Template(0.5 * (t + t[::-1, ::-1]), step)


@dataclass
class Measured:
    centres: np.ndarray  # (n, 2) px
    gain: np.ndarray  # (n,)
    background: np.ndarray  # (n,)
    ok: np.ndarray  # (n,) bool, of the input lenses


def _disc(half: int, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Pixel offsets ``(dx, dy)`` within ``radius`` + 1.5 px: the window of any centre rounded to a pixel."""
    offs = np.arange(-half, half + 1)
    dy, dx = np.meshgrid(offs, offs, indexing="ij")
    keep = dx * dx + dy * dy <= (radius + 1.5) ** 2
    return dx[keep], dy[keep]


def measure(img: np.ndarray, centres: np.ndarray, template: Template, half: int, radius: float,
            iterations: int = 3, unwarp: np.ndarray | None = None) -> Measured:
    """Centre of symmetry of each micro-image near ``centres`` (Gauss-Newton against ``template``).

    Per lens, ``I = A T(x - c - delta) + B`` is linearised in ``delta`` and solved
    with the gain ``A`` and background ``B`` over a disc of ``radius`` px.
    """
    h, w = img.shape
    ix = np.rint(centres[:, 0]).astype(np.intp)
    iy = np.rint(centres[:, 1]).astype(np.intp)
    ok = (ix - half >= 0) & (ix + half < w) & (iy - half >= 0) & (iy + half < h)
    ox, oy = _disc(half, radius)
    px = ix[ok, None] + ox  # (n, p) pixel positions
    py = iy[ok, None] + oy
    values = img[py, px].astype(np.float32)[:, :, None]
    px = px.astype(np.float32)
    py = py.astype(np.float32)
    c = centres[ok].copy()
    n = len(c)
    sol = np.zeros((n, 4))
    design = np.empty((n, 4, px.shape[1]), dtype=np.float32)  # float32: half the memory traffic
    design[:, 1] = 1.0
    for _ in range(iterations):
        dx = px - c[:, 0:1].astype(np.float32)
        dy = py - c[:, 1:2].astype(np.float32)
        if unwarp is None:
            t, gx, gy = template.sample(dx, dy)
        else:  # template in the ideal frame: T(U d), gradient U^T grad T
            u = unwarp[ok].astype(np.float32)
            t, ga, gb = template.sample(u[:, 0, 0:1] * dx + u[:, 0, 1:2] * dy, u[:, 1, 0:1] * dx + u[:, 1, 1:2] * dy)
            gx = u[:, 0, 0:1] * ga + u[:, 1, 0:1] * gb
            gy = u[:, 0, 1:2] * ga + u[:, 1, 1:2] * gb
        wgt = np.clip(np.float32(radius + 1.0) - np.sqrt(dx * dx + dy * dy), 0.0, 1.0)
        design[:, 0] = t
        design[:, 2] = -gx
        design[:, 3] = -gy
        dw = design * wgt[:, None, :]
        normal = (dw @ design.transpose(0, 2, 1)).astype(np.float64) + 1e-9 * np.eye(4)
        rhs = (dw @ values)[..., 0].astype(np.float64)
        sol = np.linalg.solve(normal, rhs[..., None])[..., 0]
        amp = np.where(np.abs(sol[:, 0]) > 1e-9, sol[:, 0], 1e-9)
        c += np.clip(sol[:, 2:4] / amp[:, None], -0.25 * radius, 0.25 * radius)
    full = np.zeros_like(centres)
    full[ok] = c
    gain = np.zeros(len(centres))
    gain[ok] = sol[:, 0]
    bg = np.zeros(len(centres))
    bg[ok] = sol[:, 1]
    return Measured(full, gain, bg, ok)


# -- 4. the global model: lattice + Brown distortion -----------------------------------
@dataclass
class _Model:
    origin: np.ndarray  # ideal centre of lattice point (0, 0), px
    basis: np.ndarray  # rows a1, a2
    k: np.ndarray  # k1, k2
    brown_centre: np.ndarray
    scale: float

    def ideal(self, mn: np.ndarray) -> np.ndarray:
        return self.origin + mn @ self.basis

    def predict(self, mn: np.ndarray) -> np.ndarray:
        return self.brown().distort(self.ideal(mn))

    def brown(self) -> Brown:
        return Brown(float(self.k[0]), float(self.k[1]), tuple(self.brown_centre), self.scale)

    def unwarp(self, mn: np.ndarray) -> np.ndarray | None:
        """Inverse local Jacobians ``(n, 2, 2)`` of the distortion at the lenses (None: no distortion)."""
        if not self.k.any():
            return None
        u = self.ideal(mn)
        b = self.brown()
        e = 0.5
        jx = (b.distort(u + [e, 0.0]) - b.distort(u - [e, 0.0])) / (2 * e)
        jy = (b.distort(u + [0.0, e]) - b.distort(u - [0.0, e])) / (2 * e)
        return np.linalg.inv(np.stack([jx, jy], axis=-1))


def _fit(model: _Model, mn: np.ndarray, meas: np.ndarray, n_k: int) -> _Model:
    """Least squares of origin, basis and ``n_k`` distortion terms to measured centres."""
    mn = mn.astype(np.float64)
    c0, s = model.brown_centre, model.scale

    def unpack(p):
        k = np.zeros(2)
        k[:n_k] = p[6:6 + n_k]
        return p[0:2], p[2:6].reshape(2, 2), k

    def resid(p):
        o, b, k = unpack(p)
        d = o + mn @ b - c0
        rho2 = np.sum(d * d, axis=1, keepdims=True) / s**2
        return (c0 + d * (1 + k[0] * rho2 + k[1] * rho2 * rho2) - meas).ravel()

    p0 = np.concatenate([model.origin, model.basis.ravel(), model.k[:n_k]])
    res = optimize.least_squares(resid, p0, method="lm", x_scale=np.concatenate(
        [[1, 1], np.full(4, 0.01), np.full(n_k, 1e-3)]))
    o, b, k = unpack(res.x)
    return _Model(o, b, k, c0, s)


def _fit_robust(model: _Model, mn: np.ndarray, meas: np.ndarray, n_k: int) -> tuple[_Model, np.ndarray, np.ndarray]:
    keep = np.ones(len(mn), bool)
    for _ in range(3):
        model = _fit(model, mn[keep], meas[keep], n_k)
        err = np.linalg.norm(model.predict(mn) - meas, axis=1)
        sigma = 1.4826 * np.median(err[keep])
        new = err <= max(5 * sigma, 0.05)
        if np.array_equal(new, keep):
            break
        keep = new
    return model, keep, err


def _lattice_points(model: _Model, shape: tuple[int, int], radius: float, margin: float = 0.0) -> np.ndarray:
    """Integer ``(m, n)`` of lattice points whose predicted centre is within ``radius`` of the image centre."""
    h, w = shape
    centre = np.array([(w - 1) / 2, (h - 1) / 2])
    inv = np.linalg.inv(model.basis)
    q0 = np.rint((centre - model.origin) @ inv)
    short = min(np.linalg.norm(model.basis, axis=1)) * 0.8  # the distortion may shrink the lattice
    reach = int(math.ceil(min(radius, 0.5 * math.hypot(w, h)) / short)) + 2
    r = np.arange(-reach, reach + 1)
    m, n = np.meshgrid(r + q0[0], r + q0[1], indexing="ij")
    mn = np.stack([m.ravel(), n.ravel()], axis=1)
    p = model.predict(mn)
    keep = (np.linalg.norm(p - centre, axis=1) <= radius) & (p[:, 0] >= -margin) & (p[:, 0] <= w - 1 + margin) \
        & (p[:, 1] >= -margin) & (p[:, 1] <= h - 1 + margin)
    return mn[keep].astype(np.int64)


def _subset(mn: np.ndarray, limit: int) -> np.ndarray:
    stride = max(1, int(math.ceil(math.sqrt(len(mn) / limit))))
    if stride == 1:
        return mn
    return mn[(mn[:, 0] % stride == 0) & (mn[:, 1] % stride == 0)]


# -- 5. the lens table -------------------------------------------------------------
def _table(model: _Model, lattice: str, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Canonical origin, basis and table size covering every lens whose centre is on the image."""
    h, w = shape
    mn = _lattice_points(model, shape, 0.5 * math.hypot(w, h) + 1, margin=0.5)
    a1, a2 = model.basis
    n_min, n_max = int(mn[:, 1].min()), int(mn[:, 1].max())
    if lattice == "square":
        m_min, m_max = int(mn[:, 0].min()), int(mn[:, 0].max())
        origin = model.origin + m_min * a1 + n_min * a2
        return origin, model.basis, (n_max - n_min + 1, m_max - m_min + 1)
    # Hex, CONVENTIONS layout: row i = n - n_min; along the row the lens sits at
    # t = m + n/2 pitches, so j = t - (i mod 2)/2 - n_min/2 is whole.
    i = mn[:, 1] - n_min
    j = mn[:, 0] + (mn[:, 1] - n_min - (i % 2)) // 2
    j_min, j_max = int(j.min()), int(j.max())
    r = a2 - a1 / 2
    origin = model.origin + (j_min + n_min / 2) * a1 + n_min * r
    return origin, model.basis, (n_max - n_min + 1, j_max - j_min + 1)


def _smooth_gain(points: np.ndarray, gain: np.ndarray, where: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Vignetting as a quartic in x, y fitted to the measured lens gains, evaluated at ``where``."""
    h, w = shape

    def terms(p):
        x = (p[:, 0] - w / 2) / w
        y = (p[:, 1] - h / 2) / h
        return np.stack([x**a * y**b for a in range(5) for b in range(5 - a)], axis=1)
    coef, *_ = np.linalg.lstsq(terms(points), gain, rcond=None)
    return terms(where.reshape(-1, 2)) @ coef


# -- the public entry --------------------------------------------------------------
def calibrate(image: np.ndarray, *, lattice: str | None = None, distortion: bool = True,
              max_lenses: int = 3000, name: str = "the white image") -> Grid:
    """The lens grid of a white image taken through a square or hex micro-lens array.

    Parameters
    ----------
    image : (H, W[, C]) uint8, uint16 or float
    lattice : {'square', 'hex'} or None
        Expected lattice; None detects it.
    distortion : bool
        Fit the Brown radial terms ``k1``, ``k2`` (else the lattice is straight).
    max_lenses : int
        Lenses measured per stage (a strided subset of all lenses).

    Returns
    -------
    Grid
        With ``residual_px`` (RMS of measured minus fitted centres) and
        ``confidence`` = inlier fraction x Fourier contrast term x residual term,
        each in ``[0, 1]``.
    """
    img = grey(image)
    h, w = img.shape
    if min(h, w) < 4 * MIN_PITCH_PX:
        raise InputError(f"{name} is {w}x{h} pixels, too small to hold two lenses of at least "
                         f"{MIN_PITCH_PX:g} px in each direction; use the camera's full image")
    found, basis, snr = _fft_basis(img, lattice, name)
    pitch = float(np.mean(np.linalg.norm(basis, axis=1)))
    if min(h, w) < 2 * pitch:
        raise InputError(f"{name} is {w}x{h} pixels, too small for two lenses of {pitch:.1f} px; "
                         "use the camera's full image")
    origin = _fold_origin(img, basis)
    model = _Model(origin, basis, np.zeros(2), np.array([(w - 1) / 2, (h - 1) / 2]), 0.5 * math.hypot(w, h))

    half = int(math.ceil(0.5 * pitch + 2))
    radius = 0.5 * pitch + 0.5
    # Work per pass is lenses x window pixels; large pitches need fewer lenses.
    limit = max(200, min(max_lenses, int(WORK_PX / len(_disc(half, radius)[0]))))
    full = 0.5 * math.hypot(w, h)
    stage = 0.5 * min(h, w, FFT_CROP) * 0.95
    template = None
    first = True
    while True:
        final = stage >= full
        mn = _subset(_lattice_points(model, (h, w), stage), limit)
        if len(mn) < 4:
            raise InputError(f"{name} holds too few whole lenses ({len(mn)}) to fit a lattice; "
                             "use a larger image")
        # Distortion terms as soon as the disc is wide enough to see them, so the
        # next, wider disc is predicted well enough to label every lens right.
        n_k = 0 if not distortion or stage < 0.2 * full else (1 if stage < 0.6 * full else 2)
        for _ in range(2 if first or final else 1):
            pred = model.predict(mn)
            if template is None:
                density = len(mn) * (2 * half + 1) ** 2 / (2 * (half + 2) / 0.25) ** 2
                template = build_template(img, pred, np.ones(len(pred)), np.zeros(len(pred)), half,
                                          0.25 if density >= 8 else 0.5)
            unwarp = model.unwarp(mn)
            got = measure(img, pred, template, half, radius, iterations=3 if first else 2, unwarp=unwarp)
            good = got.ok & (got.gain > 0.25 * np.median(got.gain[got.ok]))
            if good.sum() < 4:
                raise InputError(f"{name}: too few lenses could be measured ({int(good.sum())}); check the image")
            model, keep, err = _fit_robust(model, mn[good], got.centres[good], n_k)
            use = np.flatnonzero(good)[keep]
            template = build_template(img, got.centres[use], got.gain[use], got.background[use], half,
                                      template.step, None if unwarp is None else unwarp[use])
            first = False
        if final:
            break
        stage *= 1.6

    residual = float(np.sqrt(np.mean(err[keep] ** 2)))
    inlier = float(keep.sum()) / max(1, int(got.ok.sum()))
    confidence = inlier * min(1.0, math.log10(snr) / 3) / (1 + (residual / (0.02 * pitch)) ** 2)
    t_origin, t_basis, table = _table(model, found, (h, w))
    # Template normalised to peak 1; the gain carries the white level of each lens.
    # The white response is A T + B per lens; B (stray light, template blur in the
    # gaps) scales with the lens's gain, so it joins the template as a constant.
    ratio = float(np.median(got.background[use] / got.gain[use]))
    response = np.clip(template.values + ratio, 0.0, None)
    peak = float(response.max())
    grid = Grid(found, (w, h), t_basis, t_origin, table, model.brown())
    gain = _smooth_gain(got.centres[use], got.gain[use] * peak, grid.centres, (h, w)).reshape(table)
    return Grid(found, (w, h), t_basis, t_origin, table, model.brown(), residual_px=residual,
                confidence=round(confidence, 4), template=response / peak, template_step=template.step,
                gain=np.maximum(gain, 0.0),
                extra={"lenses_measured": int(keep.sum()), "fourier_snr": round(snr, 1)})
