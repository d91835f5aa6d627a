"""How a volume faces the viewer: LPS patient space -> display coordinates.

Display coordinates (docs/geometry.md) are POV-Ray's: ``x`` right on the screen,
``y`` up, ``z`` away from the viewer, who is at ``-z``.  It is a left-handed
set of axes, LPS a right-handed one, so a map that keeps the patient unmirrored
has determinant -1 in coordinates.  Each preset is the view a radiologist
reads, with the viewer's right ``= forward x up`` in LPS (a real turn of the
head, not a mirror):

- ``coronal``: viewer in front of the patient (anterior), head up: the
  patient's left on the screen's right (radiological convention).
- ``axial``: viewer at the feet looking towards the head, anterior up: the
  patient's left on the screen's right (radiological convention).
- ``sagittal``: viewer at the patient's left looking right, head up:
  anterior on the screen's left.

``--rotate X,Y,Z`` then turns the result as POV-Ray's ``rotate`` would.  Pure NumPy.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ConfigError, param

# (forward, up) in LPS for each preset; rows of the matrix are (right, up, forward).
_VIEWS = {
    "coronal": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "axial": ((0.0, 0.0, 1.0), (0.0, -1.0, 0.0)),
    "sagittal": ((-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
}
ORIENTATIONS = tuple(_VIEWS)


def lps_to_display(orientation: str) -> np.ndarray:
    """(3, 3) matrix ``R``: display coordinates = ``R @ lps`` (rows: the screen's right, up, away)."""
    if orientation not in _VIEWS:
        raise ConfigError(f"{param('orientation')} must be one of {', '.join(ORIENTATIONS)}, got {orientation!r}")
    forward, up = (np.asarray(v) for v in _VIEWS[orientation])
    return np.array([np.cross(forward, up), up, forward])


def pov_rotation(degrees: Any) -> np.ndarray:
    """POV-Ray's ``rotate <x, y, z>`` (about x, then y, then z) as a matrix on column vectors."""
    from ..mesh.orient import rotation

    return rotation(degrees).T


def volume_to_display(orientation: str, rotate: Any = None) -> np.ndarray:
    """(3, 3): display direction of an LPS direction, preset then ``rotate``."""
    m = lps_to_display(orientation)
    return m if rotate is None else pov_rotation(rotate) @ m


def display_box(corners: np.ndarray, matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The axis-aligned box (lo, hi), display axes, mm, of world ``corners`` turned by ``matrix``."""
    turned = np.asarray(corners, dtype=np.float64) @ np.asarray(matrix, dtype=np.float64).T
    return turned.min(axis=0), turned.max(axis=0)


def world_to_display(matrix: np.ndarray, shift: Any, scale: float) -> np.ndarray:
    """(4, 4): display mm = ``scale * (matrix @ world + shift)`` (``shift``, ``scale``: geometry.fit.Fit)."""
    m = np.eye(4)
    m[:3, :3] = scale * np.asarray(matrix, dtype=np.float64)
    m[:3, 3] = scale * np.asarray(shift, dtype=np.float64)
    return m
