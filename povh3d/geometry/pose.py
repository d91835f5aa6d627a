"""The display's pose: where the display sits in a scene modelled in its own units.

Display coordinates are those of docs/geometry.md: millimetres, the screen
at ``z = 0``, ``x`` right, ``y`` up, the viewer on ``-z``.  A ``DisplayPose``
is a rigid placement plus a uniform scale that maps it into scene units:

    p_scene = centre + units_per_mm * (x * axis_x + y * axis_y + z * axis_z)

povh3d moves its cameras (and the single-stage lens array) into the scene by
this map, never the scene into the cameras, so a scene is used as it is,
whatever it keeps at top level (``global_settings``, ``camera``, ``sky_sphere``).
The axes are orthonormal; ``axis_z`` (the display normal) points away from the
viewer, into the scene.  A pose whose axes are left-handed in POV-Ray's sense
(a scene camera with a negative ``right``, the right-handed convention) is a
mirror placement; it is allowed and recorded.

Pure: no files, no processes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ConfigError, param

#: The options a user can set instead of a pose povh3d cannot work out.
EXPLICIT_OPTIONS = f"{param('placement.center')} X,Y,Z {param('placement.normal')} X,Y,Z [{param('placement.up')} X,Y,Z] {param('placement.width')} UNITS"


def _vec(value: Any, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ConfigError(f"{name} must be three finite numbers X,Y,Z, got {value!r}")
    return v


@dataclass(frozen=True)
class DisplayPose:
    """A placement of the display in scene units (see the module docstring).

    Attributes
    ----------
    centre : (3,) float, scene units    where the display centre (x = y = z = 0) is
    axis_x, axis_y, axis_z : (3,) float  orthonormal unit vectors in scene coordinates
    units_per_mm : float                 scene units per display millimetre (> 0)
    source : str                         where it came from: 'native', 'camera', 'explicit'
    note : str                           how it was worked out, for the sidecar
    camera_distance : float or None      a camera pose's scene camera, how far from the centre
                                         (scene units); what lies behind it is no part of the view
    """

    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis_x: tuple[float, float, float] = (1.0, 0.0, 0.0)
    axis_y: tuple[float, float, float] = (0.0, 1.0, 0.0)
    axis_z: tuple[float, float, float] = (0.0, 0.0, 1.0)
    units_per_mm: float = 1.0
    source: str = "native"
    note: str = ""
    camera_distance: float | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        axes = np.array([_vec(a, f"the pose's {n}") for a, n in
                         ((self.axis_x, "x axis"), (self.axis_y, "y axis"), (self.axis_z, "normal"))])
        _vec(self.centre, "the display centre")
        if not np.allclose(axes @ axes.T, np.eye(3), atol=1e-9):
            raise ConfigError("the display's axes must be orthonormal; give a normal and an up "
                              "that are not parallel")
        if not (math.isfinite(self.units_per_mm) and self.units_per_mm > 0):
            raise ConfigError(f"the display width must be a positive number of scene units "
                              f"(units per mm {self.units_per_mm!r}); use {EXPLICIT_OPTIONS}")
        for name in ("centre", "axis_x", "axis_y", "axis_z"):
            object.__setattr__(self, name, tuple(float(v) for v in getattr(self, name)))
        object.__setattr__(self, "units_per_mm", float(self.units_per_mm))

    @property
    def is_native(self) -> bool:
        """Whether the pose is the identity (scene in mm around z = 0): nothing to write."""
        return (self.centre == (0.0, 0.0, 0.0) and self.units_per_mm == 1.0 and self.axis_x == (1.0, 0.0, 0.0)
                and self.axis_y == (0.0, 1.0, 0.0) and self.axis_z == (0.0, 0.0, 1.0))

    @property
    def mirrored(self) -> bool:
        """Whether the axes are a mirror image of POV-Ray's (x, y, z)."""
        return bool(np.linalg.det(np.array([self.axis_x, self.axis_y, self.axis_z])) < 0)

    def matrix(self) -> np.ndarray:
        """(4, 3) rows of POV-Ray's ``matrix <...>``: s x-axis, s y-axis, s normal, centre."""
        s = self.units_per_mm
        return np.array([np.multiply(self.axis_x, s), np.multiply(self.axis_y, s),
                         np.multiply(self.axis_z, s), self.centre], dtype=np.float64)

    def to_scene(self, points: np.ndarray) -> np.ndarray:
        """Display points (..., 3) mm -> scene points (..., 3) scene units."""
        m = self.matrix()
        return np.asarray(points, dtype=np.float64) @ m[:3] + m[3]

    def directions_to_scene(self, directions: np.ndarray) -> np.ndarray:
        """Display directions (..., 3) -> scene directions (scaled by units per mm)."""
        return np.asarray(directions, dtype=np.float64) @ self.matrix()[:3]

    def to_display(self, points: np.ndarray) -> np.ndarray:
        """Scene points (..., 3) -> display points (..., 3) mm (the inverse of ``to_scene``)."""
        axes = np.array([self.axis_x, self.axis_y, self.axis_z])
        return (np.asarray(points, dtype=np.float64) - np.asarray(self.centre)) @ axes.T / self.units_per_mm

    def scaled(self, factor: float) -> DisplayPose:
        """The same placement with ``factor`` times the units per mm (``--fit-depth``)."""
        return DisplayPose(self.centre, self.axis_x, self.axis_y, self.axis_z, self.units_per_mm * factor,
                            self.source, self.note, self.camera_distance)

    def as_record(self) -> dict[str, Any]:
        return {"source": self.source, "centre": list(self.centre), "axis_x": list(self.axis_x),
                "axis_y": list(self.axis_y), "normal": list(self.axis_z), "units_per_mm": self.units_per_mm,
                "mirrored": self.mirrored, **({"note": self.note} if self.note else {})}

    def summary(self) -> str:
        """One short phrase for the CLI's summary line."""
        if self.source == "native":
            return "placement native (mm, z = 0)"
        c = ", ".join(f"{v:.4g}" for v in self.centre)
        return f"placement {self.source} (centre {c}, {self.units_per_mm:.4g} units/mm)"


NATIVE = DisplayPose()


#: Within this angle (degrees) of the scene's y axis the default up turns fast with the normal:
#: ``up_warning`` asks for a ``--display-up`` there.
UP_WARNING_DEG = 10.0


def default_up(normal: Any) -> np.ndarray:
    """The display's up when none is given: the scene's ``+y`` projected onto the display.

    One rule for every normal, with no threshold: the display's ``x`` is horizontal
    (across the scene's ``y``), and turning the normal turns the image continuously,
    as a viewer tilting their head would.  Only a normal along ``+-y`` itself has no
    projection; there the up is the limit reached from a display facing ``+z`` (``x``
    stays ``+x``): ``-z`` for a normal ``+y``, ``+z`` for ``-y``.
    """
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    up = np.array([0.0, 1.0, 0.0]) - n[1] * n
    if np.linalg.norm(up) > 1e-9:
        return up / np.linalg.norm(up)
    return np.array([0.0, 0.0, -1.0 if n[1] > 0 else 1.0])


def up_warning(normal: Any, up: Any = None) -> str | None:
    """A warning when the up was chosen for the user (``up`` None) and the normal lies within
    ``UP_WARNING_DEG`` of the scene's y axis, where a small turn of the normal turns the image a lot."""
    if up is not None:
        return None
    n = _vec(normal, param("placement.normal"))
    if not np.linalg.norm(n) > 0:
        return None
    angle = math.degrees(math.acos(min(1.0, abs(n[1]) / np.linalg.norm(n))))
    if angle >= UP_WARNING_DEG:
        return None
    return (f"the display normal is {angle:.3g} deg from the scene's y axis, so its default up (the scene's y "
            f"projected onto the display: {', '.join(f'{v:.3g}' for v in default_up(n))}) turns fast with the "
            f"normal; give {param('placement.up')} X,Y,Z to fix which way is up")


def explicit_pose(centre: Any, normal: Any, width: float, panel_width_mm: float, up: Any = None,
                   *, source: str = "explicit", note: str = "") -> DisplayPose:
    """The pose from a centre, a normal (away from the viewer), an up and a width in scene units.

    ``up`` defaults to ``default_up(normal)``.  The display's ``x`` is ``up x normal``
    (POV-Ray's ``right`` for a camera with ``sky`` up looking along the normal), ``y``
    completes it.
    """
    c, n = _vec(centre, param("placement.center")), _vec(normal, param("placement.normal"))
    if not np.linalg.norm(n) > 0:
        raise ConfigError(f"{param('placement.normal')} must not be zero; use {EXPLICIT_OPTIONS}")
    z = n / np.linalg.norm(n)
    if up is None:
        up = default_up(z)
    u = _vec(up, param("placement.up"))
    x = np.cross(u, z)
    if not np.linalg.norm(x) > 1e-9 * max(float(np.linalg.norm(u)), 1e-300):
        raise ConfigError(f"the display's up is parallel to its normal; give a {param('placement.up')} across the normal")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    if not (math.isfinite(width) and width > 0):
        raise ConfigError(f"{param('placement.width')} must be a positive number of scene units, got {width!r}")
    return DisplayPose(tuple(c), tuple(x), tuple(y), tuple(z), width / panel_width_mm, source, note)


def camera_pose(location: Any, direction: Any, right: Any, up: Any, look_at: Any | None,
                 panel_width_mm: float, *, note: str = "") -> DisplayPose:
    """The pose a perspective camera defines (vectors as POV-Ray computed them).

    Centre at ``look_at`` (without one: the point of the view axis nearest the
    scene origin), normal along ``direction`` (the viewer on the camera's
    side), ``x`` and ``y`` along ``right`` and ``up``, and a width equal to the
    camera's horizontal field at the centre's distance, ``d |right| / |direction|``,
    so the middle of the H3D image frames what the 2D render framed.
    """
    loc, d, r, u = (_vec(a, "camera vector") for a in (location, direction, right, up))
    if not (np.linalg.norm(d) > 0 and np.linalg.norm(r) > 0 and np.linalg.norm(u) > 0):
        raise ConfigError(f"the scene's camera has a zero direction, right or up; use {EXPLICIT_OPTIONS}")
    z = d / np.linalg.norm(d)
    if look_at is not None:
        distance = float(np.dot(_vec(look_at, "look_at") - loc, z))
    else:
        distance = float(np.dot(-loc, z))
    if not distance > 0:
        raise ConfigError(f"the scene's camera looks away from its centre (distance {distance:.4g}); "
                          f"place the display with {EXPLICIT_OPTIONS}")
    centre = _vec(look_at, "look_at") if look_at is not None else loc + distance * z
    x = r - np.dot(r, z) * z
    if not np.linalg.norm(x) > 1e-12 * np.linalg.norm(r):
        raise ConfigError(f"the scene camera's right is parallel to its direction; use {EXPLICIT_OPTIONS}")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)  # POV-Ray's up = direction x right
    if np.dot(y, u) < 0:
        y = -y  # a mirrored camera: the image's up stays up
    width = float(distance * np.linalg.norm(r) / np.linalg.norm(d))
    return DisplayPose(tuple(centre), tuple(x), tuple(y), tuple(z), width / panel_width_mm, "camera", note,
                        float(np.linalg.norm(centre - loc)))
