"""Single-stage rendering through a virtual lens array: geometry and assembly.

The geometry (thesis 3.3, worked out against docs/geometry.md):

1. **Capture panel and camera.**  One orthographic camera on the viewer's side
   (z < 0, looking +z) at the panel's pixel pitch: camera pixel ``(col, row)``
   is a ray parallel to z at the panel position ``(X, Y)`` of that pixel.  It
   plays the panel (the thesis's CCD); its location only has to be in front of
   the lenses.
2. **Lenslets.**  Plano-convex, flat face toward the camera, curved face toward
   the scene (``optics.Lenslet``), at the lens centres ``c`` of docs/geometry.md.
   A camera ray at offset ``w`` from ``c`` leaves the lens through the rear focal
   point ``c + f z`` (exactly for the conic lens, paraxially for the sphere)
   with direction ``(-w, f)``.
3. **180-degree turn.**  The ray of the display pixel at offset ``u`` has
   direction ``(u, f)`` (docs/geometry.md), so it is the camera ray at ``w = -u``:
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
   side.
5. **Hex and fractional PPL: a lens-aligned capture bank** (``geometry.capture_bank``):
   every lens sampled at the same offsets, views again at whole focal lengths of depth.
6. **Per-pixel capture rays** (every unturned array; points 1-5 remain for turned
   arrays and ``collimated``): each pixel's capture ray is worked out backwards
   through the lenslet it leaves (``geometry.chief_rays``), exact for any grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from ...jsontext import JSONValue
from ...errors import ConfigError, param
from ...geometry.capture_bank import CaptureBank, capture_bank, recentre_unit
from ...geometry.chief_rays import (DEFAULT_IORS, PHYSICAL_IOR, UNSERVED_SHARE, ChiefRays, capture_rays, check_ior,
                                   chief_mesh, lenslet_offset, probe_array, unserved_count)
from ...geometry.lens_array import LensArray, Panel
from ...geometry.optics import Lenslet
from ...geometry.rays import pixel_rays
from ...image.colour import mean_in_linear_light
from ...image.elemental import sample_turned_bank
from ...image.interleave import interleave
from ..shots.batch import ShotBatch

APERTURE_OF_GRID = {"square": "square", "lenticular": "lenticular", "hex": "hex"}


def lenslet_for(lens_array: LensArray, shape: str = "conic", ior: float | None = None,
                front_clearance: float = 0.0) -> Lenslet:
    """The lenslet of ``lens_array``: its pitch, its focal length, ``shape`` and ``ior``.

    ``ior`` None: per-pixel capture rays (module doc, 6) are exact with any lens, so the
    lowest physical index through which every pixel's ray passes at the depth that
    ``front_clearance`` asks for (``DEFAULT_IORS``); a turned array's parallel capture keeps
    the optically thin ``optics.default_ior``.
    """
    def make(n: float | None) -> Lenslet:
        return Lenslet(shape, APERTURE_OF_GRID[lens_array.grid], lens_array.pitch_x,
                       lens_array.pitch_y, lens_array.focal, n)

    check_ior(ior)
    if ior is not None or lens_array.rotation != 0.0:
        return make(ior)
    probe = probe_array(lens_array)
    last = None
    for n in DEFAULT_IORS:
        try:
            lenslet = make(n)
        except ConfigError:  # a sphere too strongly curved to span the aperture at this index
            continue
        last = lenslet
        if SingleStagePlan.for_front_clearance(probe, lenslet, front_clearance).unserved == 0:
            return lenslet
    return last if last is not None else make(DEFAULT_IORS[-1])


def default_depth(lens_array: LensArray) -> float:
    """Default re-centring depth: one unit (module doc, 4 and 5)."""
    return recentre_unit(lens_array)


@dataclass(frozen=True)
class SingleStagePlan:
    """Everything the single-stage method decides before rendering.

    Attributes
    ----------
    lens_array : LensArray     the display's array (docs/geometry.md)
    lenslet : Lenslet
    depth : float, mm          ``D``: the focal plane of the virtual array is ``z = -D``
    supersample : int          ``k``: sub-pixel samples per axis, averaged in linear light
                               (``supersamples``); whole PPL: ``k x k`` capture pixels per
                               pixel; hex / fractional: ``k`` times denser capture samples,
                               each display pixel the mean of ``k x k`` sub-directions
    """

    lens_array: LensArray
    lenslet: Lenslet
    depth: float = 0.0
    supersample: int = 1
    collimated: bool = False

    def __post_init__(self) -> None:
        k = self.supersample
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise ConfigError(f"single-stage supersampling must be a whole number of at least 1, got {k!r}")
        unit = recentre_unit(self.lens_array, self.supersample)
        if self.depth < 0 or not math.isfinite(self.depth):
            raise ConfigError(f"the front clearance must be 0 or more mm, got {self.depth!r}")
        if self.depth > 0:
            ratio = self.depth / unit
            if abs(ratio - round(ratio)) > 1e-9:
                raise ConfigError(f"single-stage depth {self.depth!r} mm is not a multiple of {unit!r} mm")

    @classmethod
    def for_front_clearance(cls, lens_array: LensArray, lenslet: Lenslet, front_clearance: float,
                            supersample: int = 1) -> SingleStagePlan:
        """The plan whose depth is the smallest exact ``D >= front_clearance`` (0 for none)."""
        unit = recentre_unit(lens_array, supersample)
        if front_clearance <= 0:
            return cls(lens_array, lenslet, 0.0, supersample)
        return cls(lens_array, lenslet, unit * math.ceil(front_clearance / unit - 1e-9), supersample)

    @classmethod
    def checked(cls, lens_array: LensArray, lenslet: Lenslet, front_clearance: float,
                supersample: int = 1) -> SingleStagePlan:
        """``for_front_clearance``, refused in one line where a pixel's ray cannot pass a lenslet."""
        plan = cls.for_front_clearance(lens_array, lenslet, front_clearance, supersample)
        plan.check_optics()
        return plan

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

    @cached_property
    def bank(self) -> CaptureBank | None:
        """The lens-aligned capture grid (hex, fractional PPL), None with whole PPL."""
        return capture_bank(self.lens_array, self.supersample) if self.lens_array.views is None else None

    @property
    def extension(self) -> tuple[int, int]:
        """Extra capture lenses on each side, ``(Ex, Ey)``."""
        bank, la = self.bank, self.lens_array
        if self.traces_chief_rays:
            # A pixel ray crosses the vertex plane at c - u (D + f) / f, |u| at most the
            # cell's half-width; the lenslet it meets lies within one more lens.
            gain = 1 + (self.depth + self.lenslet.focal) / la.focal
            ex = math.ceil(la.pitch_x / 2 * gain / la.pitch_x) + 1
            if la.grid == "lenticular":
                return ex, 0
            half_y = la.pitch_x / math.sqrt(3) if la.grid == "hex" else la.pitch_y / 2
            ey = math.ceil(half_y * gain / la.pitch_y) + 1
            return ex, ey + ey % 2 if la.grid == "hex" else ey
        extra = 0
        if bank is not None:
            (n, m), (a, b) = bank.samples, bank.phase
            t = self.depth / la.focal
            ex = math.ceil(np.abs(bank.offsets[:, 0] + a).max() / n * t - 1e-9) + (1 if la.grid == "hex" else 0) + extra
            if la.grid == "lenticular":
                return ex, 0
            ey = math.ceil(np.abs(bank.offsets[:, 1] + b).max() / m * t - 1e-9) + extra
            return ex, ey + ey % 2 if la.grid == "hex" else ey  # hex: keep the row parity
        sx, sy = self.shifts
        return int(np.abs(sx).max()) + extra, (int(np.abs(sy).max()) + extra if la.grid != "lenticular" else 0)

    @cached_property
    def capture_array(self) -> LensArray:
        """The virtual array rendered: the display's, ``Ex``/``Ey`` lenses larger per side.

        Hex and fractional PPL: its panel is the lens-aligned capture grid of
        ``bank`` (pitch ``px/N x py/M``), one sample wider on every side.
        """
        la = self.lens_array
        if self.bank is not None:
            (n, m) = self.bank.samples
            ex, ey = self.extension
            lx, ly = la.lenses_x + 2 * ex, la.lenses_y + 2 * ey
            if la.grid == "lenticular":
                rows = la.panel.height
                if la.rotation:  # the turned panel reaches further along the lenticules
                    (w_mm, h_mm), t = la.panel.size_mm, math.radians(la.rotation)
                    rows = math.ceil((w_mm * abs(math.sin(t)) + h_mm * math.cos(t)) / la.panel.pitch_y) + 2
                    rows += (rows - la.panel.height) % 2  # keep rows centred as the panel's
                ly = rows
                panel = Panel(lx * n + 2, rows, la.pitch_x / n, la.panel.pitch_y)
            else:
                extra = n // 2 if la.grid == "hex" and ly > 1 else 0
                # Hex cells reach 2/3 of a row pitch past their centre, 1/6 past the row.
                tips = 2 * math.ceil(m / 6) if la.grid == "hex" else 0
                panel = Panel(lx * n + extra + 2, ly * m + tips + 2, la.pitch_x / n, la.pitch_y / m)
            return LensArray(la.grid, lx, ly, la.pitch_x, la.pitch_y, la.focal, panel, la.rotation)
        ny, nx = la.require_views()  # whole PPL here: views are known
        ex, ey = self.extension
        lx, ly = la.lenses_x + 2 * ex, la.lenses_y + 2 * ey
        panel = Panel(lx * nx, ly * ny, la.panel.pitch_x, la.panel.pitch_y)
        return LensArray(la.grid, lx, ly, la.pitch_x, la.pitch_y, la.focal, panel)

    @cached_property
    def camera_offset(self) -> tuple[float, float]:
        """Centre of the capture image (mm): 0, or under a sample for the lens-aligned grid."""
        if self.bank is None:
            return 0.0, 0.0
        cap, (a, b) = self.capture_array, self.bank.phase
        sx, sy = cap.panel.pitch_x, cap.panel.pitch_y
        c0 = cap.lattice_centres()[0, 0]  # the camera turns with the lattice
        # Pixel centres x0 + (col + 1/2 - Wc/2) sx must include c0 + a sx (likewise y).
        rx = (c0[0] / sx + a + cap.panel.width / 2 - 0.5) % 1.0
        ry = 0.0 if cap.grid == "lenticular" else (c0[1] / sy + b - cap.panel.height / 2 + 0.5) % 1.0
        return sx * (rx - (rx >= 0.5)), sy * (ry - (ry >= 0.5))

    # -- the POV-Ray frame ------------------------------------------------------
    def template_context(self) -> dict[str, Any]:
        cap = self.capture_array
        lenslet = self.lenslet
        panel = cap.panel
        width_mm, height_mm = panel.size_mm
        z_vertex = -self.depth - lenslet.focal
        half_x = cap.pitch_x / 2
        if cap.grid == "lenticular":
            # One lens per column spanning every row (docs/geometry.md: v = 0).
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
            "z_camera": z_vertex - lenslet.thickness - lenslet.focal, "camera_xy": self.camera_offset,
            "right": (width_mm, 0.0, 0.0), "up": (0.0, height_mm, 0.0),
            "rotation": cap.rotation, "array_offset": self.array_offset,
        }

    @property
    def camera_supersample(self) -> int:
        """Capture pixels per panel pixel and axis: ``k`` with whole PPL, else 1 (denser bank)."""
        return self.supersample if self.bank is None else 1

    # -- per-pixel capture rays (hex, fractional PPL: module doc, 6) -------------------
    @property
    def traces_chief_rays(self) -> bool:
        """Whether every pixel gets its own capture ray (module doc, 6): every unturned array
        unless ``collimated`` asks for the thesis's parallel capture camera (points 1-5)."""
        return not self.collimated and self.lens_array.rotation == 0.0

    @cached_property
    def chief(self) -> ChiefRays:
        """The capture ray of every sub-pixel, ``(H k, W k)`` (``chief_rays.capture_rays``)."""
        return capture_rays(self.lens_array, self.capture_array, self.lenslet, self.depth, self.supersample)

    @property
    def array_offset(self) -> tuple[float, float]:
        """Lateral shift of the virtual lenslets (mm): 0, or off the display's lattice for per-pixel rays."""
        return lenslet_offset(self.lens_array) if self.traces_chief_rays else (0.0, 0.0)

    @cached_property
    def unserved(self) -> int:
        """Pixels clear of their lens border (0.1 pixel) whose ray cannot pass through a lenslet."""
        return unserved_count(self.lens_array, self.chief, self.supersample) if self.traces_chief_rays else 0

    def chief_mesh(self) -> dict[str, np.ndarray]:
        """The capture camera's mesh: one triangle per sub-pixel (``chief_rays.chief_mesh``)."""
        return chief_mesh(self.lens_array, self.chief, self.supersample)

    def check_optics(self) -> None:
        """Refuse, in one line, a lenslet through which more than ``UNSERVED_SHARE`` of the
        pixel rays cannot pass.  (The few left start past the array along their own ray.)"""
        bad = self.unserved
        if bad <= UNSERVED_SHARE * pixel_rays(self.lens_array)[2].sum():
            return
        lens, la = self.lenslet, self.lens_array
        lo, hi = PHYSICAL_IOR
        need = la.focal
        for _ in range(40):  # the shortest focal length that serves every pixel at the highest index
            need *= 1.25
            try:
                trial = replace(la, focal=need)
                plan = SingleStagePlan.for_front_clearance(trial, lenslet_for(trial, lens.shape, hi), self.depth)
            except ConfigError:
                continue
            if plan.unserved == 0:
                break
        raise ConfigError(
            f"single-stage cannot pass {bad} pixel rays through a {lens.shape} lenslet of focal length "
            f"{la.focal:g} mm, pitch {la.pitch_x:g} mm and index {lens.ior:g} (total internal reflection or a "
            f"lenslet's side): real indices are {lo:g}..{hi:g}; lengthen {param('focal')} to {need:.3g} mm or more, "
            f"or use {param('method')} multi-ortho")

    def batch(self) -> ShotBatch:
        if self.traces_chief_rays:
            la, k = self.lens_array, self.supersample
            context = {**self.template_context(), "chief_mesh": self.chief_mesh()}
            return ShotBatch("single_stage.pov.j2", context, [{}], la.panel.width * k, la.panel.height * k + 1,
                              processes=1)
        panel, k = self.capture_array.panel, self.camera_supersample
        # The camera keeps its mm extent: k x k sub-pixels tile each pixel, centred in it.
        return ShotBatch("single_stage.pov.j2", self.template_context(), [{}],
                          panel.width * k, panel.height * k, processes=1)

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
        if self.traces_chief_rays:
            k = self.supersample
            h, w, c = la.panel.height, la.panel.width, capture.shape[2]
            sub = capture[1:]  # row 0 repeats row 1 (chief_mesh)
            blocks = sub.reshape(h, k, w, k, c).transpose(1, 3, 0, 2, 4).reshape(k * k, h, w, c)
            out = mean_in_linear_light(blocks) if k > 1 else blocks[0].copy()
            out[~pixel_rays(la)[2]] = 0
            return out
        if self.bank is not None:
            grid = self.capture_array.panel
            return sample_turned_bank(capture, la, (grid.pitch_x, grid.pitch_y), self.bank.phase,
                                      1 + self.depth / la.focal, self.camera_offset, self.supersample)
        k = self.camera_supersample
        if k > 1:
            # Every sub-pixel lies strictly inside its pixel, so inside its lens.
            h, w, c = capture.shape
            blocks = capture.reshape(h // k, k, w // k, k, c).transpose(1, 3, 0, 2, 4)
            capture = mean_in_linear_light(blocks.reshape(k * k, h // k, w // k, c))
        ny, nx = la.require_views()  # whole PPL here: views are known
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

    def as_record(self) -> dict[str, JSONValue]:
        cap = self.capture_array
        return {"lenslet": self.lenslet.as_record(), "focal_plane_z_mm": -self.depth,
                "principal_plane_z_mm": -self.depth - self.lenslet.focal,
                "capture_lenses": [cap.lenses_x, cap.lenses_y],
                "capture_size_px": ([self.lens_array.panel.width * self.supersample,
                                     self.lens_array.panel.height * self.supersample]
                                    if self.traces_chief_rays else
                                    [cap.panel.width * self.camera_supersample,
                                     cap.panel.height * self.camera_supersample]),
                "supersamples_per_pixel": [self.supersample, self.supersample],
                "capture": "collimated" if not self.traces_chief_rays else "per-pixel rays traced back through the lenslets",
                **({"lenslet_offset_mm": list(self.array_offset),
                    "pixels_past_the_lenslets": self.unserved} if self.traces_chief_rays else {}),
                **({"capture_samples_per_lens": list(self.bank.samples),
                    "capture_sample_phase": list(self.bank.phase)}
                   if self.bank is not None and not self.traces_chief_rays else {})}
