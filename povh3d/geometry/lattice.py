"""General lattices given by two lattice vectors (docs/geometry.md, "General lattices"),
and the cross-lenticular sheet of the thesis's section 5.3 as one of them.

Pure: vectors in, vectors and numbers out; ``lens_array.LensArray`` holds them.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError, param

# Lattice vectors closer than this to parallel (degrees between them) are a typing
# error, not a lens sheet: their cells would be slivers.
MIN_LATTICE_ANGLE_DEG = 10.0


def lattice_vectors(basis) -> tuple[np.ndarray, np.ndarray]:
    """Two lattice vectors checked and oriented: ``a1`` pointing right (or up), ``det(a1, a2) > 0``.

    Negating either vector gives the same (centred) lattice, so this only fixes
    which way the indices count: columns ``j`` along ``a1``, rows ``i`` against ``a2``.
    """
    try:
        a = np.array(basis, dtype=np.float64)
    except (TypeError, ValueError):
        a = np.full(1, np.nan)
    if a.shape != (2, 2) or not np.isfinite(a).all():
        raise ConfigError(f"a lattice is two vectors of two numbers (mm), e.g. {param('lattice')} '0.6,0;0.1,0.6', got {basis!r}")
    a1, a2 = a
    if not all(1e-9 <= float(np.hypot(*v)) <= 1e9 for v in (a1, a2)):
        raise ConfigError(f"lattice vectors must be between 1e-9 and 1e9 mm long, got {basis!r}; give them in mm")
    if a1[0] < 0 or (a1[0] == 0 and a1[1] < 0):
        a1 = -a1
    det = a1[0] * a2[1] - a1[1] * a2[0]
    angle = math.degrees(math.asin(min(1.0, abs(det) / (np.hypot(*a1) * np.hypot(*a2)))))
    if angle < MIN_LATTICE_ANGLE_DEG:
        raise ConfigError(f"the lattice vectors are {angle:.3g} deg from parallel (at least {MIN_LATTICE_ANGLE_DEG:g} "
                          f"needed): their cells would be slivers; check {param('lattice')}")
    return a1, (a2 if det > 0 else -a2)


def cell_widths(a1: np.ndarray, a2: np.ndarray) -> tuple[float, float]:
    """Distances between a lattice cell's opposite edges, mm: across ``a2`` (the
    horizontal pitch) and across ``a1`` (the vertical pitch).  For a cross-lenticular
    sheet they are the two sheets' own pitches."""
    area = abs(float(a1[0] * a2[1] - a1[1] * a2[0]))
    return area / float(np.hypot(*a2)), area / float(np.hypot(*a1))


def cross_lenticular_basis(pitch_v: float, pitch_h: float, slant_deg: float,
                           turn_deg: float = 0.0) -> tuple[tuple[float, float], tuple[float, float]]:
    """Lattice vectors of two crossed lenticular sheets (docs/geometry.md, "Cross-lenticular sheets").

    A vertical sheet of pitch ``pitch_v`` and a horizontal one of pitch ``pitch_h``
    whose lenticules are slanted ``slant_deg`` counter-clockwise (thesis 5.3: 6.34);
    the whole pair turned by ``turn_deg``.  The cells where a vertical strip and a
    slanted strip overlap are the parallelograms spanned by
    ``a1 = pitch_v (1, tan slant)`` (one vertical strip on, along the slanted axis) and
    ``a2 = (0, pitch_h / cos slant)`` (one slanted strip up, along the vertical axis).
    """
    if not -45 < slant_deg <= 45 or not -45 < turn_deg <= 45:
        raise ConfigError(f"a cross-lenticular slant and turn must be within (-45, 45] deg, got {slant_deg}, {turn_deg}")
    t = math.radians(slant_deg)
    a1, a2 = np.array([pitch_v, pitch_v * math.tan(t)]), np.array([0.0, pitch_h / math.cos(t)])
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    turn = np.array([[c, -s], [s, c]])
    (x1, y1), (x2, y2) = turn @ a1, turn @ a2
    return (float(x1), float(y1)), (float(x2), float(y2))


def lattice_coordinates(a1: np.ndarray, a2: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Panel points (mm) as ``(s, t)`` with ``(x, y) = s a1 + t a2``."""
    det = a1[0] * a2[1] - a1[1] * a2[0]
    return (a2[1] * x - a2[0] * y) / det, (a1[0] * y - a1[1] * x) / det
