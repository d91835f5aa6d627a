"""Lens centres measured against a template micro-image built from the image itself
(step 3 of ``lattice``): each centre is the point of symmetry of its micro-image,
with a per-lens gain and offset (vignetting)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage



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


def disc(half: int, radius: float) -> tuple[np.ndarray, np.ndarray]:
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
    ox, oy = disc(half, radius)
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
