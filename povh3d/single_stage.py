"""Single-stage rendering through a virtual lens array: geometry and assembly.

The geometry (thesis 3.3, worked out against CONVENTIONS):

1. **Capture panel and camera.**  One orthographic camera on the viewer's side
   (z < 0, looking +z) at the panel's pixel pitch: camera pixel ``(col, row)``
   is a ray parallel to z at the panel position ``(X, Y)`` of that pixel.  It
   plays the panel (the thesis's CCD); its location only has to be in front of
   the lenses.
2. **Lenslets.**  Plano-convex, flat face toward the camera, curved face toward
   the scene (``optics.Lenslet``), at the lens centres ``c`` of CONVENTIONS.
   A camera ray at offset ``w`` from ``c`` leaves the lens through the rear focal
   point ``c + f z`` (exactly for the conic lens, paraxially for the sphere)
   with direction ``(-w, f)``.
3. **180-degree turn.**  The ray of the display pixel at offset ``u`` has
   direction ``(u, f)`` (CONVENTIONS), so it is the camera ray at ``w = -u``:
   each elemental image is turned by 180 degrees about its lens centre.  This is
   the pseudoscopic-to-orthoscopic conversion of integral imaging.
4. **Depth re-centring.**  The rays of lens ``c`` must cross the display plane
   at ``c``: the focal plane of the virtual array is the display plane, so the
   principal plane (the curved vertices) sits at ``z = -f`` and the flat faces a
   lens thickness further.  The camera then sees everything behind
   ``z = -f``.  To see objects further in front, the array moves forward by a
   depth ``D`` (focal plane at ``z = -D``); the ray of view ``(u, v)`` through
   lens ``c'`` then crosses ``z = 0`` at ``c' + (u, v) D / f``.  With whole
   pixels per lens and ``D`` a multiple of ``f * Nx`` (odd ``Nx``) or
   ``2 f Nx`` (even), that offset is a whole number of lenses for every view,
   so shifting each view by it puts every ray through its own lens centre
   again, exactly.  The array is rendered that many lenses larger on each
   side.  Hex and fractional-PPL arrays have no views to shift: ``D = 0``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from .elemental import turn_elemental_images
from .errors import ConfigError
from .geometry import LensArray, Panel
from .interleave import interleave
from .optics import Lenslet
from .render import FrameBatch

APERTURE_OF_GRID = {"square": "square", "lenticular": "lenticular", "hex": "hex"}


def lenslet_for(lens_array: LensArray, shape: str = "conic", ior: float | None = None) -> Lenslet:
    """The lenslet of ``lens_array``: its pitch, its focal length, ``shape`` and ``ior``."""
    return Lenslet(shape, APERTURE_OF_GRID[lens_array.grid], lens_array.pitch_x,
                   lens_array.pitch_y, lens_array.focal, ior)


def recentre_unit(lens_array: LensArray) -> float:
    """Smallest depth ``D`` (mm) at which every view shifts by whole lenses; 0 if none.

    ``u_k D / (f px) = (k + 0.5 - Nx/2) D / (f Nx)`` is whole for every ``k`` when
    ``D / f`` is a multiple of ``Nx`` (odd ``Nx``) or ``2 Nx`` (even); likewise
    vertically (not for lenticular sheets, whose rays keep their row).
    """
    views = lens_array.views
    if views is None:
        return 0.0
    ny, nx = views
    steps = [nx if nx % 2 else 2 * nx]
    if not lens_array.unidirectional:
        steps.append(ny if ny % 2 else 2 * ny)
    return lens_array.focal * math.lcm(*steps)


def default_depth(lens_array: LensArray) -> float:
    """Default re-centring depth: one unit (integral PPL), else 0 (see module doc)."""
    return recentre_unit(lens_array)


@dataclass(frozen=True)
class SingleStagePlan:
    """Everything the single-stage method decides before rendering.

    Attributes
    ----------
    lens_array : LensArray     the display's array (CONVENTIONS)
    lenslet : Lenslet
    depth : float, mm          ``D``: the focal plane of the virtual array is ``z = -D``
    """

    lens_array: LensArray
    lenslet: Lenslet
    depth: float = 0.0

    def __post_init__(self) -> None:
        unit = recentre_unit(self.lens_array)
        if self.depth < 0 or not math.isfinite(self.depth):
            raise ConfigError(f"the front clearance must be 0 or more mm, got {self.depth!r}")
        if self.depth > 0:
            if unit == 0.0:
                raise ConfigError(
                    "single-stage rendering through a hex or fractional-PPL array sees only what lies "
                    f"behind z = -{self.lens_array.focal:g} mm (the lenses' focal length in front of "
                    "the screen); drop --front-clearance, or use a square/lenticular array with whole "
                    "pixels per lens")
            ratio = self.depth / unit
            if abs(ratio - round(ratio)) > 1e-9:
                raise ConfigError(f"single-stage depth {self.depth!r} mm is not a multiple of {unit!r} mm")

    @classmethod
    def for_clearance(cls, lens_array: LensArray, lenslet: Lenslet, clearance: float) -> SingleStagePlan:
        """The plan whose depth is the smallest exact ``D >= clearance`` (0 for no clearance)."""
        unit = recentre_unit(lens_array)
        if clearance <= 0:
            return cls(lens_array, lenslet, 0.0)
        if unit == 0.0:
            return cls(lens_array, lenslet, clearance)  # raises the explanatory error
        return cls(lens_array, lenslet, unit * math.ceil(clearance / unit - 1e-9))

    # -- view shifts ------------------------------------------------------------
    @cached_property
    def shifts(self) -> tuple[np.ndarray, np.ndarray]:
        """Whole-lens shift of every view: ``(sx (Nx,), sy (Ny,))`` int.

        Display lens ``(j, i)``, view ``(l, k)`` takes capture lens
        ``(j + Ex - sx[k], i + Ey + sy[l])``.
        """
        la = self.lens_array
        if self.depth == 0.0:
            views = la.views or (1, 1)
            return np.zeros(views[1], np.int64), np.zeros(views[0], np.int64)
        u, v = la.view_offsets()
        sx = u * self.depth / (la.focal * la.pitch_x)
        sy = np.zeros_like(v) if la.unidirectional else v * self.depth / (la.focal * la.pitch_y)
        for s in (sx, sy):
            assert np.allclose(s, np.round(s), atol=1e-6), "depth is not an exact re-centring unit"
        return np.round(sx).astype(np.int64), np.round(sy).astype(np.int64)

    @property
    def extension(self) -> tuple[int, int]:
        """Extra capture lenses on each side, ``(Ex, Ey)``."""
        sx, sy = self.shifts
        return int(np.abs(sx).max()), int(np.abs(sy).max())

    @cached_property
    def capture_array(self) -> LensArray:
        """The virtual array rendered: the display's, ``Ex``/``Ey`` lenses larger per side."""
        la = self.lens_array
        if la.views is None:
            return la
        ny, nx = la.views
        ex, ey = self.extension
        lx, ly = la.lenses_x + 2 * ex, la.lenses_y + 2 * ey
        panel = Panel(lx * nx, ly * ny, la.panel.pitch_x, la.panel.pitch_y)
        return LensArray(la.grid, lx, ly, la.pitch_x, la.pitch_y, la.focal, panel)

    # -- the POV-Ray frame ------------------------------------------------------
    def template_context(self) -> dict[str, Any]:
        cap = self.capture_array
        lenslet = self.lenslet
        panel = cap.panel
        width_mm, height_mm = panel.size_mm
        z_vertex = -self.depth - lenslet.focal
        half_x = cap.pitch_x / 2
        if cap.grid == "lenticular":
            # One lens per column spanning every row (CONVENTIONS: v = 0).
            lenses, pitch = (cap.lenses_x, 1), (cap.pitch_x, height_mm)
            half_y = height_mm / 2 + cap.panel.pitch_y
        else:
            lenses, pitch = (cap.lenses_x, cap.lenses_y), (cap.pitch_x, cap.pitch_y)
            half_y = cap.pitch_y / 2
        hex_half_y = cap.pitch_x / math.sqrt(3)
        return {
            "aperture": lenslet.aperture, "lenslet": lenslet, "quadric": lenslet.quadric(),
            "half_x": half_x, "half_y": half_y, "hex_half_y": hex_half_y,
            "bound_half_y": hex_half_y if cap.grid == "hex" else half_y,
            "sqrt3_2": math.sqrt(3) / 2, "thickness": lenslet.thickness,
            "lenses": lenses, "pitch": pitch,
            "z_vertex": z_vertex, "z_flat": z_vertex - lenslet.thickness, "z_focus": -self.depth,
            "z_camera": z_vertex - lenslet.thickness - lenslet.focal,
            "right": (width_mm, 0.0, 0.0), "up": (0.0, height_mm, 0.0),
        }

    def batch(self) -> FrameBatch:
        panel = self.capture_array.panel
        return FrameBatch("single_stage.pov.j2", self.template_context(), [{}],
                          panel.width, panel.height, processes=1)

    # -- from the capture to the H3D image ------------------------------------------
    def assemble(self, capture: np.ndarray) -> np.ndarray:
        """Turn the elemental images and re-centre the depth.

        Parameters
        ----------
        capture : (Hc, Wc, C) array     the camera image of ``capture_array``

        Returns
        -------
        (H, W, C) array for the panel (fractional PPL / hex), or the bank region
        ``(Ly*Ny, Lx*Nx, C)`` (whole PPL; the caller pads the margin).
        """
        la = self.lens_array
        if la.views is None:
            return turn_elemental_images(capture, la)
        ny, nx = la.views
        cap = self.capture_array
        c = capture.shape[2]
        # Whole PPL: the turn is a flip of every lens's Ny x Nx block.
        lenses = capture.reshape(cap.lenses_y, ny, cap.lenses_x, nx, c)[:, ::-1, :, ::-1]
        views = lenses.transpose(1, 3, 0, 2, 4)  # (Ny, Nx, Ly', Lx', C)
        sx, sy = self.shifts
        ex, ey = self.extension
        out = np.empty((ny, nx, la.lenses_y, la.lenses_x, c), capture.dtype)
        for l in range(ny):
            for k in range(nx):
                i0, j0 = ey + sy[l], ex - sx[k]
                out[l, k] = views[l, k, i0:i0 + la.lenses_y, j0:j0 + la.lenses_x]
        return interleave(out)

    def describe(self) -> dict[str, Any]:
        cap = self.capture_array
        return {"lenslet": self.lenslet.describe(), "focal_plane_z_mm": -self.depth,
                "principal_plane_z_mm": -self.depth - self.lenslet.focal,
                "capture_lenses": [cap.lenses_x, cap.lenses_y],
                "capture_size_px": [cap.panel.width, cap.panel.height]}
