"""Brown radial distortion (thesis section 4.2) and undistorting an image with it.

The model maps an *ideal* (undistorted) image position ``u`` to where the camera
actually records it::

    x = c + (u - c) * (1 + k1 rho^2 + k2 rho^4),   rho = |u - c| / scale

with ``c`` the distortion centre (the image centre) and ``scale`` the half
diagonal, so ``k1``, ``k2`` are dimensionless and comparable between image sizes.
``k1 < 0`` is barrel, ``k1 > 0`` pincushion.  Positions are ``(x, y)`` image
pixels, ``0, 0`` the centre of the top-left pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import ConfigError
from ..image.colour import from_linear, to_linear


MAX_SCALE_PX = 1e9  # a half diagonal far beyond any image a panel holds (2^30 pixels at most)


@dataclass(frozen=True)
class Brown:
    """Radial Brown model of one image size.

    Parameters
    ----------
    k1, k2 : float
        Radial coefficients (dimensionless, ``rho`` in half diagonals).
    centre : (float, float), px
        Distortion centre ``(x, y)``.
    scale : float, px
        Radius that ``rho = 1`` stands for (the half diagonal).
    """

    k1: float
    k2: float
    centre: tuple[float, float]
    scale: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.k1) and np.isfinite(self.k2)):
            raise ConfigError(f"distortion coefficients must be finite, got k1={self.k1!r}, k2={self.k2!r}")
        # The half diagonal of an image: a damaged grid file's 1e308 overflowed scale**2 (an internal error).
        if not (np.isfinite(self.scale) and 0 < self.scale <= MAX_SCALE_PX):
            raise ConfigError(f"distortion scale must be a positive number of pixels up to {MAX_SCALE_PX:g}, "
                              f"got {self.scale!r}")
        object.__setattr__(self, "centre", (float(self.centre[0]), float(self.centre[1])))
        if not np.all(np.isfinite(self.centre)):
            raise ConfigError(f"distortion centre must be finite, got {self.centre!r}")

    @classmethod
    def for_image(cls, width: int, height: int, k1: float = 0.0, k2: float = 0.0) -> Brown:
        """The model centred on a ``width x height`` image, ``rho = 1`` at its corners."""
        return cls(float(k1), float(k2), ((width - 1) / 2, (height - 1) / 2), 0.5 * float(np.hypot(width, height)))

    @property
    def is_identity(self) -> bool:
        return self.k1 == 0.0 and self.k2 == 0.0

    def _factor(self, rho2: np.ndarray) -> np.ndarray:
        return 1.0 + self.k1 * rho2 + self.k2 * rho2 * rho2

    def distort(self, points: np.ndarray) -> np.ndarray:
        """Ideal ``(..., 2)`` positions (px) -> recorded positions (px)."""
        p = np.asarray(points, dtype=np.float64)
        d = p - self.centre
        rho2 = np.sum(d * d, axis=-1, keepdims=True) / self.scale**2
        return self.centre + d * self._factor(rho2)

    def undistort(self, points: np.ndarray, iterations: int = 8) -> np.ndarray:
        """Recorded ``(..., 2)`` positions (px) -> ideal positions (px).

        Newton's method on the radius, which the model maps monotonically while
        ``1 + 3 k1 rho^2 + 5 k2 rho^4 > 0`` (every sane lens inside the image).
        """
        p = np.asarray(points, dtype=np.float64)
        d = p - self.centre
        rd = np.sqrt(np.sum(d * d, axis=-1, keepdims=True)) / self.scale
        ru = rd.copy()
        for _ in range(iterations):
            r2 = ru * ru
            f = ru * self._factor(r2) - rd
            df = 1.0 + 3 * self.k1 * r2 + 5 * self.k2 * r2 * r2
            ru = ru - f / df
        ratio = np.divide(ru, rd, out=np.ones_like(rd), where=rd > 0)
        return self.centre + d * ratio

    def as_record(self) -> dict:
        return {"model": "brown-radial", "k1": self.k1, "k2": self.k2,
                "centre_px": list(self.centre), "scale_px": self.scale}

    @classmethod
    def from_dict(cls, record: dict) -> Brown:
        return cls(float(record["k1"]), float(record["k2"]), tuple(record["centre_px"]), float(record["scale_px"]))


def sample(image: np.ndarray, xy: np.ndarray, *, order: int = 1) -> np.ndarray:
    """Interpolate ``image`` ``(H, W[, C])`` at positions ``xy`` ``(..., 2)`` px; 0 outside.

    The one resampler of the calibration package (undistort, rectify, stitch).
    """
    img = np.asarray(image, dtype=np.float64)
    coords = np.stack([xy[..., 1], xy[..., 0]])  # map_coordinates takes rows, cols
    if img.ndim == 2:
        return ndimage.map_coordinates(img, coords, order=order, mode="constant", cval=0.0, prefilter=order > 1)
    return np.stack([ndimage.map_coordinates(img[..., ch], coords, order=order, mode="constant", cval=0.0,
                                             prefilter=order > 1) for ch in range(img.shape[2])], axis=-1)


def undistort_image(image: np.ndarray, model: Brown) -> np.ndarray:
    """The image as an ideal camera would have recorded it (same size and dtype).

    Output pixel ``u`` takes the input at ``model.distort(u)`` (bilinear, in
    linear light for 8/16-bit sRGB images, docs/geometry.md "Files"); positions
    that fall outside the input become black.
    """
    h, w = image.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    src = model.distort(np.stack([xx, yy], axis=-1))
    lin, dtype = to_linear(image), image.dtype
    return from_linear(sample(lin, src), dtype)
