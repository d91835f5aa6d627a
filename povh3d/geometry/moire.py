"""What a viewer sees of a white panel through a lens sheet, and the moire in it (docs/moire.md).

Each lens shows the viewer one point of the panel: the point where the viewer's ray
through the lens centre, continued through the lens, meets the panel a focal length
behind (``seen_points``).  The panel is an RGB stripe panel with a black matrix
(``PanelPattern``).  The brightness seen through every lens, low-passed like an eye
that does not resolve single lenses, gives the moire's contrast; the strongest
component of its spectrum gives its period and direction (``measure``).
``predicted_moire`` is the analytic oracle: the panel's grating frequency, magnified,
minus the nearest frequency of the lens lattice.

Pure NumPy (and SciPy's Gaussian filter): lens arrays and viewer positions in, arrays
and numbers out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, param
from .lens_array import LensArray

#: Rec. 709 luminance of linear R, G, B: the brightness a viewer sees of a colour.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@dataclass(frozen=True)
class PanelPattern:
    """A white RGB stripe panel: pixel pitch ``pitch_x x pitch_y`` mm, R, G, B stripes left
    to right, each subpixel open over ``open_x`` of its width (``pitch_x / 3``) and
    ``open_y`` of the pixel's height; the rest is black matrix.  Pixel edges lie on
    multiples of the pitch (a panel of even size, centred on the origin)."""

    pitch_x: float
    pitch_y: float
    open_x: float = 0.8
    open_y: float = 0.7

    def __post_init__(self) -> None:
        for name in ("pitch_x", "pitch_y"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"the panel's {name} must be a positive number of mm, got {v!r}")
        for name in ("open_x", "open_y"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0 < v <= 1):
                raise ConfigError(f"the panel's {name} (open fraction) must be within (0, 1], got {v!r}")

    def colour(self, x: np.ndarray, y: np.ndarray, spot: float = 0.0) -> np.ndarray:
        """Linear RGB of the panel at points ``x, y`` (mm), averaged over a ``spot x spot`` mm square.

        Returns
        -------
        (..., 3) float
            Channel ``k`` is lit where subpixel ``k`` is open (1) and 0 on the black matrix.
        """
        return self.columns(x, spot) * self.rows(y, spot)[..., None]

    def columns(self, x: np.ndarray, spot: float = 0.0) -> np.ndarray:
        """The column pattern: ``(..., 3)``, channel ``k`` open over subpixel stripe ``k``."""
        sub = self.pitch_x / 3
        x = np.asarray(x, dtype=np.float64)
        return np.stack([_open_fraction(x, self.pitch_x, (k + 0.5) * sub, self.open_x * sub, spot)
                         for k in range(3)], axis=-1)

    def rows(self, y: np.ndarray, spot: float = 0.0) -> np.ndarray:
        """The row pattern: 1 on a pixel row's open part, 0 on the black matrix between rows."""
        return _open_fraction(np.asarray(y, dtype=np.float64), self.pitch_y, 0.5 * self.pitch_y, self.open_y * self.pitch_y, spot)


def _open_fraction(x: np.ndarray, period: float, centre: float, width: float, spot: float) -> np.ndarray:
    """The mean over ``[x - spot/2, x + spot/2]`` of a periodic window open on
    ``|x - centre| < width / 2`` (mod ``period``); at ``spot = 0`` the window itself."""
    if width >= period:
        return np.ones_like(x)
    if spot <= 0:
        r = np.mod(x - centre + period / 2, period) - period / 2
        return (np.abs(r) < width / 2).astype(np.float64)

    def cumulative(t: np.ndarray) -> np.ndarray:  # open length in [0, t), exact for any t
        n = np.floor(t / period)
        r = t - n * period
        return n * width + np.clip(r - (centre - width / 2), 0, width)

    return (cumulative(x + spot / 2) - cumulative(x - spot / 2)) / spot


def lattice_basis(lens_array: LensArray) -> tuple[np.ndarray, np.ndarray]:
    """The two lattice vectors (mm) of a square grid (turned) or a general lattice."""
    la = lens_array
    if la.grid == "lattice":
        return la.basis_vectors()
    if la.grid == "square":
        return (np.array(la.from_lattice(np.float64(la.pitch_x), np.float64(0.0))),
                np.array(la.from_lattice(np.float64(0.0), np.float64(la.pitch_y))))
    raise ConfigError(f"the moire of a {la.grid} sheet is not modelled (its lenses are not one lattice of 2D "
                      f"lenses); use a square grid or a lattice ({param('lattice')}, e.g. cross-lenticular)")


def seen_points(lens_array: LensArray, viewer: tuple[float, float, float]) -> np.ndarray:
    """The panel point each lens shows a viewer at ``viewer = (x, y, distance)`` mm.

    The viewer stands ``distance`` mm in front of the screen (at ``z = -distance``).
    The ray from the viewer through lens centre ``c`` goes on undeviated (a ray through
    a lens's centre is not bent) and meets the panel, ``f`` behind, at
    ``c + (c - viewer_xy) f / distance``.

    Returns
    -------
    (Ly, Lx, 2) float, mm
    """
    vx, vy, distance = (float(v) for v in viewer)
    if not (math.isfinite(distance) and distance > 0 and math.isfinite(vx) and math.isfinite(vy)):
        raise ConfigError(f"the viewer must stand in front of the screen at a finite position, got {viewer!r}")
    c = lens_array.lens_centres()
    return c + (c - np.array([vx, vy])) * (lens_array.focal / distance)


def seen_image(lens_array: LensArray, pattern: PanelPattern, viewer: tuple[float, float, float],
               spot: float = 0.0) -> np.ndarray:
    """Linear RGB seen through every lens, ``(Ly, Lx, 3)``: the panel at its ``seen_points``."""
    p = seen_points(lens_array, viewer)
    return pattern.colour(p[..., 0], p[..., 1], spot)


@dataclass(frozen=True)
class MoireMeasure:
    """The moire of a seen image.

    contrast : Michelson contrast ``(max - min) / (max + min)`` of the brightness low-passed
        by a Gaussian of ``blur`` lens steps, away from the edges.
    period_mm, direction_deg : the strongest component of the low-passed spectrum: its
        period and the direction of its wave vector (the fringes run across it).
    """

    contrast: float
    period_mm: float
    direction_deg: float


def measure(brightness: np.ndarray, lens_array: LensArray, blur: float = 1.5) -> MoireMeasure:
    """Contrast and period of the moire in ``brightness`` (``(Ly, Lx)``, one value per lens)."""
    from ..extras import require

    gaussian_filter = require("scipy.ndimage", "analysis", "the moire measure").gaussian_filter

    lattice_basis(lens_array)  # a sheet whose moire is modelled, else the one-line error
    b = np.asarray(brightness, dtype=np.float64)
    if b.shape != (lens_array.lenses_y, lens_array.lenses_x):
        raise ValueError(f"brightness must be (Ly, Lx) = {(lens_array.lenses_y, lens_array.lenses_x)}, got {b.shape}")
    if not blur > 0:
        raise ValueError(f"blur must be a positive number of lens steps, got {blur!r}")
    edge = int(math.ceil(2 * blur))
    if min(b.shape) <= 2 * edge + 4:
        raise ValueError(f"a {b.shape[1]}x{b.shape[0]} lens sheet is too small to measure a moire at blur {blur}")
    low = gaussian_filter(b, blur, mode="reflect")[edge:-edge, edge:-edge]
    top, bottom = float(low.max()), float(low.min())
    contrast = (top - bottom) / (top + bottom) if top + bottom > 0 else 0.0
    k, _ = _spectrum_peak(b, lens_array, blur)
    return MoireMeasure(contrast, float(1 / np.hypot(*k)) if np.any(k) else math.inf,
                        float(np.degrees(np.arctan2(k[1], k[0]))) % 180.0)


def _spectrum_peak(b: np.ndarray, lens_array: LensArray, blur: float) -> tuple[np.ndarray, float]:
    """The physical wave vector (cycles/mm) of the strongest non-constant component of ``b``,
    weighted by the low-pass, from a Hann-windowed, 4x zero-padded FFT over the lens indices."""
    a1, a2 = lattice_basis(lens_array)
    ly, lx = b.shape
    window = np.outer(np.hanning(ly), np.hanning(lx))
    spec = np.abs(np.fft.fft2((b - b.mean()) * window, s=(4 * ly, 4 * lx)))
    nu_i, nu_j = np.meshgrid(np.fft.fftfreq(4 * ly), np.fft.fftfreq(4 * lx), indexing="ij")
    k = shortest_alias(a1, a2, _wave_vectors(a1, a2, nu_j, nu_i))
    pitch = math.sqrt(abs(a1[0] * a2[1] - a1[1] * a2[0]))
    weight = np.exp(-2 * (math.pi * blur * pitch) ** 2 * (k[..., 0] ** 2 + k[..., 1] ** 2))
    weighted = spec * weight
    weighted[0, 0] = 0
    i, j = np.unravel_index(np.argmax(weighted), weighted.shape)
    # Sub-bin peak: a parabola through the log magnitudes either side, along each index axis.
    log = np.log(np.maximum(weighted, 1e-300))
    ni, nj = weighted.shape

    def vertex(left: float, centre: float, right: float) -> float:
        den = left - 2 * centre + right
        return 0.0 if den >= 0 else float(np.clip(0.5 * (left - right) / den, -0.5, 0.5))

    di = vertex(log[(i - 1) % ni, j], log[i, j], log[(i + 1) % ni, j])
    dj = vertex(log[i, (j - 1) % nj], log[i, j], log[i, (j + 1) % nj])
    nu_i0, nu_j0 = np.fft.fftfreq(ni)[i] + di / ni, np.fft.fftfreq(nj)[j] + dj / nj
    return shortest_alias(a1, a2, _wave_vectors(a1, a2, np.float64(nu_j0), np.float64(nu_i0))), float(weighted[i, j])


def _wave_vectors(a1: np.ndarray, a2: np.ndarray, nu_j: np.ndarray | float, nu_i: np.ndarray | float) -> np.ndarray:
    """Physical wave vectors ``k`` of index frequencies: lens ``(j, i)`` sits at ``j a1 - i a2`` (+ a
    constant), so ``k . a1 = nu_j`` and ``k . a2 = -nu_i``."""
    inv = np.linalg.inv(np.array([a1, a2]))
    return np.stack([inv[0, 0] * nu_j - inv[0, 1] * nu_i, inv[1, 0] * nu_j - inv[1, 1] * nu_i], axis=-1)


def reciprocal(a1: np.ndarray, a2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The reciprocal lattice vectors ``g1, g2`` (cycles/mm): ``g_i . a_j = delta_ij``."""
    g = np.linalg.inv(np.array([a1, a2])).T
    return g[0], g[1]


def shortest_alias(a1: np.ndarray, a2: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``k - G`` for the reciprocal lattice vector ``G`` nearest ``k`` (``(..., 2)`` cycles/mm):
    the lowest frequency a lattice of samples can show for ``k``."""
    g1, g2 = reciprocal(a1, a2)
    gm = np.array([g1, g2]).T
    n = np.rint(np.einsum("ij,...j->...i", np.linalg.inv(gm), k))
    # rounding in a skewed basis can miss the nearest by one step
    cands = [k - (n[..., 0:1] + d1) * g1 - (n[..., 1:2] + d2) * g2 for d1 in (-1, 0, 1) for d2 in (-1, 0, 1)]
    best = cands[0]
    for cand in cands[1:]:
        shorter = np.sum(cand ** 2, axis=-1) < np.sum(best ** 2, axis=-1)
        best = np.where(shorter[..., None], cand, best)
    return best


def predicted_moire(lens_array: LensArray, grating: tuple[float, float], distance: float) -> np.ndarray:
    """The analytic moire wave vector (cycles/mm) of a panel grating seen through the lenses.

    A panel grating of wave vector ``q`` (e.g. ``(0, 1/s)`` for the rows of a black
    matrix) is seen magnified by ``1 + f/distance`` (``seen_points``) and sampled once per
    lens: the moire is ``q (1 + f/distance) - G`` with ``G = n1 g1 + n2 g2`` the nearest
    reciprocal lattice vector.  With ``n1 = 0`` this is the classic moire of two line
    gratings, period ``p1 p2 / sqrt(p1^2 + p2^2 - 2 p1 p2 cos a)`` (docs/moire.md).
    """
    a1, a2 = lattice_basis(lens_array)
    q = np.asarray(grating, dtype=np.float64) * (1 + lens_array.focal / distance)
    return shortest_alias(a1, a2, q)


@dataclass(frozen=True)
class SlantSweep:
    """Moire of a cross-lenticular sheet against its slant (``slant_sweep``), one entry per angle."""

    slants_deg: np.ndarray
    contrast: np.ndarray          # total brightness
    row_contrast: np.ndarray      # the panel's rows alone (the black matrix between them)
    column_contrast: np.ndarray   # the panel's columns alone (R, G, B stripes and the lines between)
    period_mm: np.ndarray         # of the total
    direction_deg: np.ndarray
    row_period_mm: np.ndarray     # of the rows' moire, measured
    row_predicted_mm: np.ndarray  # of the rows' moire, ``predicted_moire``


def cross_sheet(pitch: float, slant: float, focal: float, lenses: tuple[int, int], pattern: PanelPattern,
                *, turn: bool = False) -> LensArray:
    """A cross-lenticular sheet of two ``pitch`` mm sheets, the horizontal one slanted by
    ``slant`` deg (``turn``: the whole pair turned instead, as thesis 5.3 tried at 18.43)."""
    from .lattice import cross_lenticular_basis
    from .lens_array import Panel, lattice_array

    basis = cross_lenticular_basis(pitch, pitch, 0.0, slant) if turn else cross_lenticular_basis(pitch, pitch, slant)
    lx, ly = lenses
    panel = Panel(2 * math.ceil(lx * pitch / pattern.pitch_x), 2 * math.ceil(ly * pitch / pattern.pitch_y),
                  pattern.pitch_x, pattern.pitch_y)
    return lattice_array(basis, lx, ly, focal, panel)


def slant_sweep(pattern: PanelPattern, pitch: float, focal: float, slants_deg, viewer: tuple[float, float, float],
                lenses: tuple[int, int] = (96, 96), *, turn: bool = False, spot: float = 0.0,
                blur: float = 1.5) -> SlantSweep:
    """The moire a viewer sees of a white panel through a cross-lenticular sheet, per slant angle.

    Brightness is the luminance of the seen colour (``LUMINANCE``).  The row and column
    figures split the panel's pattern (it is a product of a column and a row pattern):
    rows alone are what the horizontal sheet beats with, columns what the vertical one does.
    """
    slants = np.asarray(slants_deg, dtype=np.float64)
    out = {k: np.empty(len(slants)) for k in ("contrast", "row_contrast", "column_contrast", "period_mm",
                                              "direction_deg", "row_period_mm", "row_predicted_mm")}
    for n, slant in enumerate(slants):
        la = cross_sheet(pitch, float(slant), focal, lenses, pattern, turn=turn)
        p = seen_points(la, viewer)
        columns, rows = pattern.columns(p[..., 0], spot) @ LUMINANCE, pattern.rows(p[..., 1], spot)
        m = measure(columns * rows, la, blur)
        out["contrast"][n], out["period_mm"][n], out["direction_deg"][n] = m.contrast, m.period_mm, m.direction_deg
        m = measure(rows, la, blur)
        out["row_contrast"][n], out["row_period_mm"][n] = m.contrast, m.period_mm
        out["row_predicted_mm"][n] = 1 / np.hypot(*predicted_moire(la, (0.0, 1 / pattern.pitch_y), viewer[2]))
        out["column_contrast"][n] = measure(columns, la, blur).contrast
    return SlantSweep(slants, **out)
