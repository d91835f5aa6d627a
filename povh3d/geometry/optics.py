"""Lens-maker and conic optics of a plano-convex lenslet: pure maths, no I/O.

The lenslet of the single-stage method is plano-convex, flat face toward the
camera (the capture "panel"), curved face toward the scene.  Collimated camera
rays cross the flat face undeviated and refract once, at the curved face.

- Focal length: ``1/f = (n - 1)/R`` (lens-maker, ``r2 = inf``), exact also for a
  thick lens because the flat face has no power.  With the flat face first the
  rear principal plane touches the curved vertex, so the focus lies ``f`` past
  the vertex whatever the thickness (thesis Eq. 3.1; docs/geometry.md).
- Curved face, vertex at the origin, axis +z, glass at ``z < 0``:
  ``h^2 = 2 R s - (1 + K) s^2`` with sag ``s = -z`` at height ``h``.
  ``K = 0`` is a sphere; ``K = -n^2`` is the hyperboloid that focuses collimated
  light coming through the flat face to one point (Fermat: ``n s + |P F| = f``).
- Even the hyperboloid maps a ray's height ``w`` to ``tan(theta) = w / (f + s(w))``,
  not ``w / f``: the ray bends where it leaves the surface, ``s(w)`` before the
  principal plane.  That is a distortion, not an aberration; it shrinks with the
  sag, so the default index makes the lenslet optically thin (``default_ior``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import cast

import numpy as np

from ..errors import ConfigError, param

SHAPES = ("spherical", "conic")
APERTURES = ("square", "hex", "lenticular")

#: Default thinness: sag at the aperture's corner as a fraction of f.  The
#: angular distortion of the lenslet is about this fraction at the corner.
DEFAULT_THINNESS = 0.005
#: Default index when a lens is thin enough with it (acrylic / crown glass).
GLASS_IOR = 1.5


# A lenslet deeper than this many focal lengths is refused (IOR too close to 1).
MAX_SAG_FOCALS = 10.0


def aperture_radius(aperture: str, pitch_x: float, pitch_y: float) -> float:
    """Largest distance from the lens centre to its aperture edge, mm.

    Square: half the diagonal; hex (rows ``pitch_x*sqrt(3)/2`` apart): the
    hexagon's circumradius ``pitch_x/sqrt(3)``; lenticular: half the pitch.
    """
    if aperture == "square":
        return math.hypot(pitch_x, pitch_y) / 2
    if aperture == "hex":
        return pitch_x / math.sqrt(3)
    if aperture == "lenticular":
        return pitch_x / 2
    raise ConfigError(f"aperture must be one of {', '.join(APERTURES)}, got {aperture!r}")


def default_ior(focal: float, rho: float, thinness: float = DEFAULT_THINNESS) -> float:
    """The index used when ``--ior`` is not given.

    The smallest index (at least ``GLASS_IOR``) whose paraxial sag at the
    aperture corner, ``rho^2 / (2 (n-1) f)``, is at most ``thinness * f``.  A
    virtual lens may have any index; a thin one traces the ray of a pixel
    (docs/geometry.md) with little distortion, spherical or conic.  ``--ior 1.5``
    simulates a real acrylic lenslet instead, distortion and all.
    """
    n = 1.0 + rho * rho / (2.0 * thinness * focal * focal)
    return max(GLASS_IOR, math.ceil(n * 100) / 100)


def sag(h: np.ndarray | float, radius: float, conic: float) -> np.ndarray:
    """Sag ``s(h)`` of the conic surface ``h^2 = 2 R s - (1 + K) s^2``, mm.

    Parameters
    ----------
    h : (...) float, mm      distance from the axis
    radius : float, mm       vertex radius ``R``
    conic : float            conic constant ``K``

    Returns
    -------
    (...) float, mm; NaN where the surface does not reach (a sphere past ``R``).
    """
    h = np.asarray(h, dtype=np.float64)
    root = 1.0 - (1.0 + conic) * h * h / (radius * radius)
    with np.errstate(invalid="ignore"):
        return h * h / (radius * (1.0 + np.sqrt(root)))


@dataclass(frozen=True)
class Lenslet:
    """One plano-convex lenslet of the virtual array.

    Parameters
    ----------
    shape : {'spherical', 'conic'}
    aperture : {'square', 'hex', 'lenticular'}
    pitch_x, pitch_y : float, mm   aperture (the lens pitch; hex: ``pitch_y`` is the row spacing)
    focal : float, mm              focal length, from the rear principal plane
    ior : float or None            index of refraction; None picks ``default_ior``
    """

    shape: str
    aperture: str
    pitch_x: float
    pitch_y: float
    focal: float
    ior: float | None = None

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ConfigError(f"{param('lenslet')} must be one of {', '.join(SHAPES)}, got {self.shape!r}")
        rho = aperture_radius(self.aperture, self.pitch_x, self.pitch_y)
        if self.ior is None:
            object.__setattr__(self, "ior", default_ior(self.focal, rho))
        n = self.ior
        if isinstance(n, bool) or not isinstance(n, (int, float)) or not math.isfinite(n) or n <= 1.0:
            raise ConfigError(f"the index of refraction must be greater than 1 (a lens of index <= 1 "
                              f"does not converge), got {n!r}; change {param('ior')}, e.g. {param('ior')} 1.5")
        object.__setattr__(self, "ior", float(n))
        if self.shape == "spherical" and self.radius <= rho * (1 + 1e-9):
            # A sphere of radius R covers at most a disc of radius R: the cap
            # cannot span the aperture, whatever the thickness.
            need_n = 1.0 + rho / self.focal
            raise ConfigError(
                f"a spherical lenslet of focal length {self.focal:g} mm and index {n:g} has radius "
                f"{self.radius:.4g} mm, too small to span the {rho:.4g} mm aperture corner; raise {param('ior')} "
                f"above {need_n:.4g}, lengthen {param('focal')} above {rho / (n - 1):.4g} mm, or use {param('lenslet')} conic")

        if self.corner_sag > MAX_SAG_FOCALS * self.focal:
            # Near n = 1 the curved face needs an enormous sag, and its maths loses
            # precision (measured: focus off by half at n - 1 = 1e-9).
            raise ConfigError(
                f"an index of refraction of {n:.12g} makes the {self.shape} lenslet {self.corner_sag:.4g} mm "
                f"deep, {self.corner_sag / self.focal:.0f} focal lengths; raise {param('ior')} (at least about "
                f"{self._least_ior():.4g}; 1.5 is glass)")

    def _least_ior(self) -> float:
        """The smallest index whose corner sag stays within MAX_SAG_FOCALS focal lengths."""
        lo, hi = 1.0, 2.0
        for _ in range(60):
            mid = (lo + hi) / 2
            deep = sag(self.aperture_radius, (mid - 1) * self.focal,
                       0.0 if self.shape == "spherical" else -mid ** 2) > MAX_SAG_FOCALS * self.focal
            lo, hi = (mid, hi) if deep else (lo, mid)
        return hi

    @property
    def refractive_index(self) -> float:
        return cast(float, self.ior)  # a float: __post_init__ replaces None by default_ior

    @property
    def radius(self) -> float:
        """Vertex radius of the curved face, ``R = (n - 1) f``, mm (lens-maker)."""
        return (self.refractive_index - 1.0) * self.focal

    @property
    def conic(self) -> float:
        """Conic constant ``K``: 0 (sphere) or ``-n^2`` (hyperboloid)."""
        return 0.0 if self.shape == "spherical" else -self.refractive_index ** 2

    @property
    def aperture_radius(self) -> float:
        return aperture_radius(self.aperture, self.pitch_x, self.pitch_y)

    @cached_property
    def corner_sag(self) -> float:
        """Sag of the curved face at the aperture corner, mm."""
        return float(sag(self.aperture_radius, self.radius, self.conic))

    @property
    def thickness(self) -> float:
        """Centre thickness: the corner sag plus a thin edge (no zero-width rim), mm."""
        return self.corner_sag + max(0.02 * self.corner_sag, 1e-4 * self.focal)

    @property
    def tir_height(self) -> float:
        """Height above which a collimated ray meets total internal reflection, mm.

        Sphere: incidence ``asin(h/R)`` exceeds ``asin(1/n)`` past ``h = R/n``.
        The hyperboloid approaches the critical angle only at infinity: ``inf``.
        """
        return self.radius / self.refractive_index if self.shape == "spherical" else math.inf

    def quadric(self) -> tuple[tuple[float, float, float], tuple[float, float, float],
                               tuple[float, float, float], float]:
        """POV-Ray ``quadric { <A,B,C>, <D,E,F>, <G,H,I>, J }`` of the curved face.

        ``A x^2 + B y^2 + C z^2 + ... + I z + J``, negative inside the glass:
        ``x^2 + y^2 + (1 + K) z^2 + 2 R z``.  A lenticular lens has no ``y^2``
        term (a cylinder along y).
        """
        b = 0.0 if self.aperture == "lenticular" else 1.0
        return ((1.0, b, 1.0 + self.conic), (0.0, 0.0, 0.0), (0.0, 0.0, 2.0 * self.radius), 0.0)

    def as_record(self) -> dict:
        return {"shape": self.shape, "aperture": self.aperture, "ior": self.ior,
                "radius_mm": self.radius, "conic_constant": self.conic, "focal_mm": self.focal,
                "aperture_radius_mm": self.aperture_radius, "thickness_mm": self.thickness,
                "corner_sag_mm": self.corner_sag, "tir_height_mm": (None if math.isinf(self.tir_height)
                                                                    else self.tir_height)}
