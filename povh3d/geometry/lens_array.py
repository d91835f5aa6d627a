"""Panel and lens-array model: the geometry of docs/geometry.md as frozen values.

Everything here is pure: parameters in, NumPy arrays or numbers out.  Positions
are computed from indices (``(j + 0.5 - Lx/2) * px``), never by accumulating
increments, so a row of thousands of lenses does not drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TypeVar

import numpy as np

from .axes import to_edge
from ..errors import ConfigError, param

GRIDS = ("square", "lenticular", "hex", "lattice")

_Coord = TypeVar("_Coord", np.ndarray, float)  # coordinates: arrays, or one point's numbers

# PPL closer than this to a whole number counts as integral: pitches come from
# decimal data sheets (0.3825 / 0.0425 is 9 within rounding, not exactly).
_INTEGRAL_TOLERANCE = 1e-6


# Lengths (pitches, focal lengths) outside this range in mm are typing errors, and
# products of them would overflow or lose every digit: refused on entry.
LENGTH_RANGE_MM = (1e-9, 1e9)
# The largest panel povh3d accepts (2^30 pixels: 32768 x 32768), checked before
# anything is allocated; 16K displays have a sixth of that.
MAX_PANEL_PIXELS = 1 << 30


def _positive(name: str, value: float, fix: str) -> float:
    if not isinstance(value, (int, float, np.floating, np.integer)) or isinstance(value, bool):
        raise ConfigError(f"{name} must be a number, got {value!r}; {fix}")
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise ConfigError(f"{name} must be a positive finite number, got {value!r}; {fix}")
    low, high = LENGTH_RANGE_MM
    if not low <= value <= high:
        raise ConfigError(f"{name} must be between {low:g} and {high:g} mm, got {value:g}; {fix}")
    return value


def _count(name: str, value: int, fix: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ConfigError(f"{name} must be a whole number of at least 1, got {value!r}; {fix}")
    if value > MAX_PANEL_PIXELS:
        raise ConfigError(f"{name} {value} is too large; {fix}")
    return int(value)


def lens_rotation(value: object) -> float:
    """A lens rotation in degrees within (-45, 45] as a float; a ConfigError otherwise (a
    lattice turned further is the same lattice turned less)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or not -45 < value <= 45:
        raise ConfigError(f"the lens rotation must be a number of degrees within (-45, 45], got {value!r}; "
                          f"a lattice turned further is the same lattice turned less ({param('lens_rotation')})")
    return float(value)


def nearest_integer(value: float) -> int | None:
    """``value`` as an int when it is integral within data-sheet rounding, else None."""
    rounded = round(value)
    if rounded >= 1 and abs(value - rounded) <= _INTEGRAL_TOLERANCE * max(1.0, abs(value)):
        return int(rounded)
    return None


@dataclass(frozen=True)
class Panel:
    """A pixel panel: ``width x height`` pixels of pitch ``pitch_x x pitch_y`` mm."""

    width: int
    height: int
    pitch_x: float
    pitch_y: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "width", _count("panel width", self.width, f"give the panel size as WxH pixels, e.g. {param('panel')} 1920x1080"))
        object.__setattr__(self, "height", _count("panel height", self.height, f"give the panel size as WxH pixels, e.g. {param('panel')} 1920x1080"))
        object.__setattr__(self, "pitch_x", _positive("pixel pitch", self.pitch_x, f"give it in mm, e.g. {param('pixel_pitch')} 0.1"))
        object.__setattr__(self, "pitch_y", _positive("vertical pixel pitch", self.pitch_y, f"give it in mm, e.g. {param('pixel_pitch')} 0.1"))
        if self.width * self.height > MAX_PANEL_PIXELS:
            raise ConfigError(f"a {self.width}x{self.height} panel has {self.width * self.height:.3g} pixels, over "
                              f"povh3d's limit of {MAX_PANEL_PIXELS:.3g} (32768x32768); use fewer lenses ({param('lenses')}) "
                              f"or fewer pixels per lens ({param('ppl')})")

    @property
    def size_mm(self) -> tuple[float, float]:
        return (self.width * self.pitch_x, self.height * self.pitch_y)

    def pixel_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Pixel centres on the panel.

        Returns
        -------
        X : (W,) float, mm
            ``(col + 0.5 - W/2) * s`` for each column.
        Y : (H,) float, mm
            ``(H/2 - row - 0.5) * s`` for each row (row 0 at the top).
        """
        cols = np.arange(self.width, dtype=np.float64)
        rows = np.arange(self.height, dtype=np.float64)
        return ((cols + 0.5 - self.width / 2) * self.pitch_x,
                (self.height / 2 - rows - 0.5) * self.pitch_y)


@dataclass(frozen=True)
class LensArray:
    """A lens array over a panel, following docs/geometry.md.

    Parameters
    ----------
    grid : {'square', 'lenticular', 'hex', 'lattice'}
    lenses_x, lenses_y : int
        Lens count ``Lx x Ly`` (lenticular: ``Ly`` is the panel height in rows).
    pitch_x, pitch_y : float, mm
        Lens pitch (lenticular: ``pitch_y`` is the pixel pitch; hex: row spacing
        ``pitch_x * sqrt(3)/2``).
    focal : float, mm
        Focal length: the gap between the lens array and the panel.
    panel : Panel
    rotation : float, degrees
        The lattice turned by this angle about the origin, counter-clockwise as the
        viewer sees it (x right, y up), within (-45, 45]; a slanted lenticular sheet
        leans its lenticules this far from vertical (docs/geometry.md, "Rotated lattices").
    basis : ((a1x, a1y), (a2x, a2y)), mm, only for ``grid='lattice'``
        The two lattice vectors (docs/geometry.md, "General lattices"): lens ``(j, i)``
        sits at ``(j + 0.5 - Lx/2) a1 + (Ly/2 - i - 0.5) a2`` and owns the parallelogram
        cell spanned by them.  Taken with ``a1`` pointing right (or up) and ``a2`` on its
        left (a positive determinant); given the other way they are negated, which is
        the same lattice.  ``pitch_x`` and ``pitch_y`` must be the distances between the
        cell's opposite edges (``lattice_array`` works them out); ``rotation`` stays 0
        (turn the vectors instead).
    """

    grid: str
    lenses_x: int
    lenses_y: int
    pitch_x: float
    pitch_y: float
    focal: float
    panel: Panel
    rotation: float = 0.0
    basis: tuple[tuple[float, float], tuple[float, float]] | None = None

    def __post_init__(self) -> None:
        self._check_basis()
        object.__setattr__(self, "rotation", lens_rotation(self.rotation))
        if self.grid not in GRIDS:
            raise ConfigError(f"grid must be one of {', '.join(GRIDS)}, got {self.grid!r}; pick one with {param('grid')}")
        object.__setattr__(self, "lenses_x", _count("lens count", self.lenses_x, f"give it as {param('lenses')} 60x40 (lenticular: {param('lenses')} 60)"))
        object.__setattr__(self, "lenses_y", _count("lens rows", self.lenses_y, f"give it as {param('lenses')} 60x40 (lenticular: {param('rows')})"))
        object.__setattr__(self, "pitch_x", _positive("lens pitch", self.pitch_x, f"give pixels per lens with {param('ppl')} or a lens pitch in mm"))
        object.__setattr__(self, "pitch_y", _positive("vertical lens pitch", self.pitch_y, f"give pixels per lens with {param('ppl')} 8x8"))
        object.__setattr__(self, "focal", _positive("focal length", self.focal, f"give it in mm with {param('focal')}, e.g. {param('focal')} 1.5"))
        p = self.panel
        if self.grid == "lenticular":
            if self.lenses_y != p.height or not math.isclose(self.pitch_y, p.pitch_y, rel_tol=1e-12):
                raise ConfigError(f"a lenticular array has one lens row per panel row; set the panel height with {param('rows')}")
        if self.grid == "hex" and not math.isclose(self.pitch_y, self.pitch_x * math.sqrt(3) / 2, rel_tol=1e-9):
            raise ConfigError("a hex array has rows spaced pitch*sqrt(3)/2; give only the horizontal lens pitch")
        if self.pitch_x < p.pitch_x * (1 - 1e-9) or self.pitch_y < p.pitch_y * (1 - 1e-9):
            raise ConfigError(f"the lens pitch {self.pitch_x:g} mm is under one pixel ({p.pitch_x:g} mm); "
                              f"use at least 1 pixel per lens ({param('ppl')})")
        width_mm, height_mm = p.size_mm
        # hex odd rows are shifted right by half a pitch, so they reach further.
        array_w = self.lenses_x * self.pitch_x + (self.pitch_x / 2 if self.grid == "hex" and self.lenses_y > 1 else 0)
        array_h = self.lenses_y * self.pitch_y
        slack = 1e-9 * max(width_mm, height_mm)
        # A rotated lattice is cut by the panel's edges, as a real slanted sheet is.
        if self.rotation == 0.0 and self.grid != "lattice" and (array_w > width_mm + slack or array_h > height_mm + slack):
            raise ConfigError(
                f"the lens array ({array_w:.6g} x {array_h:.6g} mm) is larger than the panel "
                f"({width_mm:.6g} x {height_mm:.6g} mm); use fewer lenses ({param('lenses')}) or a larger panel ({param('panel')})")

    def _check_basis(self) -> None:
        from .lattice import cell_widths, lattice_vectors  # here: keeps lens_array's imports shallow

        if self.grid != "lattice":
            if self.basis is not None:
                raise ConfigError(f"lattice vectors are for grid 'lattice', not {self.grid!r}; drop {param('lattice')} or {param('grid')}")
            return
        a1, a2 = lattice_vectors(self.basis)
        if self.rotation:
            raise ConfigError(f"a lattice given by its vectors is not turned again ({param('lens_rotation')}); "
                              "turn its vectors instead")
        object.__setattr__(self, "basis", (tuple(map(float, a1)), tuple(map(float, a2))))
        px, py = cell_widths(a1, a2)
        if not (math.isclose(self.pitch_x, px, rel_tol=1e-9) and math.isclose(self.pitch_y, py, rel_tol=1e-9)):
            raise ConfigError(f"a lattice's pitches are its cell widths ({px:.9g} x {py:.9g} mm), got "
                              f"{self.pitch_x:.9g} x {self.pitch_y:.9g}; build it with lattice_array()")

    # -- pixels per lens and views -------------------------------------------------
    @property
    def ppl_x(self) -> float:
        """Pixels per lens horizontally, ``Nx = px / s`` (need not be whole)."""
        return self.pitch_x / self.panel.pitch_x

    @property
    def ppl_y(self) -> float:
        """Pixels per lens vertically, ``Ny = py / s`` (1 for lenticular)."""
        return self.pitch_y / self.panel.pitch_y

    @property
    def unidirectional(self) -> bool:
        return self.grid == "lenticular"

    @cached_property
    def views(self) -> tuple[int, int] | None:
        """``(Ny, Nx)`` views of the camera bank, or None when the PPL is not whole."""
        if self.grid in ("hex", "lattice") or self.rotation:
            return None
        nx, ny = nearest_integer(self.ppl_x), nearest_integer(self.ppl_y)
        if nx is None or ny is None:
            return None
        # The array is centred on the panel: an odd pixel margin would put every
        # pixel half a pixel off the u_k grid, and no view bank fits.
        if (self.panel.width - self.lenses_x * nx) % 2 or (self.panel.height - self.lenses_y * ny) % 2:
            return None
        return (ny, nx)

    @property
    def bank_region(self) -> tuple[slice, slice]:
        """Rows and columns of the panel that the camera bank covers (the array is centred)."""
        ny, nx = self.require_views()
        row0 = (self.panel.height - self.lenses_y * ny) // 2
        col0 = (self.panel.width - self.lenses_x * nx) // 2
        return (slice(row0, row0 + self.lenses_y * ny), slice(col0, col0 + self.lenses_x * nx))

    def require_views(self) -> tuple[int, int]:
        """The views ``(Ny, Nx)``, or a ConfigError saying why there is no camera bank."""
        if self.views is None:
            if self.grid == "hex":
                raise ConfigError("a hex lens array has no orthographic camera bank; render it through a "
                                  f"virtual lens array with {param('method')} single-stage (views: 'povh3d extract' "
                                  f"resamples them), or pick a square or lenticular {param('grid')}")
            if self.grid == "lattice":
                raise ConfigError(f"a lattice given by two vectors ({param('lattice')}) has no camera bank; render it with "
                                  f"{param('method')} multi-ortho, which traces one cell per lens")
            raise ConfigError(f"a camera bank needs whole pixels per lens (got {self.ppl_x:g} x {self.ppl_y:g}) "
                              f"and an even pixel margin around the array; change {param('ppl')}, {param('lenses')} or the panel")
        return self.views

    @property
    def view_size(self) -> tuple[int, int]:
        """``(rows, cols)`` of one view image: one pixel per lens, ``Ly x Lx``."""
        return (self.lenses_y, self.lenses_x)

    @property
    def h3d_size(self) -> tuple[int, int]:
        """``(rows, cols)`` of the H3D image the camera bank fills: ``Ly*Ny x Lx*Nx``."""
        ny, nx = self.require_views()
        return (self.lenses_y * ny, self.lenses_x * nx)

    def view_offsets(self) -> tuple[np.ndarray, np.ndarray]:
        """Pixel offsets from the lens centre for every view.

        Returns
        -------
        u : (Nx,) float, mm
            ``u_k = (k + 0.5 - Nx/2) * s``, k left to right.
        v : (Ny,) float, mm
            ``v_l = (Ny/2 - l - 0.5) * s``, l top to bottom.
        """
        ny, nx = self.require_views()
        k = np.arange(nx, dtype=np.float64)
        l = np.arange(ny, dtype=np.float64)
        return ((k + 0.5 - nx / 2) * self.panel.pitch_x, (ny / 2 - l - 0.5) * self.panel.pitch_y)

    def view_directions(self) -> np.ndarray:
        """Unit ray direction of every view.

        Returns
        -------
        (Ny, Nx, 3) float
            ``normalize(u_k, v_l, f)``.
        """
        u, v = self.view_offsets()
        d = np.stack(np.broadcast_arrays(u[None, :], v[:, None], np.float64(self.focal)), axis=-1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def view_angles_deg(self) -> tuple[np.ndarray, np.ndarray]:
        """Horizontal and vertical view angles ``atan(u_k/f)``, ``atan(v_l/f)`` in degrees."""
        u, v = self.view_offsets()
        return (np.degrees(np.arctan2(u, self.focal)), np.degrees(np.arctan2(v, self.focal)))

    # -- lens centres ------------------------------------------------------------
    def to_lattice(self, x: _Coord, y: _Coord) -> tuple[_Coord, _Coord]:
        """Panel coordinates (mm) in the lattice's own frame: turned back by ``-rotation``."""
        if not self.rotation:
            return x, y
        c, s = math.cos(math.radians(self.rotation)), math.sin(math.radians(self.rotation))
        return c * x + s * y, -s * x + c * y

    def from_lattice(self, x: _Coord, y: _Coord) -> tuple[_Coord, _Coord]:
        """Lattice-frame coordinates (or offsets) in the panel frame: turned by ``rotation``."""
        if not self.rotation:
            return x, y
        c, s = math.cos(math.radians(self.rotation)), math.sin(math.radians(self.rotation))
        return c * x - s * y, s * x + c * y

    def basis_vectors(self) -> tuple[np.ndarray, np.ndarray]:
        """``a1, a2`` of a ``grid='lattice'`` array (``basis``) as arrays, mm."""
        if self.basis is None:
            raise ConfigError(f"lattice vectors are for grid 'lattice', not {self.grid!r}")
        a1, a2 = np.array(self.basis)
        return a1, a2

    def lens_centres(self) -> np.ndarray:
        """Centre of every lens on the display plane.

        Returns
        -------
        (Ly, Lx, 2) float, mm
            ``(cx, cy)`` of lens ``(j, i)`` at ``[i, j]``; hex odd rows shifted by ``px/2``;
            turned by ``rotation`` about the origin.
        """
        c = self.lattice_centres()
        return np.stack(self.from_lattice(c[..., 0], c[..., 1]), axis=-1)

    def lattice_centres(self) -> np.ndarray:
        """``lens_centres`` in the lattice's own frame (before the rotation), ``(Ly, Lx, 2)`` mm."""
        j = np.arange(self.lenses_x, dtype=np.float64)
        i = np.arange(self.lenses_y, dtype=np.float64)
        if self.grid == "lattice":
            (a1x, a1y), (a2x, a2y) = self.basis_vectors()
            s, t = (j + 0.5 - self.lenses_x / 2)[None, :], ((self.lenses_y / 2 - i - 0.5))[:, None]
            return np.stack([s * a1x + t * a2x, s * a1y + t * a2y], axis=-1)
        cx = np.broadcast_to((j + 0.5 - self.lenses_x / 2) * self.pitch_x, (self.lenses_y, self.lenses_x))
        if self.grid == "hex":
            # docs/geometry.md literally: odd rows shifted right by px/2 from the square
            # formula (so the array as a whole sits px/4 right of the origin).
            cx = cx + (np.arange(self.lenses_y) % 2)[:, None] * (self.pitch_x / 2)
        cy = np.broadcast_to(((self.lenses_y / 2 - i - 0.5) * self.pitch_y)[:, None], cx.shape)
        return np.stack([cx, cy], axis=-1)

    # -- display figures ------------------------------------------------------------
    @property
    def viewing_angle_deg(self) -> float:
        """Full viewing angle ``2 atan(pitch / 2f)`` in degrees."""
        return math.degrees(2 * math.atan(self.pitch_x / (2 * self.focal)))

    @property
    def resolution_3d(self) -> tuple[int, int]:
        """``(horizontal, vertical)`` 3D pixels: one per lens."""
        return (self.lenses_x, self.lenses_y)

    @property
    def ppi_3d(self) -> tuple[float, float]:
        """3D pixels per inch, horizontal and vertical."""
        return (25.4 / self.pitch_x, 25.4 / self.pitch_y)

    def as_record(self) -> dict:
        """Plain values for JSON sidecars and ``povh3d info``."""
        out: dict = {
            "grid": self.grid,
            "lenses": [self.lenses_x, self.lenses_y],
            "lens_pitch_mm": [self.pitch_x, self.pitch_y],
            "focal_mm": self.focal,
            "panel": {"size_px": [self.panel.width, self.panel.height],
                      "pixel_pitch_mm": [self.panel.pitch_x, self.panel.pitch_y],
                      "size_mm": list(self.panel.size_mm)},
            "ppl": [self.ppl_x, self.ppl_y],
            **({"rotation_deg": self.rotation} if self.rotation else {}),
            **({"lattice_mm": [list(a) for a in self.basis]} if self.basis is not None else {}),
            "viewing_angle_deg": self.viewing_angle_deg,
            "resolution_3d": list(self.resolution_3d),
            "pixel_distance_3d_mm": [self.pitch_x, self.pitch_y],
            "ppi_3d": list(self.ppi_3d),
        }
        if self.views is not None:
            ah, av = self.view_angles_deg()
            out.update({
                "views": to_edge(self.views),
                "view_size_px": to_edge(self.view_size),
                "h3d_size_px": to_edge(self.h3d_size),
                "view_angles_deg": {"horizontal": ah.tolist(), "vertical": av.tolist()},
            })
        return out


def lattice_array(basis, lenses_x: int, lenses_y: int, focal: float, panel: Panel) -> LensArray:
    """The ``grid='lattice'`` LensArray of two lattice vectors (pitches worked out from them)."""
    from .lattice import cell_widths, lattice_vectors

    a1, a2 = lattice_vectors(basis)
    px, py = cell_widths(a1, a2)
    return LensArray("lattice", lenses_x, lenses_y, px, py, focal, panel, 0.0, (tuple(a1), tuple(a2)))
