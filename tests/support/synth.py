"""Synthetic white images through a micro-lens array, with exactly known lens centres.

A physically motivated stand-in for a photograph of a white background through
a holoscopic camera (thesis 4.2 to 4.4), made in NumPy until single-stage CSG
rendering can produce the same through POV-Ray:

- a square or hex lattice of lenses with any pitch (px, non-integral), rotation
  and offset, in the *ideal* image frame;
- each micro-image is the lens's white response: ``rounded`` = cos^k fall-off
  with the off-axis angle, cut by a circular aperture (dark gaps between
  lenses), or ``flat`` = uniform up to the lens cell less a dark border;
- a Brown radial distortion (the main lens) maps the ideal frame to the image;
- cos^4 vignetting of the main lens, Gaussian noise;
- every pixel integrates its square footprint (``supersample^2`` samples).

The true centre of lens ``(m, n)`` is ``distort(centre0 + m a1 + n a2)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from povh3d.errors import ConfigError
from povh3d.calibration.distortion import Brown
from povh3d.calibration.gridfile import nearest_lattice

PROFILES = ("rounded", "flat")


def lattice_basis(lattice: str, pitch: float, rotation_deg: float) -> np.ndarray:
    """Rows ``a1``, ``a2`` (px) of a lattice turned ``rotation_deg`` counter-clockwise as displayed."""
    t = math.radians(rotation_deg)
    a1 = pitch * np.array([math.cos(t), -math.sin(t)])  # image y points down
    turn = math.radians(90.0 if lattice == "square" else 60.0)
    rot = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
    return np.stack([a1, rot @ a1])


@dataclass(frozen=True)
class WhiteSpec:
    """What to synthesise.

    Parameters
    ----------
    size : (int, int)
        ``(W, H)`` px.
    lattice : {'square', 'hex'}
    pitch_px, rotation_deg : float
    offset_px : (float, float)
        Ideal position of one lens centre relative to the image centre.
    k1, k2 : float
        Brown radial coefficients (:class:`Brown` for the image).
    profile : {'rounded', 'flat'}
    cos_power : float
        ``k`` of the cos^k fall-off (rounded).
    focal_px : float
        Micro-lens focal length in pixels; sets how fast cos^k falls (rounded).
    aperture : float
        Aperture radius as a fraction of half the pitch (rounded).
    border_px : float
        Width of the dark border between flat micro-images.
    edge_px : float
        Width of the linear ramp at every aperture edge: the micro-lens blurs
        its aperture's image, and a hard edge would alias (the true centre would
        then depend on the supersampling).
    vignetting : float
        Relative fall-off at the image corners (cos^4 law), 0 = none.
    noise : float
        Standard deviation of additive Gaussian noise, in units of the peak.
    level : float
        Peak brightness at the image centre.
    supersample : int
        Samples per pixel side.
    """

    size: tuple[int, int]
    lattice: str = "square"
    pitch_px: float = 9.37
    rotation_deg: float = 0.0
    offset_px: tuple[float, float] = (0.23, -0.41)
    k1: float = 0.0
    k2: float = 0.0
    profile: str = "rounded"
    cos_power: float = 4.0
    focal_px: float = 12.0
    aperture: float = 0.92
    border_px: float = 1.2
    edge_px: float = 0.7
    vignetting: float = 0.0
    noise: float = 0.0
    level: float = 0.9
    supersample: int = 4
    seed: int = 0

    def __post_init__(self) -> None:
        if self.lattice not in ("square", "hex"):
            raise ConfigError(f"lattice must be square or hex, got {self.lattice!r}")
        if self.profile not in PROFILES:
            raise ConfigError(f"profile must be one of {', '.join(PROFILES)}, got {self.profile!r}")
        if self.pitch_px < 2:
            raise ConfigError(f"pitch_px must be at least 2, got {self.pitch_px!r}")

    @property
    def basis(self) -> np.ndarray:
        return lattice_basis(self.lattice, self.pitch_px, self.rotation_deg)

    @property
    def distortion(self) -> Brown:
        return Brown.for_image(*self.size, k1=self.k1, k2=self.k2)

    @property
    def centre0(self) -> np.ndarray:
        w, h = self.size
        return np.array([(w - 1) / 2 + self.offset_px[0], (h - 1) / 2 + self.offset_px[1]])


def _response(d: np.ndarray, spec: WhiteSpec) -> np.ndarray:
    """White response at ideal offsets ``d`` ``(..., 2)`` px from the lens centre."""
    half = spec.pitch_px / 2
    if spec.profile == "rounded":
        r2 = np.sum(d * d, axis=-1)
        falloff = (1.0 + r2 / spec.focal_px**2) ** (-spec.cos_power / 2)  # cos^k(atan(r/f))
        return falloff * _ramp(spec.aperture * half - np.sqrt(r2), spec.edge_px)
    # Flat: inside the lens cell (distance to every cell edge) less half the border.
    basis = spec.basis
    normals = [basis[0], basis[1]] if spec.lattice == "square" else [basis[0], basis[1], basis[1] - basis[0]]
    reach = np.zeros(d.shape[:-1])
    for nvec in normals:
        u = nvec / np.linalg.norm(nvec)
        reach = np.maximum(reach, np.abs(d @ u))
    return _ramp(half - spec.border_px / 2 - reach, spec.edge_px)


def _ramp(inside_by: np.ndarray, width: float) -> np.ndarray:
    """1 well inside an edge, 0 well outside, linear over ``width`` px across it."""
    if width <= 0:
        return (inside_by >= 0).astype(np.float64)
    return np.clip(inside_by / width + 0.5, 0.0, 1.0)


Content = Callable[[np.ndarray, np.ndarray], np.ndarray]


def render_white(spec: WhiteSpec, *, content: Content | None = None, rows_per_chunk: int = 64) -> np.ndarray:
    """The white image, ``(H, W)`` float32 linear, values about ``[0, level]``.

    ``content(centre, uv)`` turns it into a scene capture: the scene brightness
    seen by the lens whose ideal centre is ``centre`` (``(..., 2)`` px) at the
    in-lens position ``uv`` (``(..., 2)``, lattice units along ``a1`` and
    perpendicular to it, ``0`` at the centre); it multiplies the white response.
    """
    w, h = spec.size
    s = int(spec.supersample)
    sub = (np.arange(s) + 0.5) / s - 0.5
    xs = (np.arange(w)[:, None] + sub[None, :]).ravel()
    basis = spec.basis
    inv = np.linalg.inv(basis.T)
    dist = spec.distortion
    c0 = spec.centre0
    out = np.empty((h, w), dtype=np.float32)
    for r0 in range(0, h, rows_per_chunk):
        r1 = min(h, r0 + rows_per_chunk)
        ys = (np.arange(r0, r1)[:, None] + sub[None, :]).ravel()
        pts = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1)
        ideal = pts if dist.is_identity else dist.undistort(pts)
        q = (ideal - c0) @ inv.T
        nearest = nearest_lattice(q, basis, spec.lattice)
        d = ideal - (c0 + nearest @ basis)
        value = _response(d, spec)
        if content is not None:
            centre = c0 + nearest @ basis
            e1 = basis[0] / np.linalg.norm(basis[0])
            e2 = np.array([-e1[1], e1[0]])
            uv = np.stack([d @ e1, d @ e2], axis=-1) / spec.pitch_px
            value = value * content(centre, uv)
        out[r0:r1] = value.reshape(r1 - r0, s, w, s).mean(axis=(1, 3))
    if spec.vignetting > 0:
        yy, xx = np.mgrid[0:h, 0:w]
        r = np.hypot(xx - (w - 1) / 2, yy - (h - 1) / 2)
        # cos^4(atan(r/F)), F chosen so that the corners keep 1 - vignetting.
        corner = 0.5 * math.hypot(w, h)
        F = corner / math.sqrt((1 - spec.vignetting) ** -0.5 - 1)
        out *= ((1 + (r / F) ** 2) ** -2).astype(np.float32)
    out *= np.float32(spec.level)
    if spec.noise > 0:
        rng = np.random.default_rng(spec.seed)
        out += rng.normal(0.0, spec.noise * spec.level, out.shape).astype(np.float32)
    return out


def true_centres(spec: WhiteSpec, margin: float = 0.0) -> np.ndarray:
    """Recorded centres ``(n, 2)`` px of every lens whose centre lies on the image (``margin`` px inside)."""
    w, h = spec.size
    basis = spec.basis
    c0 = spec.centre0
    reach = int(math.ceil(1.5 * math.hypot(w, h) / spec.pitch_px)) + 2
    m, n = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1), indexing="ij")
    ideal = c0 + m.ravel()[:, None] * basis[0] + n.ravel()[:, None] * basis[1]
    # Only the part of the ideal plane the image sees: a barrel model folds back
    # far outside it, which would list phantom lenses.
    ideal = ideal[np.hypot(*(ideal - [(w - 1) / 2, (h - 1) / 2]).T) <= 1.5 * 0.5 * math.hypot(w, h)]
    c = spec.distortion.distort(ideal)
    keep = ((c[:, 0] >= -0.5 + margin) & (c[:, 0] <= w - 0.5 - margin)
            & (c[:, 1] >= -0.5 + margin) & (c[:, 1] <= h - 0.5 - margin))
    return c[keep]


def to_uint(image: np.ndarray, bits: int = 16) -> np.ndarray:
    """Quantise a linear ``[0, 1]`` float image to 8/16-bit sRGB, as a camera file would be."""
    from povh3d.image.colour import from_linear

    return from_linear(np.clip(image, 0, 1), np.uint16 if bits == 16 else np.uint8)


def render_lenticular_white(size: tuple[int, int], pitch_px: float, slant_deg: float, phase_px: float, *,
                            k1: float = 0.0, vignetting: float = 0.0, noise: float = 0.0,
                            border_px: float = 1.0, supersample: int = 4, seed: int = 0) -> np.ndarray:
    """A white image ``(H, W)`` float of a slanted lenticular sheet (``calibration.lenticular`` conventions).

    Each lenticule is bright on its axis with a cos^2 fall-off and a dark border
    ``border_px`` wide; a Brown ``k1`` maps ideal to image positions; cos^4
    vignetting keeps ``1 - vignetting`` at the corners; every pixel integrates its
    square footprint.  Axes lie where ``n . (q - c) = phase + m pitch`` with
    ``n = (cos t, -sin t)`` (image y down), ``c`` the image centre.
    """
    w, h = size
    s = int(supersample)
    sub = (np.arange(s) + 0.5) / s - 0.5
    t = math.radians(slant_deg)
    n = np.array([math.cos(t), -math.sin(t)])
    centre = np.array([(w - 1) / 2, (h - 1) / 2])
    dist = Brown.for_image(w, h, k1=k1)
    xs = (np.arange(w)[:, None] + sub[None, :]).ravel()
    out = np.empty((h, w))
    for r0 in range(0, h, 64):
        r1 = min(h, r0 + 64)
        ys = (np.arange(r0, r1)[:, None] + sub[None, :]).ravel()
        pts = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1)
        q = pts if dist.is_identity else dist.undistort(pts)
        d = (q - centre) @ n - phase_px
        d = d - pitch_px * np.round(d / pitch_px)  # from the nearest axis
        value = np.cos(np.pi * d / (1.6 * pitch_px)) ** 2 * _ramp(pitch_px / 2 - border_px / 2 - np.abs(d), 0.6)
        out[r0:r1] = value.reshape(r1 - r0, s, w, s).mean(axis=(1, 3))
    if vignetting > 0:
        yy, xx = np.mgrid[0:h, 0:w]
        r = np.hypot(xx - centre[0], yy - centre[1])
        F = 0.5 * math.hypot(w, h) / math.sqrt((1 - vignetting) ** -0.5 - 1)
        out *= (1 + (r / F) ** 2) ** -2
    out *= 0.9
    if noise > 0:
        out += np.random.default_rng(seed).normal(0.0, noise * 0.9, out.shape)
    return out.astype(np.float32)
