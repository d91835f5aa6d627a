"""Which way up a model is, and turning it so its front faces the viewer with its up along ``+y``.

The loader (``load.py``) takes every format as right-handed ``+y`` up with the
viewer on ``+z`` (glTF's convention and OBJ's habit) and maps it into POV-Ray's
frame by negating ``z``.  Many STL and PLY files come from CAD or scanning
tools that are ``+z`` up with the viewer on ``-y`` (the front view), and 3MF is
``+z`` up by its specification.  ``reorient`` turns parts already in POV-Ray's
frame (as the loader made them) into the frame of another up axis:

- model up ``u`` becomes POV-Ray ``+y``;
- the model's "toward the viewer" ``t`` (``+z`` for a ``y`` up, ``-y`` for a
  ``z`` up, ``+z`` for an ``x`` up) becomes POV-Ray ``-z`` (the viewer's side);
- its right ``u x t`` becomes POV-Ray ``+x``.

This is a rotation of the loader's result (a proper one: no winding change).
``--rotate X,Y,Z`` then turns the model in degrees as POV-Ray's ``rotate``
would (about ``x``, then ``y``, then ``z``).  Pure NumPy.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ..errors import ConfigError, param

UPS = ("x", "y", "z", "-x", "-y", "-z")
_AXES = {"x": np.array([1.0, 0, 0]), "y": np.array([0.0, 1, 0]), "z": np.array([0.0, 0, 1])}
#: Formats whose specification fixes the up axis; the rest are detected.
FORMAT_UP = {".gltf": "y", ".glb": "y", ".obj": "y", ".3mf": "z"}


def _axis(name: str) -> np.ndarray:
    if name not in UPS:
        raise ConfigError(f"{param('up')} must be one of {', '.join(UPS)}, got {name!r}")
    return -_AXES[name[1:]] if name.startswith("-") else _AXES[name]


def model_to_pov(up: str) -> np.ndarray:
    """(3, 3) rows ``right, up, away``: POV-Ray coordinates = model coordinates @ this.T."""
    u = _axis(up)
    toward = np.array([0.0, -1, 0]) * np.sign(u[2]) if u[2] else np.array([0.0, 0, 1])
    right = np.cross(u, toward)
    return np.array([right, u, -toward])


def rotation(degrees: Any) -> np.ndarray:
    """POV-Ray's ``rotate <x, y, z>`` as a (3, 3) matrix on row vectors (``p @ R``)."""
    ax, ay, az = np.radians(np.asarray(degrees, dtype=np.float64))
    rx = np.array([[1, 0, 0], [0, np.cos(ax), np.sin(ax)], [0, -np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, -np.sin(ay)], [0, 1, 0], [np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), np.sin(az), 0], [-np.sin(az), np.cos(az), 0], [0, 0, 1]])
    return rx @ ry @ rz


def reorient(parts: list, up: str, rotate: Any = None) -> list:
    """Parts in POV-Ray's frame as the loader made them (``y`` up) -> ``up`` up, then ``rotate``."""
    # Loader: pov = model * (1, 1, -1).  Wanted: pov' = model @ M.T; so pov' = pov @ diag(1,1,-1) @ M.T.
    m = np.diag([1.0, 1.0, -1.0]) @ model_to_pov(up).T
    if rotate is not None:
        m = m @ rotation(rotate)
    if np.allclose(m, np.eye(3), atol=0):
        return parts
    out = []
    for p in parts:
        normals = None if p.normals is None else p.normals @ m
        out.append(dataclasses.replace(p, vertices=p.vertices @ m + 0.0, normals=normals))
    return out


def detect_up(suffix: str, lo: np.ndarray, hi: np.ndarray) -> tuple[str, str]:
    """The up axis to take for a model (before ``reorient``) and why.

    ``lo``/``hi`` are the model's box in the loader's frame (``y`` up, ``z`` negated).
    glTF, OBJ: ``y`` (the format's convention); 3MF: ``z`` (its specification).
    STL, PLY, OFF: ``z`` when the model stands on the plane ``z = 0`` of its file
    (a CAD part on its build plate: the file's minimum ``z``, the loader's
    maximum ``z``, is 0) and not on ``y = 0``; else ``y``.
    """
    suffix = suffix.lower()
    if suffix in FORMAT_UP:
        return FORMAT_UP[suffix], f"the {suffix} convention"
    extent = float(np.max(hi - lo)) or 1.0
    on_z = abs(float(hi[2])) <= 1e-6 * extent      # file min z = -(loader max z)
    on_y = abs(float(lo[1])) <= 1e-6 * extent
    if on_z and not on_y:
        return "z", "detected: the model stands on z = 0, as CAD exports do"
    return "y", f"the default for this format (no build plate at z = 0 found); {param('up')} z turns a z-up model"
