"""The lens-aligned capture bank of single-stage rendering (hex and fractional PPL).

Their display
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

Pure geometry: which capture grid, which re-centring depth, and how far every pixel
lies inside its lens.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING

import numpy as np

from .rays import cell_contains, pixel_rays

if TYPE_CHECKING:  # a type only: the array is built by the caller
    from .lens_array import LensArray


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
    assert best is not None  # each axis has candidates: four N from the pixels per lens up
    return best[1]
