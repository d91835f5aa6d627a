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
5. **Hex and fractional PPL: a lens-aligned capture bank.**  Their display
   pixels sit at a different phase in every lens, so there is no view to
   shift.  The capture camera is therefore not the panel: its pixel pitch is
   ``px / N`` by ``py / M`` and its grid is aligned to the lens centres, so every
   capture lens is sampled at the same offsets ``w_km = ((k + a) px/N, (m + b) py/M)``
   (``a, b`` 0 or 1/2).  Those samples are views again: for ``D = T f`` with the
   whole number ``T`` chosen so that every in-cell offset times ``T`` is a lattice
   vector of the array (hex: odd row steps carry a half-pitch), sample ``-u`` of
   capture lens ``c - u T`` is exactly the ray through ``(c, 0)`` with direction
   ``(u, f)``.  The display pixel at offset ``u`` from lens ``c`` is then
   interpolated in direction only, bilinearly in linear light, from the samples
   of its own lens around ``u`` (``elemental.sample_turned_bank``).  Where the
   PPL is a whole multiple of a half or a third (6.5) the samples can hit the
   display offsets exactly (``N = ppl * q``) and no interpolation is left; hex
   vertical offsets are irrational multiples of a pixel.  ``capture_bank``
   picks ``N, M`` (at least one sample per pixel; hex ``N`` even, to align the
   half-pitch) for the fewest capture pixels.
   The same construction is why a hex array cannot simply move forward: a lens
   array in one plane offers only rays through its own focal points, and
   ``c - u D/f`` is a focal point only on such a grid.
6. **Per-pixel capture rays (every unturned array; points 1-5 remain for turned
   arrays and ``collimated``).**  Parallel capture rays reach only the rays
   through the focal points, bent by the lenslet's distortion
   (``tan = w / (f + sag)``), and 2-5 interpolate between them: hex pixels
   landed up to 1.8 mm off on a plane 30 mm away.  Instead each pixel gets its
   own capture ray, worked out backwards through the lenslet its ray leaves
   (``geometry.chief_rays``): POV-Ray refracts it at the flat and the curved
   face and it leaves along the pixel's ray exactly, for any grid, depth ``D``,
   shape and index.  The camera is a ``mesh_camera`` with one face per
   (sub-)pixel; the 180-degree turn and the view shifts are in the rays, so
   ``assemble`` only averages sub-pixels.  The lenslets sit off the display's
   lattice by an irrational fraction of a pitch (``array_offset``).  The index
   is a real one (``PHYSICAL_IOR``); where no real index lets the pixel rays
   through, the render is refused (``check_optics``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

from fractions import Fraction

from ..image.elemental import cell_contains, sample_turned_bank
from ..errors import ConfigError
from ..geometry.lens_array import LensArray, Panel
from ..geometry.rays import pixel_rays
from ..image.colour import mean_in_linear_light
from ..image.interleave import interleave
from ..geometry.optics import Lenslet
from ..geometry.chief_rays import ChiefRays, chief_rays
from .batch import ShotBatch

APERTURE_OF_GRID = {"square": "square", "lenticular": "lenticular", "hex": "hex"}


#: Indices of real lens materials for visible light: water 1.33 up to diamond 2.42 (the
#: densest optical glasses reach about 2.0).  Outside this range no lenslet can be made.
PHYSICAL_IOR = (1.3, 2.5)
#: Share of pixels whose ray may miss every lenslet (at a lens's rim, grazing a corner):
#: they are traced from past the array along their own ray, still exact, not refracted.
UNSERVED_SHARE = 0.005
#: Indices tried, lowest first, when ``--ior`` is not given (1.5: acrylic, crown glass).
DEFAULT_IORS = tuple(round(1.5 + 0.1 * k, 1) for k in range(11))


def lenslet_for(lens_array: LensArray, shape: str = "conic", ior: float | None = None,
                front_clearance: float = 0.0) -> Lenslet:
    """The lenslet of ``lens_array``: its pitch, its focal length, ``shape`` and ``ior``.

    ``ior`` None: per-pixel capture rays (module doc, 6) are exact with any lens, so the
    lowest physical index through which every pixel's ray passes at the depth that
    ``front_clearance`` asks for (``DEFAULT_IORS``); a
    turned array's parallel capture keeps the optically thin ``optics.default_ior``.
    """
    def make(n: float | None) -> Lenslet:
        return Lenslet(shape, APERTURE_OF_GRID[lens_array.grid], lens_array.pitch_x,
                       lens_array.pitch_y, lens_array.focal, n)

    lo, hi = PHYSICAL_IOR
    if ior is not None and ior > 1 and not lo <= ior <= hi:
        raise ConfigError(f"--ior {ior:g} is no lens material: real lenses have indices from {lo:g} (water 1.33) "
                          f"to {hi:g} (diamond 2.42); raise --ior above {lo:g} or lower it to {hi:g} at most "
                          f"(1.5 is glass)")
    if ior is not None or lens_array.rotation != 0.0:
        return make(ior)
    probe = _probe_array(lens_array)
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


def _probe_array(lens_array: LensArray, lenses: int = 24) -> LensArray:
    """A piece of ``lens_array`` at most ``lenses`` a side, on the same pixels, for trying indices.

    Whether a pixel ray passes a lenslet depends on its offset and slope, which a
    piece of the array already shows in all their variety; the whole array is checked
    once the index is chosen (``SingleStagePlan.check_optics``).
    """
    la = lens_array
    lx, ly = min(la.lenses_x, lenses), min(la.lenses_y, lenses)
    if la.grid == "lenticular":
        ly = min(la.lenses_y, 4 * lenses)
    if (lx, ly) == (la.lenses_x, la.lenses_y):
        return la
    s_x, s_y = la.panel.pitch_x, la.panel.pitch_y
    extra = la.pitch_x / 2 if la.grid == "hex" and ly > 1 else 0.0
    width = math.ceil((lx * la.pitch_x + extra) / s_x - 1e-9)
    height = ly if la.grid == "lenticular" else math.ceil(ly * la.pitch_y / s_y - 1e-9)
    width += (la.panel.width - width) % 2  # the same pixel phase about the centre
    height += (la.panel.height - height) % 2
    return LensArray(la.grid, lx, ly, la.pitch_x, la.pitch_y, la.focal, Panel(width, height, s_x, s_y))


def border_margin(lens_array: LensArray) -> np.ndarray:
    """(H, W) mm: how far each pixel centre lies inside its lens's cell (-inf outside every lens)."""
    c, _, inside = pixel_rays(lens_array)
    X, Y = lens_array.to_lattice(*np.meshgrid(*lens_array.panel.pixel_centres()))
    cx, cy = lens_array.to_lattice(c[..., 0], c[..., 1])
    ax, ay = np.abs(X - cx), np.abs(Y - cy)
    px, py = lens_array.pitch_x, lens_array.pitch_y
    if lens_array.grid == "hex":
        margin = np.minimum(px / 2 - ax, px / 2 - ax / 2 - math.sqrt(3) / 2 * ay)
    elif lens_array.grid == "lenticular":
        margin = px / 2 - ax
    else:
        margin = np.minimum(px / 2 - ax, py / 2 - ay)
    return np.where(inside, margin, -np.inf)


def recentre_unit(lens_array: LensArray, density: int = 1) -> float:
    """Smallest depth ``D`` (mm) at which every view shifts by whole lenses; 0 if none.

    ``u_k D / (f px) = (k + 0.5 - Nx/2) D / (f Nx)`` is whole for every ``k`` when
    ``D / f`` is a multiple of ``Nx`` (odd ``Nx``) or ``2 Nx`` (even); likewise
    vertically (not for lenticular sheets, whose rays keep their row).
    """
    views = lens_array.views
    if views is None:  # the capture bank's, at ``density`` samples per pixel
        return lens_array.focal * capture_bank(lens_array, density).unit
    ny, nx = views
    steps = [nx if nx % 2 else 2 * nx]
    if not lens_array.unidirectional:
        steps.append(ny if ny % 2 else 2 * ny)
    return lens_array.focal * math.lcm(*steps)


@dataclass(frozen=True)
class CaptureBank:
    """The lens-aligned capture grid of a hex or fractional-PPL array (module doc, 5).

    Attributes
    ----------
    samples : (N, M)        capture samples per lens pitch, horizontally and vertically
    phase : (a, b)          0 or 1/2: sample ``k`` sits at ``(k + a) px / N`` from the centre
    unit : int              ``T``: the smallest ``D / f`` at which every sample is a lattice shift
    offsets : (K, 2) int    the in-cell sample indices ``(k, m)``
    """

    samples: tuple[int, int]
    phase: tuple[float, float]
    unit: int
    offsets: np.ndarray


def _axis_candidates(ppl: float, display_offsets: np.ndarray, even: bool) -> list[tuple[int, float, bool]]:
    """``(N, phase, exact)`` candidates for one axis (``display_offsets`` in lens pitches).

    ``N`` at least one sample per pixel; ``exact`` when every display offset is a sample.
    """
    out = []
    for n in sorted({*range(math.ceil(ppl - 1e-9), math.ceil(ppl - 1e-9) + 4),
                     *(round(ppl * q) for q in (2, 3) if abs(ppl * q - round(ppl * q)) < 1e-6)}):
        if n < 1 or (even and n % 2):
            continue
        for phase in (0.0, 0.5):
            x = display_offsets * n - phase
            out.append((n, phase, bool(np.all(np.abs(x - np.rint(x)) < 1e-6))))
    return out


def _unit(grid: str, xs: set, pairs: set) -> int:
    """Smallest whole ``T`` with every in-cell offset times ``T`` a lattice vector."""
    if grid == "hex":  # rows step by whole b, columns by whole a plus b/2
        terms = {y for _, y in pairs} | {x - y / 2 for x, y in pairs}
    elif grid == "lenticular":
        terms = xs
    else:
        terms = {x for x, _ in pairs} | {y for _, y in pairs}
    return math.lcm(*(f.denominator for f in terms))


def capture_bank(lens_array: LensArray, density: int = 1) -> CaptureBank:
    """The capture grid and re-centring unit of a hex or fractional-PPL array.

    Among the candidate grids (``N, M`` from ``density`` samples per pixel up, both phases) the one
    with the fewest capture pixels at one unit of depth, halved for grids that
    hit every display offset exactly (no direction interpolation left).
    """
    la = lens_array
    centres, _, inside = pixel_rays(la)
    X, Y = np.meshgrid(*la.panel.pixel_centres())
    # Offsets in the lattice's own frame: the capture grid is aligned to the (turned) lenses.
    du, dv = la.to_lattice(X - centres[..., 0], Y - centres[..., 1])
    du, dv = (du / la.pitch_x)[inside], (dv / la.pitch_y)[inside]
    lent = la.grid == "lenticular"
    xs = _axis_candidates(la.ppl_x * density, du, even=la.grid == "hex")
    ys = [(1, 0.0, True)] if lent else _axis_candidates(la.ppl_y * density, dv, even=False)
    best = None
    for n, a, ex_x in xs:
        for m, b, ex_y in ys:
            k = np.arange(-n - 1, n + 1)
            mm = np.zeros(1, np.int64) if lent else np.arange(-2 * m - 1, 2 * m + 1)
            K, M = np.meshgrid(k, mm)
            ou, ov = (K + a) * la.pitch_x / n, (M + b) * la.pitch_y / m
            ok = cell_contains(la.grid, la.pitch_x, la.pitch_y, ou, np.zeros_like(ou) if lent else ov)
            offsets = np.stack([K[ok], M[ok]], axis=-1)
            fa, fb = Fraction(a), Fraction(b)
            pairs = {((int(kk) + fa) / n, (int(ll) + fb) / m) for kk, ll in offsets}
            t = _unit(la.grid, {x for x, _ in pairs}, pairs)
            ex = float(max(abs(x) for x, _ in pairs)) * t + 1
            ey = 0.0 if lent else float(max(abs(y) for _, y in pairs)) * t + 1
            cost = (la.lenses_x + 2 * ex) * n * (la.lenses_y + 2 * ey) * m / (2 if ex_x and ex_y else 1)
            if best is None or cost < best[0]:
                best = (cost, CaptureBank((n, m), (a, b), t, offsets))
    return best[1]


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
        ny, nx = la.views
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
        """The capture ray of every sub-pixel, ``(H k, W k)`` (``chief_rays``)."""
        la, k = self.lens_array, self.supersample
        c, _, inside = pixel_rays(la)
        X, Y = np.meshgrid(*la.panel.pixel_centres())
        d = (np.arange(k) + 0.5) / k - 0.5  # sub-pixel centres, in pixels, inside the pixel's own lens
        h, w = inside.shape
        cs = np.repeat(np.repeat(np.nan_to_num(c), k, 0), k, 1)
        u = np.repeat(np.repeat(X, k, 0), k, 1) + np.tile(d, w)[None, :] * la.panel.pitch_x - cs[..., 0]
        v = np.repeat(np.repeat(Y, k, 0), k, 1) - np.tile(d, h)[:, None] * la.panel.pitch_y - cs[..., 1]
        if la.grid == "lenticular":
            v = np.zeros_like(v)
            cs[..., 1] = np.repeat(np.repeat(Y, k, 0), k, 1) - np.tile(d, h)[:, None] * la.panel.pitch_y
        dirs = np.stack([u, v, np.full(u.shape, la.focal)], axis=-1)
        dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
        rays = chief_rays(self.capture_array, self.lenslet, -self.depth - self.lenslet.focal, cs, dirs,
                          air_gap=1e-3 * self.lenslet.focal, offset=self.array_offset)
        keep = np.repeat(np.repeat(inside, k, 0), k, 1)
        return ChiefRays(rays.origins, rays.directions, rays.served & keep)

    @property
    def array_offset(self) -> tuple[float, float]:
        """Lateral shift of the virtual lenslets (mm): 0, or off the display's lattice for per-pixel rays.

        Per-pixel capture rays do not need the lenslets on the display's centres; off
        them by an irrational fraction of a pitch, no family of pixel rays (a column of
        hex pixels with ``u = 0``, say) runs along a lenslet's edge, where POV-Ray's
        answer depends on rounding.
        """
        if not self.traces_chief_rays:
            return 0.0, 0.0
        la = self.lens_array
        return (math.sqrt(2) - 1) * 0.5 * la.pitch_x, (0.0 if la.grid == "lenticular" else (math.sqrt(5) - 2) * la.pitch_y)

    @cached_property
    def unserved(self) -> int:
        """Pixels clear of their lens border (0.1 pixel) whose ray cannot pass through a lenslet."""
        if not self.traces_chief_rays:
            return 0
        la, k = self.lens_array, self.supersample
        # Sub-pixel rays reach up to (1 - 1/k) / sqrt(2) of a pixel from its centre.
        reach = 0.1 + (1 - 1 / k) / math.sqrt(2)
        clear = np.repeat(np.repeat(border_margin(la) > reach * la.panel.pitch_x, k, 0), k, 1)
        return int(np.sum(clear & ~self.chief.served))

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
            f"lenslet's side): real indices are {lo:g}..{hi:g}; lengthen --focal to {need:.3g} mm or more, "
            f"or use --method multi-ortho")

    def chief_mesh(self) -> dict[str, np.ndarray]:
        """One triangle per sub-pixel, centroid at its ray's origin, normal along it.

        ``mesh_camera`` distribution 0 shoots image pixel ``(col, row)`` from the
        centroid of face ``col + (row - 1) W`` along the face's normal (measured:
        row 0 repeats row 1, so the image has one extra row on top, cut off).
        Pixels outside every lens look back (-z) at the background; they are
        blacked out afterwards.
        """
        la, k = self.lens_array, self.supersample
        rays = self.chief
        _, _, inside = pixel_rays(la)
        keep = np.repeat(np.repeat(inside, k, 0), k, 1).reshape(-1)
        o = rays.origins.reshape(-1, 3).copy()
        nrm = rays.directions.reshape(-1, 3).copy()
        o[~keep] = (0.0, 0.0, -1.0)
        nrm[~keep] = (0.0, 0.0, -1.0)
        e1 = np.cross(nrm, (0.0, 1.0, 0.0))
        e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
        e2 = np.cross(nrm, e1)
        size = la.pitch_x  # large faces: their float32 normals stay exact to ~1e-7
        r3 = math.sqrt(3) / 2
        verts = np.stack([o + size * e1, o - size * (0.5 * e1 + r3 * e2), o - size * (0.5 * e1 - r3 * e2)], axis=1)
        faces = np.arange(3 * len(o), dtype=np.int64).reshape(-1, 3)
        return {"vertices": verts.reshape(-1, 3), "faces": faces}

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
            cap = self.capture_array.panel
            return sample_turned_bank(capture, la, (cap.pitch_x, cap.pitch_y), self.bank.phase,
                                      1 + self.depth / la.focal, self.camera_offset, self.supersample)
        k = self.camera_supersample
        if k > 1:
            # Every sub-pixel lies strictly inside its pixel, so inside its lens.
            h, w, c = capture.shape
            blocks = capture.reshape(h // k, k, w // k, k, c).transpose(1, 3, 0, 2, 4)
            capture = mean_in_linear_light(blocks.reshape(k * k, h // k, w // k, c))
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

    def as_record(self) -> dict[str, Any]:
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
