"""The lens grid of a camera (``grid.json``): lattice, distortion, lens table.

A grid says where every micro-lens of a holoscopic capture sits.  Lens
``(i, j)`` (row ``i`` top to bottom, column ``j`` left to right, as in
docs/geometry.md) has its ideal centre

- square: ``origin + j a1 + i a2``
- hex:    ``origin + (j + (i mod 2) / 2) a1 + i r``, ``r = a2 - a1 / 2``
  (odd rows shifted right by half a pitch, as in docs/geometry.md),

and is recorded at ``distortion.distort(ideal)``.  ``a1`` runs along a lens row
(the lattice vector nearest image ``+x``), ``a2`` is ``a1`` turned by 90 (square)
or 60 (hex) degrees toward image ``+y`` (down).  All positions are ``(x, y)``
image pixels, ``0, 0`` the centre of the top-left pixel.
"""

from __future__ import annotations

from .. import jsontext
import json
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import ConfigError, InputError
from ..image.io import atomic_path
from .distortion import Brown

LATTICES = ("square", "hex")


def nearest_lattice(q: np.ndarray, basis: np.ndarray, lattice: str) -> np.ndarray:
    """Integer lattice coordinates ``(..., 2)`` of the lattice point nearest each ``q`` (lattice units).

    ``basis`` rows are the lattice vectors (px), which decide "nearest" for hex.
    """
    if lattice == "square":
        return np.round(q)
    # Hex: the nearest point is one of the four corners of the enclosing rhombus.
    base = np.floor(q)
    best = base
    best_d = None
    for dm in (0.0, 1.0):
        for dn in (0.0, 1.0):
            cand = base + np.array([dm, dn])
            r = q - cand
            v = r[..., 0:1] * basis[0] + r[..., 1:2] * basis[1]
            d = np.sum(v * v, axis=-1)
            if best_d is None:
                best, best_d = cand, d
            else:
                closer = d < best_d
                best = np.where(closer[..., None], cand, best)
                best_d = np.where(closer, d, best_d)
    return best
KIND = "povh3d-lens-grid"


@dataclass(frozen=True, eq=False)
class Grid:
    """A calibrated lens grid.

    Parameters
    ----------
    lattice : {'square', 'hex'}
    image_size : (int, int)
        ``(W, H)`` of the image the grid belongs to, px.
    basis : (2, 2) float, px
        Rows ``a1``, ``a2`` (ideal frame).
    origin : (2,) float, px
        Ideal centre of lens ``(0, 0)``.
    table : (int, int)
        ``(rows, cols)`` of the lens table; lenses of the table whose centre is
        outside the image are not listed in ``centers_px``.
    distortion : Brown
    residual_px : float
        RMS distance of the measured lens centres from the fitted grid.
    confidence : float
        0 (no trust) to 1, see :func:`povh3d.calibration.lattice.calibrate`.
    template : (K, K) float or None
        White micro-image (the lens's response, peak 1) sampled every
        ``template_step`` px around a lens centre; drives border correction.
    gain : (rows, cols) float or None
        White level of each lens (vignetting), peak of its micro-image.
    """

    lattice: str
    image_size: tuple[int, int]
    basis: np.ndarray
    origin: np.ndarray
    table: tuple[int, int]
    distortion: Brown
    residual_px: float = 0.0
    confidence: float = 1.0
    template: np.ndarray | None = None
    template_step: float = 0.25
    gain: np.ndarray | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.lattice not in LATTICES:
            raise ConfigError(f"lattice must be one of {', '.join(LATTICES)}, got {self.lattice!r}")
        basis = np.asarray(self.basis, dtype=np.float64)
        origin = np.asarray(self.origin, dtype=np.float64)
        if basis.shape != (2, 2) or not np.all(np.isfinite(basis)) or abs(np.linalg.det(basis)) < 1e-6:
            raise ConfigError(f"grid basis must be two independent 2D vectors, got {basis.tolist()}")
        if origin.shape != (2,) or not np.all(np.isfinite(origin)):
            raise ConfigError(f"grid origin must be (x, y), got {origin.tolist()}")
        rows, cols = (int(v) for v in self.table)
        if rows < 1 or cols < 1:
            raise ConfigError(f"the lens table must hold at least one lens, got {rows}x{cols}")
        w, h = (int(v) for v in self.image_size)
        object.__setattr__(self, "basis", basis)
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "table", (rows, cols))
        object.__setattr__(self, "image_size", (w, h))
        if self.gain is not None:
            object.__setattr__(self, "gain", np.asarray(self.gain, dtype=np.float64).reshape(rows, cols))

    # -- derived values --------------------------------------------------------
    @property
    def a1(self) -> np.ndarray:
        return self.basis[0]

    @property
    def a2(self) -> np.ndarray:
        return self.basis[1]

    @property
    def row_step(self) -> np.ndarray:
        """Ideal displacement from one lens row to the next (px)."""
        return self.a2 if self.lattice == "square" else self.a2 - self.a1 / 2

    @property
    def pitch_px(self) -> float:
        """Lens pitch: mean length of the two basis vectors (ideal frame, px)."""
        return float(np.mean(np.linalg.norm(self.basis, axis=1)))

    @property
    def rotation_deg(self) -> float:
        """Angle of a lens row, counter-clockwise as displayed (image ``y`` points down)."""
        return math.degrees(math.atan2(-self.a1[1], self.a1[0]))

    def ideal_centres(self, rows: np.ndarray | None = None, cols: np.ndarray | None = None) -> np.ndarray:
        """Ideal centres of lenses ``(rows, cols)`` (broadcast), or of the whole table ``(rows, cols, 2)``."""
        if rows is None or cols is None:
            rows, cols = np.meshgrid(np.arange(self.table[0]), np.arange(self.table[1]), indexing="ij")
        i = np.asarray(rows, dtype=np.float64)
        j = np.asarray(cols, dtype=np.float64)
        if self.lattice == "hex":
            j = j + 0.5 * (np.asarray(rows) % 2)
        return self.origin + j[..., None] * self.a1 + i[..., None] * self.row_step

    @cached_property
    def centres(self) -> np.ndarray:
        """Recorded centre of every lens of the table, ``(rows, cols, 2)`` px."""
        return self.distortion.distort(self.ideal_centres())

    @cached_property
    def inside(self) -> np.ndarray:
        """``(rows, cols)`` bool: the lens centre lies on the image."""
        w, h = self.image_size
        c = self.centres
        return (c[..., 0] >= -0.5) & (c[..., 0] <= w - 0.5) & (c[..., 1] >= -0.5) & (c[..., 1] <= h - 0.5)

    @cached_property
    def complete(self) -> np.ndarray:
        """``(rows, cols)`` bool: the lens's whole micro-image lies on the image."""
        w, h = self.image_size
        c = self.centres
        # The cell reaches at most half a pitch (square: times sqrt 2; hex: 2/sqrt 3) from its centre.
        reach = self.pitch_px * (math.sqrt(0.5) if self.lattice == "square" else 1 / math.sqrt(3))
        reach *= max(1.0, float(np.max(np.abs(self.local_scale()))))
        return ((c[..., 0] - reach >= -0.5) & (c[..., 0] + reach <= w - 0.5)
                & (c[..., 1] - reach >= -0.5) & (c[..., 1] + reach <= h - 0.5))

    def local_scale(self) -> np.ndarray:
        """Radial magnification of the distortion at every lens, ``(rows, cols)`` (1 = none)."""
        d = self.distortion
        u = self.ideal_centres() - d.centre
        rho2 = np.sum(u * u, axis=-1) / d.scale**2
        return 1 + 3 * d.k1 * rho2 + 5 * d.k2 * rho2 * rho2

    def local_jacobian(self, points: np.ndarray, eps: float = 0.5) -> np.ndarray:
        """``d distort / d ideal`` at ideal ``points`` ``(..., 2)`` -> ``(..., 2, 2)`` (central differences)."""
        ex = np.array([eps, 0.0])
        ey = np.array([0.0, eps])
        d = self.distortion
        jx = (d.distort(points + ex) - d.distort(points - ex)) / (2 * eps)
        jy = (d.distort(points + ey) - d.distort(points - ey)) / (2 * eps)
        return np.stack([jx, jy], axis=-1)

    def lens_of_pixels(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The lens each recorded position ``(..., 2)`` belongs to (its Voronoi cell in the ideal frame).

        Returns table row ``i``, column ``j`` (may fall outside the table) and the
        lens's recorded centre ``(..., 2)`` px.
        """
        ideal = self.distortion.undistort(points) if not self.distortion.is_identity else np.asarray(points, float)
        q = (ideal - self.origin) @ np.linalg.inv(self.basis)  # axial lattice coordinates
        mn = nearest_lattice(q, self.basis, self.lattice)
        centre = self.distortion.distort(self.origin + mn @ self.basis)
        m = mn[..., 0].astype(np.int64)
        n = mn[..., 1].astype(np.int64)
        # Hex: axial (m, n) -> docs/geometry.md offset rows, j = m + floor(i / 2).
        return n, (m if self.lattice == "square" else m + n // 2), centre

    def check_image(self, shape: tuple[int, ...], name: str = "the image") -> None:
        """InputError unless an image of ``shape`` ``(H, W, ...)`` is the size this grid was made for."""
        h, w = shape[:2]
        if (w, h) != tuple(self.image_size):
            raise InputError(f"{name} is {w}x{h} pixels but the grid was calibrated on a "
                             f"{self.image_size[0]}x{self.image_size[1]} image; calibrate with a white image "
                             "taken by the same camera at the same size")

    # -- JSON ------------------------------------------------------------------
    def as_record(self) -> dict[str, Any]:
        inside = self.inside
        rc = np.argwhere(inside)
        record: dict[str, Any] = {
            "kind": KIND, "povh3d_version": __version__,
            "lattice": self.lattice, "pitch_px": self.pitch_px, "rotation_deg": self.rotation_deg,
            "residual_px": float(self.residual_px), "confidence": float(self.confidence),
            "image_size": list(self.image_size), "table": list(self.table),
            "basis_px": self.basis.tolist(), "origin_px": self.origin.tolist(),
            "distortion": self.distortion.as_record(),
            "lens_count": int(inside.sum()),
            "centers_px": np.round(self.centres[inside], 6).tolist(),
            "lens_rc": rc.tolist(),
            **self.extra,
        }
        if self.gain is not None:
            record["gain"] = np.round(self.gain, 6).tolist()
        if self.template is not None:
            record["template"] = {"step_px": self.template_step,
                                  "values": np.round(self.template, 5).tolist()}
        return record

    @classmethod
    def from_dict(cls, record: dict[str, Any], source: str = "grid") -> Grid:
        if not isinstance(record, dict) or record.get("kind") != KIND:
            raise InputError(f"{source} is not a povh3d lens grid (no \"kind\": \"{KIND}\"); "
                             "make one with 'povh3d calibrate WHITE.png -o grid.json'")
        try:
            template = record.get("template")
            return cls(
                lattice=record["lattice"], image_size=tuple(record["image_size"]),
                basis=np.array(record["basis_px"], dtype=float), origin=np.array(record["origin_px"], dtype=float),
                table=tuple(record["table"]), distortion=Brown.from_dict(record["distortion"]),
                residual_px=float(record.get("residual_px", 0.0)), confidence=float(record.get("confidence", 1.0)),
                template=None if template is None else np.array(template["values"], dtype=float),
                template_step=0.25 if template is None else float(template["step_px"]),
                gain=None if record.get("gain") is None else np.array(record["gain"], dtype=float),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{source} is damaged ({type(exc).__name__}: {exc}); calibrate again") from None


def write_grid(path: str | Path, grid: Grid) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(grid.as_record()) + "\n", encoding="utf-8")


def read_grid(path: str | Path) -> Grid:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"grid file {str(path)!r} does not exist; make one with 'povh3d calibrate WHITE.png -o grid.json'")
    try:
        record = jsontext.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read grid file {str(path)!r}: {exc}") from None
    return Grid.from_dict(record, repr(str(path)))
