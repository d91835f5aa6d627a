"""A volume: voxel values on a regular grid placed in physical space (mm).

Every reader returns a ``Volume``; everything after reading (surfaces, media,
fitting, the set-up picture) works from it, whatever the file format was.

Physical (world) coordinates are the patient frame of DICOM, **LPS**: ``+x``
towards the patient's left, ``+y`` posterior, ``+z`` superior (head), in mm.
Readers of RAS formats (NIfTI) convert to LPS.  Formats with no patient frame
(a plain ``.vti``, ``.npy``) are taken as LPS as they are.

Voxel ``(i, j, k)`` (``values[i, j, k]``, ``i`` fastest in VTK's order: x) has
its centre at ``origin + direction @ (spacing * (i, j, k))``: the columns of
``direction`` are the world directions of the grid's i, j and k axes (DICOM's
and ITK's convention).  Pure NumPy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ConfigError, param


@dataclass(frozen=True, eq=False)
class Volume:
    """Voxel values with their place in LPS space.

    Attributes
    ----------
    values : (ni, nj, nk) array     one scalar per voxel (labels: integers)
    spacing : (3,) float, mm        voxel size along i, j, k
    origin : (3,) float, mm         world position of voxel (0, 0, 0)'s centre
    direction : (3, 3) float        columns: world directions of the i, j, k axes (orthonormal)
    name : str                      what to call it in messages and records (the file's name)
    label_names : mapping           label value -> tissue name, when the file has a label table
    label_colours : mapping         label value -> (r, g, b) in 0..1 (sRGB), when the table has colours
    """

    values: np.ndarray
    spacing: tuple[float, float, float]
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    direction: np.ndarray = field(default_factory=lambda: np.eye(3))
    name: str = "volume"
    label_names: dict[int, str] = field(default_factory=dict)
    label_colours: dict[int, tuple[float, float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.values.ndim != 3 or min(self.values.shape) < 1:
            raise ConfigError(f"{self.name}: a volume needs three dimensions, got shape {self.values.shape}")
        s = np.asarray(self.spacing, dtype=np.float64)
        if s.shape != (3,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise ConfigError(f"{self.name}: voxel spacing must be three positive mm values, got "
                              f"{self.spacing!r}; give {param('spacing')} SX,SY,SZ")
        d = np.asarray(self.direction, dtype=np.float64)
        if d.shape != (3, 3) or not np.allclose(d.T @ d, np.eye(3), atol=1e-4):
            raise ConfigError(f"{self.name}: the volume's direction matrix is not a rotation or reflection")

    @property
    def shape(self) -> tuple[int, int, int]:
        nx, ny, nz = self.values.shape  # three: __post_init__ checks
        return int(nx), int(ny), int(nz)

    def index_to_world(self) -> np.ndarray:
        """(4, 4) matrix: world (mm, LPS) = M @ (i, j, k, 1)."""
        m = np.eye(4)
        m[:3, :3] = np.asarray(self.direction, dtype=np.float64) * np.asarray(self.spacing, dtype=np.float64)
        m[:3, 3] = self.origin
        return m

    def corners(self) -> np.ndarray:
        """(8, 3) world corners of the physical box: voxel centres +- half a voxel (the box POV-Ray's
        ``density_file`` fills and the surfaces lie within)."""
        n = np.asarray(self.shape, dtype=np.float64)
        lo, hi = -0.5 * np.ones(3), n - 0.5
        idx = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        return (idx @ self.index_to_world().T)[:, :3]

    def value_range(self) -> tuple[float, float]:
        return float(np.nanmin(self.values)), float(np.nanmax(self.values))

    def labels(self) -> list[int]:
        """The label values present (0, the background, left out)."""
        return present_labels(self.values)

    def as_record(self) -> dict[str, Any]:
        lo, hi = self.value_range()
        return {"name": self.name, "shape": list(self.shape), "spacing_mm": [float(s) for s in self.spacing],
                "origin_mm": [float(o) for o in self.origin],
                "direction": np.asarray(self.direction, dtype=float).round(9).tolist(),
                "dtype": str(self.values.dtype), "range": [lo, hi]}


def present_labels(values: np.ndarray) -> list[int]:
    """The values present in ``values``, ascending, without the background 0.

    Non-negative integers up to 65,535 are marked in a table of that length, one scatter over
    the voxels in their own memory order (a 32-million-voxel label map: 3x faster than
    ``np.unique``, which sorts a copy); other values go through ``np.unique``."""
    if np.issubdtype(values.dtype, np.integer) and values.size:
        lo, hi = int(values.min()), int(values.max())
        if lo >= 0 and hi < 1 << 16:
            seen = np.zeros(hi + 1, dtype=bool)
            seen[values.ravel(order="K")] = True
            return [int(v) for v in np.flatnonzero(seen) if v]
    return [int(v) for v in np.unique(values) if v != 0]
