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
from scipy import optimize

from ..errors import InputError
from .basis import FFT_CROP, MIN_PITCH_PX, WORK_PX, fft_basis, fold_origin, grey
from .distortion import Brown
from .gridfile import Grid
from .template import build_template, disc, measure


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
    # Hex, docs/geometry.md layout: row i = n - n_min; along the row the lens sits at
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
    found, basis, snr = fft_basis(img, lattice, name)
    pitch = float(np.mean(np.linalg.norm(basis, axis=1)))
    if min(h, w) < 2 * pitch:
        raise InputError(f"{name} is {w}x{h} pixels, too small for two lenses of {pitch:.1f} px; "
                         "use the camera's full image")
    origin = fold_origin(img, basis)
    model = _Model(origin, basis, np.zeros(2), np.array([(w - 1) / 2, (h - 1) / 2]), 0.5 * math.hypot(w, h))

    half = int(math.ceil(0.5 * pitch + 2))
    radius = 0.5 * pitch + 0.5
    # Work per pass is lenses x window pixels; large pitches need fewer lenses.
    limit = max(200, min(max_lenses, int(WORK_PX / len(disc(half, radius)[0]))))
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

    assert template is not None  # the loop above built it
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
