"""Replay: what an eye at ``E`` sees of an H3D image on its display (thesis 3.6, 3.7, A.10).

Pure NumPy.  The display of docs/geometry.md: the lens plane (the lenses' principal plane)
at ``z = 0``, the panel one focal length behind it at ``z = f``, the viewer on the ``-z``
side.  A pixel at offset ``u`` from its lens centre ``c`` sends its light out along
``-(u, f)``, so the ray an eye at ``E`` (``E_z < 0``) sends through a pinhole at ``c``
lands on the panel at

    L = c + (c - E_xy) f / |E_z|

and the eye sees there the H3D pixel that holds ``L`` (black off the panel).  It is the
exact display for a pinhole mask at the lens centres (the thesis's pinhole display, A.II)
and for the chief ray of a lens; a lenticular sheet (or a parallax barrier's slits) is a
pinhole in ``x`` only: the ray crosses the slit at the point of its axis beside it and
goes on straight along it, which is the same formula with ``c`` that point.

- ``size="lenses"``: one replay pixel a lens (``(Ly, Lx)``), the ray through its centre.
- ``size=(W, H)``: a perspective picture from ``E`` of the display's area (the panel's
  rectangle in the lens plane, an off-axis window): each picture pixel's ray crosses the
  lens plane in some lens's cell, goes through that lens's pinhole (a filled aperture:
  the whole cell shows its chief ray's pixel) and lands on the panel behind.
- ``optics="none"``: no sheet and the panel in the lens plane, the chain's identity check:
  at the panel's size every picture pixel is its own panel pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError, param
from ..geometry.lens_array import LensArray
from ..geometry.rays import lens_of_points

OPTICS = ("pinhole", "barrier", "lens", "none")
# numpy's optics: "barrier" is the slit mask of a lenticular panel, geometrically its pinholes
NUMPY_OPTICS = ("pinhole", "barrier", "none")
DEFAULT_DISTANCE_MM = 300.0


@dataclass(frozen=True)
class Replay:
    """One eye's replay.

    Attributes
    ----------
    image : (rows, cols, C) array   what the eye sees, the H3D's dtype
    landing : (rows, cols, 2) float  where each pixel's ray lands on the panel, mm (NaN: no lens)
    pixel : (rows, cols, 2) int      the H3D pixel ``(col, row)`` it shows (-1: off the panel / no lens)
    lens : (rows, cols, 2) int       the lens ``(j, i)`` whose pinhole the ray goes through (-1: none)
    """

    image: np.ndarray
    landing: np.ndarray
    pixel: np.ndarray
    lens: np.ndarray


def check_eye(eye, lens_array: LensArray) -> np.ndarray:
    """The eye ``(x, y, z)`` mm as a float array; a ConfigError when it is not on the viewer's side
    in front of the sheet (``z < -f``: closer, the eye would sit inside the lenses' own depth)."""
    try:
        e = np.asarray(eye, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ConfigError(f"the eye must be three numbers X,Y,Z in mm, got {eye!r}; e.g. {param('eye')} 0,0,-300") from None
    if not np.all(np.isfinite(e)):
        raise ConfigError(f"the eye ({', '.join(f'{v:g}' for v in e)}) is not finite; give it in mm, e.g. {param('eye')} 0,0,-300")
    if e[2] >= 0:
        raise ConfigError(f"the eye at z = {e[2]:g} mm is on the panel's side (the viewer is at z < 0); "
                          f"give a negative z, e.g. {param('eye')} 0,0,-300")
    if -e[2] <= lens_array.focal:
        raise ConfigError(f"the eye at z = {e[2]:g} mm is inside the lens sheet ({lens_array.focal:g} mm deep); "
                          f"move it out to a viewing distance, e.g. {param('eye')} 0,0,-300")
    return e


def lens_cells(lens_array: LensArray, x: np.ndarray, y: np.ndarray, shift: float = 0.0
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The lens whose cell holds each lens-plane point ``(x, y)`` mm (docs/geometry.md's rule for
    pixel centres, applied to any point).

    Returns ``(j, i, inside, c)``: column and row of the lens, whether a lens holds the point at all,
    and ``c`` (..., 2) mm, the pinhole the ray goes through (panel frame): the lens centre, or on a
    lenticular sheet the point of the lenticule's axis beside the point.
    """
    X, Y = lens_array.to_lattice(np.asarray(x, np.float64), np.asarray(y, np.float64))
    X = X - shift  # a sheet moved ``shift`` mm across (a mapped panel's, ``subpixel.placed_sheet``)
    centres = lens_array.lattice_centres()
    i, j, inside = lens_of_points(lens_array, X, Y)
    c = centres[i, j].copy()
    if lens_array.grid == "lenticular":
        c[..., 1] = Y  # a slit: the ray crosses the lenticule's axis beside the point
    c = np.stack(lens_array.from_lattice(c[..., 0] + shift, c[..., 1]), axis=-1)
    return j, i, inside, c


def sheet_centres(lens_array: LensArray, shift: float = 0.0) -> np.ndarray:
    """Every lens centre (Ly, Lx, 2) mm, the sheet moved ``shift`` mm across its lenticules (or columns)."""
    c = lens_array.lattice_centres()
    return np.stack(lens_array.from_lattice(c[..., 0] + shift, c[..., 1]), axis=-1)


def landing(centres: np.ndarray, eye: np.ndarray, focal: float) -> np.ndarray:
    """Where the ray from ``eye`` through each pinhole ``centres`` (..., 2) mm lands on the panel
    ``focal`` mm behind: ``c + (c - E_xy) f / |E_z|``."""
    return centres + (centres - eye[:2]) * (focal / abs(eye[2]))


def panel_pixel(lens_array: LensArray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The panel pixel ``(col, row)`` (..., 2) int holding each point (..., 2) mm, and whether it is on
    the panel; a point on a pixel border goes to the pixel on the right (below), as docs/geometry.md."""
    p = lens_array.panel
    with np.errstate(invalid="ignore"):
        col = np.floor(points[..., 0] / p.pitch_x + p.width / 2 + 1e-9)
        row = np.floor(p.height / 2 - points[..., 1] / p.pitch_y + 1e-9)
        on = np.isfinite(col) & np.isfinite(row) & (col >= 0) & (col < p.width) & (row >= 0) & (row < p.height)
    pix = np.stack([np.where(on, col, -1), np.where(on, row, -1)], axis=-1).astype(np.int64)
    return pix, on


def window_points(lens_array: LensArray, size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Lens-plane points ``(x, y)`` (H, W) mm of a ``size = (W, H)`` picture of the panel's area:
    pixel ``(col, row)`` at ``((col + 0.5 - W/2) w / W, (H/2 - row - 0.5) h / H)``."""
    width, height = size
    w_mm, h_mm = lens_array.panel.size_mm
    x = (np.arange(width) + 0.5 - width / 2) * (w_mm / width)
    y = (height / 2 - np.arange(height) - 0.5) * (h_mm / height)
    return np.meshgrid(x, y)


def replay(h3d: np.ndarray, lens_array: LensArray, eye, *, optics: str = "pinhole",
           size: str | tuple[int, int] = "lenses", shift: float = 0.0, subpixels: bool = False) -> Replay:
    """What an eye at ``eye`` (mm, display coordinates) sees of ``h3d`` on its display (module docstring).

    ``shift``: the sheet lies that many mm across from ``lens_array``'s.  ``subpixels``: the panel is
    seen subpixel by subpixel (a mapped slanted panel, whose sheet addresses R, G and B apart): the ray
    lands on one subpixel ``3 col + c`` (``s/3`` wide) and the eye sees channel ``c`` of pixel ``col``
    alone; ``pixel`` then holds ``(3 col + c, row)``."""
    if optics not in NUMPY_OPTICS:
        raise ConfigError(f"optics {optics!r} is not one NumPy replays ({', '.join(NUMPY_OPTICS)}); "
                          f"'lens' runs POV-Ray (povh3d replay {param('optics')} lens)")
    if optics == "barrier" and lens_array.grid != "lenticular":
        raise ConfigError(f"a parallax barrier (slits) is for a lenticular panel, not a {lens_array.grid} one; "
                          f"use {param('optics')} pinhole")
    h3d = np.asarray(h3d)
    p = lens_array.panel
    if h3d.ndim != 3 or h3d.shape[:2] != (p.height, p.width):
        raise ConfigError(f"the image is {h3d.shape[1] if h3d.ndim > 1 else '?'}x{h3d.shape[0]}, not the "
                          f"{p.width}x{p.height} panel of its lens array; replay the image its sidecar describes")
    e = check_eye(eye, lens_array)
    if size == "lenses":
        if optics == "none":
            raise ConfigError(f"without a sheet ({param('optics')} none) there are no lenses to sample; give {param('size')} WxH")
        c = sheet_centres(lens_array, shift)
        rows, cols = c.shape[:2]
        jj, ii = np.meshgrid(np.arange(cols), np.arange(rows))
        inside = np.ones((rows, cols), bool)
    else:
        width, height = _size(size)
        x, y = window_points(lens_array, (width, height))
        if optics == "none":  # the panel in the lens plane: the ray lands where it crosses it
            c = np.stack([x, y], axis=-1)
            jj, ii, inside = np.full(x.shape, -1), np.full(x.shape, -1), np.ones(x.shape, bool)
        else:
            jj, ii, inside, c = lens_cells(lens_array, x, y, shift)
    land = c if optics == "none" else landing(c, e, lens_array.focal)
    land = np.where(inside[..., None], land, np.nan)
    image = np.zeros(land.shape[:-1] + h3d.shape[2:], h3d.dtype)
    if subpixels:
        from .subpixel import subpixel_array

        pix, on = panel_pixel(subpixel_array(lens_array), land)
        col, row = pix[on][:, 0], pix[on][:, 1]
        seen = np.zeros((col.size, h3d.shape[2]), h3d.dtype)
        seen[np.arange(col.size), col % 3] = h3d[row, col // 3, col % 3]
        image[on] = seen
    else:
        pix, on = panel_pixel(lens_array, land)
        image[on] = h3d[pix[on][:, 1], pix[on][:, 0]]
    lens = np.stack([np.where(inside, jj, -1), np.where(inside, ii, -1)], axis=-1).astype(np.int64)
    return Replay(image, land, pix, lens)


def _size(size) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ConfigError(f"the replay size must be 'lenses' or (W, H) pixels, got {size!r}; e.g. {param('size')} 800x600") from None
    if width < 1 or height < 1 or width * height > 1 << 26:
        raise ConfigError(f"the replay size {width}x{height} must be at least 1x1 and at most 64 Mpixel; "
                          f"e.g. {param('size')} 800x600")
    return width, height


def default_eye(lens_array: LensArray, distance: float | None = None) -> tuple[float, float, float]:
    """The eye centred at ``distance`` mm (default 300) in front of the display."""
    return (0.0, 0.0, -float(distance if distance is not None else DEFAULT_DISTANCE_MM))


def sweep_eyes(eye, axis: str, start: float, stop: float, count: int) -> np.ndarray:
    """``count`` eyes from ``eye`` with ``x`` (or ``y``) from ``start`` to ``stop`` mm, (count, 3)."""
    if count < 2:
        raise ConfigError(f"a sweep needs at least 2 eye positions, got {count}; e.g. {param('sweep')} -60:60:9")
    eyes = np.repeat(np.asarray(eye, np.float64).reshape(1, 3), count, axis=0)
    eyes[:, 0 if axis == "x" else 1] = np.linspace(start, stop, count)
    return eyes


# -- the report ---------------------------------------------------------------------------------------
def pixel_lens(lens_array: LensArray, pix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lens ``(j, i)`` (..., 2) that owns each panel pixel ``(col, row)`` (-1: none), and its offset
    ``(u, v)`` (..., 2) mm from that lens's centre: the view the pixel is part of."""
    p = lens_array.panel
    ok = pix[..., 0] >= 0
    X = np.where(ok, (pix[..., 0] + 0.5 - p.width / 2) * p.pitch_x, 0.0)
    Y = np.where(ok, (p.height / 2 - pix[..., 1] - 0.5) * p.pitch_y, 0.0)
    j, i, inside, c = lens_cells(lens_array, X, Y)
    ok &= inside
    lens = np.stack([np.where(ok, j, -1), np.where(ok, i, -1)], axis=-1)
    offset = np.where(ok[..., None], np.stack([X, Y], axis=-1) - c, np.nan)
    return lens, offset


def same_lens(a: np.ndarray, b: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """Whether lens indices ``(j, i)`` (..., 2) name the same lens: on a lenticular sheet the column alone
    (a lenticule runs across every row; the ray may land a row up or down)."""
    if lens_array.grid == "lenticular":
        return a[..., 0] == b[..., 0]
    return np.all(a == b, axis=-1)


def view_zone(lens_array: LensArray, distance: float) -> dict:
    """The eye's ``x`` range (mm, at ``distance``) over which lens ``c`` shows its own elemental image,
    ``c_x +- p D / 2f`` (for the lens nearest the origin); the central zone is where every lens does (empty
    when the array is wider than ``p D / f``); upright arrays: the eye ``x`` where that lens's view flips."""
    half = lens_array.pitch_x * distance / (2 * lens_array.focal)
    centres = lens_array.lens_centres()
    cx = centres[..., 0]
    low, high = float(cx.max() - half), float(cx.min() + half)
    flat = centres.reshape(-1, 2)
    c0 = flat[np.argmin(np.hypot(flat[:, 0], flat[:, 1]))]  # the lens nearest the origin
    out = {"distance_mm": float(distance), "lens_zone_width_mm": 2 * half,
           "centre_lens_mm": [float(c0[0]), float(c0[1])],
           "centre_lens_zone_mm": [float(c0[0] - half), float(c0[0] + half)],
           "every_lens_zone_mm": [low, high] if low <= high else None}
    if not lens_array.rotation and lens_array.grid != "lattice":
        # the lens nearest the origin: the eye x where its chief ray crosses a pixel column's edge,
        # E = c - (X_edge - c) D / f, i.e. where the view it shows flips
        c = c0
        p = lens_array.panel
        edges = (np.arange(p.width + 1) - p.width / 2) * p.pitch_x
        edges = edges[np.abs(edges - c[0]) <= lens_array.pitch_x / 2 + 1e-9]
        flips = np.sort(c[0] - (edges - c[0]) * distance / lens_array.focal)
        out["view_flips_x_mm"] = [round(float(v), 6) for v in flips]
    return out


def report(result: Replay, lens_array: LensArray, eye) -> dict:
    """Per eye: for each lens, the view it shows (its pixel's offset from the lens that owns it, in pixels
    of the panel) and whether that lens is its own (inside the view zone) or a neighbour's (a flipped zone)."""
    e = np.asarray(eye, np.float64)
    own_lens, offset = pixel_lens(lens_array, result.pixel)
    sampled = result.lens[..., 0] >= 0
    shown = result.pixel[..., 0] >= 0
    own = shown & sampled & same_lens(own_lens, result.lens, lens_array)
    flipped = shown & sampled & ~own
    s = lens_array.panel
    off = offset[shown]
    return {
        "eye_mm": e.tolist(),
        "samples": int(sampled.sum()),
        "off_panel": int((sampled & ~shown).sum()),
        "own_lens_share": float(own.sum() / max(1, sampled.sum())),
        "neighbour_lens_share": float(flipped.sum() / max(1, sampled.sum())),
        "view_offset_px": {  # which view: the shown pixel's offset from its lens centre, in pixels
            "x": [float(np.nanmin(off[:, 0]) / s.pitch_x), float(np.nanmax(off[:, 0]) / s.pitch_x)] if off.size else None,
            "y": [float(np.nanmin(off[:, 1]) / s.pitch_y), float(np.nanmax(off[:, 1]) / s.pitch_y)] if off.size else None,
        },
        "view_zone": view_zone(lens_array, abs(float(e[2]))),
        **_views_record(result, lens_array),
    }


def _views_record(result: Replay, lens_array: LensArray) -> dict:
    """On a camera bank: how many samples show each view ``"l,k"``, and per lens (up to 10,000 lenses) the
    view it shows (``[l, k]``, ``[-1, -1]`` off the panel)."""
    views = views_shown(result, lens_array)
    if views is None:
        return {}
    ok = views[..., 0] >= 0
    keys, counts = np.unique(views[ok].reshape(-1, 2), axis=0, return_counts=True)
    out: dict = {"view_counts": {f"{l},{k}": int(n) for (l, k), n in zip(keys.tolist(), counts.tolist())}}
    if views.shape[0] * views.shape[1] <= 10_000:
        out["view_of_lens"] = views.tolist()
    return out


def views_shown(result: Replay, lens_array: LensArray) -> np.ndarray | None:
    """On a camera bank: the view ``(l, k)`` (rows, cols, 2) each replay pixel shows (-1: none)."""
    if lens_array.views is None:
        return None
    ny, nx = lens_array.views
    rows, cols = lens_array.bank_region
    pix = result.pixel
    col, row = pix[..., 0] - cols.start, pix[..., 1] - rows.start
    ok = (pix[..., 0] >= 0) & (col >= 0) & (col < cols.stop - cols.start) & (row >= 0) & (row < rows.stop - rows.start)
    return np.stack([np.where(ok, row % ny, -1), np.where(ok, col % nx, -1)], axis=-1)


def coded_panel(lens_array: LensArray) -> np.ndarray:
    """A 16-bit panel whose pixel ``(col, row)`` holds ``(col + 1, row + 1, 0)``: replayed through any
    optics, each picture pixel names the panel pixel it shows (0: none)."""
    p = lens_array.panel
    if max(p.width, p.height) >= 65535:
        raise ConfigError(f"a {p.width}x{p.height} panel is too large to code its pixels in 16 bits")
    rows, cols = np.mgrid[0:p.height, 0:p.width]
    return np.stack([cols + 1, rows + 1, np.zeros_like(cols)], axis=-1).astype(np.uint16)


def light_shares(seen: np.ndarray, lens_array: LensArray, eye, size: str | tuple[int, int]) -> dict:
    """Where the light of each lens's aperture comes from, from a picture ``seen`` (H, W, >=2) of
    ``coded_panel`` replayed at ``size`` from ``eye``: the share of picture pixels (inside a lens whose
    chief ray lands on the panel) showing the chief pixel, another pixel of the same lens's elemental
    image (a neighbouring view), a pixel of another lens's image (crosstalk), or nothing."""
    chief = replay(coded_panel(lens_array), lens_array, eye, size=size)
    counted = (chief.lens[..., 0] >= 0) & (chief.pixel[..., 0] >= 0)
    pix = seen[..., :2].astype(np.int64) - 1
    dark = np.asarray((pix < 0).any(axis=-1))
    same = np.all(pix == chief.pixel, axis=-1)
    owner, _ = pixel_lens(lens_array, np.where(dark[..., None], -1, pix))
    own = same_lens(owner, chief.lens, lens_array) & ~dark
    n = max(1, int(counted.sum()))
    return {"chief_pixel": float((same & counted).sum() / n),
            "neighbouring_views": float((own & ~same & counted).sum() / n),
            "neighbouring_lenses": float((~own & ~dark & counted).sum() / n),
            "dark": float((dark & counted).sum() / n), "samples": int(counted.sum())}


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two pictures of one dtype (inf when equal)."""
    peak = float(np.iinfo(a.dtype).max) if np.issubdtype(a.dtype, np.integer) else 1.0
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(peak * peak / mse)


# -- mapped slanted panels -----------------------------------------------------------------------------
def mapped_sheet(mapping, panel, focal: float) -> tuple[LensArray, float, np.ndarray]:
    """The sheet a slanted subpixel ``mapping`` addresses on its physical ``panel`` (``subpixel.placed_sheet``:
    the turned lenticular array and how far across it lies, mm) and the view ``(H, W, 3)`` every subpixel
    shows under the mapping."""
    from .subpixel import placed_sheet

    sheet, shift = placed_sheet(mapping, panel, focal)
    index = mapping.sample((panel.width, panel.height)).index
    return sheet, shift, ((index // 3) % mapping.views).astype(np.int16)


def mapped_report(result: Replay, sheet: LensArray, shift: float, views: np.ndarray, eye) -> dict:
    """Per eye on a mapped panel: how many lens samples show each view (the view the mapping gives the
    subpixel the ray lands on), and how many show the view whose direction, by the sheet's geometry, points
    at the eye (the landing point's place across its lenticule), exactly and within one view."""
    e = np.asarray(eye, np.float64)
    pix = result.pixel
    ok = pix[..., 0] >= 0
    col3, row = pix[..., 0][ok], pix[..., 1][ok]
    shown = views[row, col3 // 3, col3 % 3].astype(np.int64)
    n = int(views.max()) + 1
    x, _ = sheet.to_lattice(result.landing[..., 0][ok], result.landing[..., 1][ok])
    t = (x - shift) / sheet.pitch_x + sheet.lenses_x / 2
    geometric = np.minimum(np.floor((t - np.floor(t)) * n), n - 1).astype(np.int64)
    keys, counts = np.unique(shown, return_counts=True)
    m = max(1, int(ok.sum()))
    return {"eye_mm": e.tolist(), "samples": int(ok.size), "off_panel": int((~ok).sum()),
            "view_counts": {str(k): int(c) for k, c in zip(keys.tolist(), counts.tolist())},
            "geometric_view_share": float((shown == geometric).sum() / m),
            "within_one_view_share": float((np.minimum(np.abs(shown - geometric), n - np.abs(shown - geometric)) <= 1).sum() / m),
            "view_zone": view_zone(sheet, abs(float(e[2])))}


# -- the view each lens shows, over its aperture ---------------------------------------------------------
APERTURE_SAMPLES = (8, 32)  # across a lenticule, along its piece of one panel row
APERTURE_LENSES = 20_000   # lenses measured (a seeded sample when the sheet has more)


def label_centre_offset(sheet: LensArray, shift: float, labels: np.ndarray, views: int) -> tuple[float, bool]:
    """Where a mapping's subpixels of view ``v`` sit across their lenticule: ``(offset, reversed)``, the
    median of ``g - v`` (mod N, wrapped to -N/2..N/2) with ``g = N t`` (``t`` a subpixel centre's place
    across its lenticule, ``subpixel.sheet_phase``), or ``g = N (1 - t)`` when the views run the other way
    (a Looking Glass's ``invView``, a reversed mapping): whichever spreads less.  0.5 when view ``v``'s
    subpixels are centred in the ``v``-th N-th of the lenticule (alioscopy); 1.0 when they sit on its
    upper edge (philips: its phase is a subpixel's left edge, and a subpixel spans two views)."""
    from .subpixel import sheet_phase

    _, t = sheet_phase(sheet, shift)
    v = labels.reshape(t.shape[0], -1)
    best = None
    for rev in (False, True):
        d = np.mod(views * (1 - t if rev else t) - v, views)
        d = np.where(d >= views / 2, d - views, d)
        med = float(np.median(d))
        spread = float(np.median(np.abs(np.mod(d - med + views / 2, views) - views / 2)))
        if best is None or spread < best[2]:
            best = (med, rev, spread)
    assert best is not None   # the loop ran: both directions were tried
    return best[0], best[1]


def aperture_views(sheet: LensArray, shift: float, labels: np.ndarray, eye, views: int, *,
                   offset: tuple[float, bool] | None = None, expected: int | None = None,
                   panel_sheet: tuple[LensArray, float] | None = None, view_at=None, lenses: int | None = APERTURE_LENSES,
                   samples: tuple[int, int] = APERTURE_SAMPLES, rows: int = 1, seed: int = 0) -> dict:
    """The view each lens (lenticule ``j`` x panel row ``r``) shows an eye at ``eye``, over its aperture.

    The aperture is the piece of lenticule ``j`` (``sheet`` moved ``shift`` mm across) over panel row ``r``
    (``rows`` rows from ``r`` down: a 3D pixel's height), sampled ``samples = (K, M)``: K points across
    the lenticule, M along it over the rows' height.  A thin
    lenticule focused on the panel sends the ray from ``E`` through aperture point ``a`` (axis point ``c``
    beside it) to ``L = c + (a - E_xy) f / |E_z|``: across it is a lens (``a`` moves ``L`` only
    ``p f / |E_z|``), along it a flat sheet (``L`` follows ``a``).  ``labels`` (H, W, 3) is the view every
    subpixel holds (the mapping's, or read from the image); the lens's *dominant* view is the label seen
    at most of its samples.  The view the lens should show is the one whose subpixels are centred
    nearest ``L``'s place ``t`` across its lenticule: ``floor(N frac(t) - offset + 1/2)`` mod N, with
    ``offset`` the mapping's own (``label_centre_offset``, from ``labels`` unless given: give the mapping's
    when ``labels`` are read from an image, so that a panel written for another sheet cannot set it); a
    lens whose samples lie in two of those views (its aperture straddles a view boundary) or off the panel
    is left out.  ``expected``: the view every lens should show instead (a Looking Glass's camera for
    the eye), within one view; the sheet's views still decide which lenses straddle a boundary.
    ``panel_sheet``: the sheet and shift whose lenticules' phase on the panel names the views (``labels``,
    ``offset``), when the lens sheet itself is smaller (a Looking Glass's, converging at the viewer).
    ``view_at``: a function giving the slot coordinate (float: view ``k``'s slot is ``[k, k + 1)``) of
    panel points ``(..., 2)`` mm instead (a Looking Glass's shader phase, ``device_slots_at``).

    Returns the shares of the lenses left in whose dominant view is the right one, and within one view;
    ``mean_view_share``: whose *mean* view (the light-weighted centre of the views its samples show,
    wrapped across lobes: a subpixel wider than a slot shows the eye a blend) rounds to the right one,
    and ``mean_view_error``: how far that centre lies from the eye's own place in its slot (percentiles
    50, 99, 100, in views).  ``away_from_boundaries``: the lenses whose landing points all lie farther
    than half the aperture's emitting element from a slot boundary, the element a subpixel over
    ``rows`` (the rows' share of it): none of a single row when a slot is a subpixel wide or less;
    ``away_mean_view_share`` and
    ``away_dominant_view_share`` are theirs (docs/replay.md, "The view each lens shows").
    """
    e = np.asarray(eye, np.float64)
    if offset is None and view_at is None:
        offset = label_centre_offset(sheet, shift, labels, views)
    centre, reverse = offset or (None, None)
    H = sheet.panel.height
    if not 1 <= rows <= H:
        raise ConfigError(f"an aperture of {rows} rows does not fit a panel of {H}; give 1 to {H}")
    total = sheet.lenses_x * (H // rows)
    rng = np.random.default_rng(seed)
    flat = np.arange(total) if lenses is None or lenses >= total else np.sort(rng.choice(total, lenses, replace=False))
    j, r = flat % sheet.lenses_x, (flat // sheet.lenses_x) * rows
    k_n, m_n = samples
    across = ((np.arange(k_n) + 0.5) / k_n - 0.5) * sheet.pitch_x
    along = (np.arange(m_n) + 0.5) / m_n * rows
    axis = (j + 0.5 - sheet.lenses_x / 2) * sheet.pitch_x + shift            # lattice X of the lenticule's axis
    X = axis[:, None, None] + across[None, :, None] + 0 * along[None, None, :]
    y = (H / 2 - r[:, None, None] - along[None, None, :]) * sheet.panel.pitch_y + 0 * X  # within row r's band
    t = math.radians(sheet.rotation)
    Y = (y - math.sin(t) * X) / math.cos(t)                                  # the lattice Y with that panel y
    a = np.stack(sheet.from_lattice(X, Y), axis=-1)
    c = np.stack(sheet.from_lattice(axis[:, None, None] + 0 * X, Y), axis=-1)
    land = c + (a - e[:2]) * (sheet.focal / abs(e[2]))
    phase, phase_shift = panel_sheet or (sheet, shift)
    if view_at is not None:  # the slot coordinate: view k's slot is [k, k + 1)
        slot = view_at(land).reshape(flat.size, -1)
    else:
        lx, _ = phase.to_lattice(land[..., 0], land[..., 1])
        u = (lx - phase_shift) / phase.pitch_x + phase.lenses_x / 2
        frac = u - np.floor(u)
        g = views * (1 - frac if reverse else frac)
        slot = (g - centre + 0.5).reshape(flat.size, -1)
    geometric = np.floor(slot).astype(np.int64)
    # how far the landing points lie from the nearest slot boundary, in subpixels along a row: a slot is
    # the lenticule's width along a row over N (subpixel s / 3 wide)
    slots_per_subpixel = views * (phase.panel.pitch_x / 3) * math.cos(math.radians(phase.rotation)) / phase.pitch_x
    inside = slot - np.floor(slot)
    margin = np.minimum(inside, 1 - inside).min(axis=1) / slots_per_subpixel
    from .subpixel import subpixel_array

    pix, on = panel_pixel(subpixel_array(panel_sheet[0] if panel_sheet else sheet), land)
    on = on.reshape(flat.size, -1)
    col3, row = pix[..., 0].reshape(flat.size, -1), pix[..., 1].reshape(flat.size, -1)
    seen = np.where(on, labels[np.maximum(row, 0), np.maximum(col3, 0) // 3, np.maximum(col3, 0) % 3], -1)
    whole = on.all(axis=1)
    straddles = geometric.min(axis=1) != geometric.max(axis=1)
    kept = whole & ~straddles
    counts = np.zeros((flat.size, views), np.int64)
    np.add.at(counts, (np.repeat(np.arange(flat.size), seen.shape[1])[on.ravel()], seen[on]), 1)
    dominant = counts.argmax(axis=1)
    right = geometric[:, 0] % views if expected is None else np.full(flat.size, int(expected))
    # the light-weighted mean of the views the lens shows, from the right one (wrapped across lobes):
    # a subpixel wider than a slot shows an eye a blend of neighbouring views, centred on the eye's
    wrapped = np.mod(seen - right[:, None] + views / 2, views) - views / 2
    mean = np.where(on, wrapped, 0).sum(axis=1) / np.maximum(on.sum(axis=1), 1)
    d = np.abs(dominant - right)
    lobes = np.minimum(d, views - d)  # the views repeat in lobes: view N - 1 borders the next lobe's view 0
    if expected is None:
        d = lobes
    n = int(kept.sum())
    out = {"eye_mm": e.tolist(), "lenses": int(flat.size), "lenses_of_sheet": int(total),
           "off_panel": int((~whole).sum()), "straddling_a_view_boundary": int((whole & straddles).sum()),
           "measured": n, "aperture_samples": [k_n, m_n], "aperture_rows": rows}
    if expected is None and view_at is None:
        out.update(label_offset_views=centre, views_reversed=reverse)
    if expected is not None:
        out["expected_view"] = int(expected)
    # none measured: every lens straddles a boundary, the eye is between two views
    out["dominant_view_share"] = float((kept & (d == 0)).sum() / n) if n else None
    out["mean_view_share"] = float((kept & (np.abs(mean) < 0.5)).sum() / n) if n else None
    # the centroid against the eye's place in its slot (slot centre 0): how far the blend is off the eye
    err = mean - (slot.mean(axis=1) - np.floor(slot.mean(axis=1)) - 0.5)
    out["mean_view_error"] = [float(v) for v in np.percentile(np.abs(err[kept]), (50, 99, 100))] if n else None
    # away from view boundaries: the landing points lie over half the aperture's emitting element (a
    # subpixel over ``rows``) from a slot boundary
    away = whole & (margin > 0.5 / rows)
    m = int(away.sum())
    out["subpixel_slots"] = float(slots_per_subpixel)
    out["away_from_boundaries"] = m
    out["away_views"] = sorted(set(right[away].tolist()))  # the views judged there
    out["away_dominant_view_share"] = float((away & (d == 0)).sum() / m) if m else None
    out["away_mean_view_share"] = float((away & (np.abs(mean) < 0.5)).sum() / m) if m else None
    out["margin_subpixels_median"] = float(np.median(margin[whole])) if whole.any() else None
    out["dominant_within_one_view_share"] = float((kept & (d <= 1)).sum() / n) if n else None
    if expected is not None:  # the camera's view counted as the far end of the neighbouring lobe too
        out["dominant_within_one_view_share_across_lobes"] = float((kept & (lobes <= 1)).sum() / n) if n else None
    return out


# -- a Looking Glass: its native image through the device's sheet --------------------------------------
def _shader_fraction(cal, points: np.ndarray) -> np.ndarray:
    """The vendor's shader's view fraction in ``[0, 1)`` at each panel point ``(..., 2)`` mm (panel
    frame: origin at the centre, y up), ``inv_view`` applied."""
    from .mappings.looking_glass_shader import shader_uniforms

    u = shader_uniforms(cal)
    w_mm, h_mm = cal.size_mm
    x = points[..., 0] / w_mm + 0.5 + u["subp"]
    y = points[..., 1] / h_mm + 0.5
    a = (x + y * u["tilt"]) * u["pitch"] - u["center"]
    frac = a - np.floor(a)
    return 1.0 - frac if cal.inv_view else frac


def device_views_at(cal, points: np.ndarray, views: int) -> np.ndarray:
    """The view (int) the vendor's shader gives a subpixel centred at each panel point ``(..., 2)`` mm
    (panel frame: origin at the centre, y up).  The shader reads subpixel ``c`` of pixel ``col`` at
    ``(col + 1/2 + c/3) / W``, a third of a pixel right of its centre ``(col + c/3 + 1/6) / W``; the
    calibration was made with it, so that is the view of the light there."""
    from .mappings.looking_glass_shader import _HIGH, _LOW

    frac = _shader_fraction(cal, points)
    return np.minimum((np.clip(frac, _LOW, _HIGH) * views).astype(np.int64), views - 1)


def device_slots_at(cal, points: np.ndarray, views: int) -> np.ndarray:
    """The shader's slot coordinate ``N fraction`` (float, view ``k``'s slot is ``[k, k + 1)``) at each panel
    point, as ``device_views_at`` reads it."""
    return _shader_fraction(cal, points) * views


def device_sheet(cal, focal: float, distance: float) -> tuple[LensArray, float, LensArray, float]:
    """A Looking Glass's lenticular sheet for an eye at ``distance`` mm: ``(lens sheet, its shift, panel
    sheet, its shift)``.  The panel sheet is the calibration's lenticules on the panel (pitch and slant
    from ``pitch``, ``slope`` and ``DPI``), each axis on the line where the shader's view fraction is 1/2
    (``center`` puts the middle view straight ahead); the lens sheet is that sheet drawn toward the
    screen's centre by ``D / (D + f)``, so every lenticule shows the eye at ``(0, 0, -D)`` its axis: the
    views converge at the viewer, as the vendor's cameras assume (each sees the whole screen)."""
    from ..geometry.lens_array import Panel

    if cal.subpixel_cells:
        raise ConfigError("replay models a Looking Glass panel of plain R, G, B stripes; this unit's subpixel "
                          "cells (Gen3 16\" and 32\") are not built yet")
    pitch_mm = cal.pixel_pitch_mm
    panel = Panel(cal.screen_w, cal.screen_h, pitch_mm, pitch_mm)
    turn = math.atan(1.0 / cal.slope)        # the lenticules' lean (counter-clockwise positive)
    across = cal.lens_pitch_mm * math.cos(turn)
    w_mm, h_mm = cal.size_mm
    reach = w_mm * math.cos(turn) + h_mm * abs(math.sin(turn))
    lenses = math.ceil(reach / across) + 3
    sheet = LensArray("lenticular", lenses, cal.screen_h, across, pitch_mm, focal, panel, math.degrees(turn))
    # the phase along the lattice's X at the centre: where the view fraction is 1/2
    probe = np.stack(sheet.from_lattice(np.array([0.0, 1e-3]), np.zeros(2)), axis=-1)
    from .mappings.looking_glass_shader import shader_uniforms

    u = shader_uniforms(cal)
    x = probe[:, 0] / w_mm + 0.5 + u["subp"]
    y = probe[:, 1] / h_mm + 0.5
    a = (x + y * u["tilt"]) * u["pitch"] - u["center"]
    slope = (a[1] - a[0]) / 1e-3                          # lenticules per mm along X
    if not math.isclose(abs(slope) * across, 1.0, rel_tol=1e-3):
        raise ConfigError("the calibration's pitch and slope do not make one lenticule a pitch; check visual.json")
    axis = (0.5 - (a[0] - math.floor(a[0]))) / slope      # X of a lenticule axis (fract(a) = 1/2)
    centre0 = (0.5 - lenses / 2) * across                  # lattice X of lens 0's axis before the shift
    shift = ((axis - centre0) / across % 1.0) * across
    shift = shift - across if shift > across / 2 else shift
    k = distance / (distance + focal)
    lens_sheet = LensArray("lenticular", lenses, cal.screen_h, across * k, pitch_mm, focal, panel, sheet.rotation)
    return lens_sheet, shift * k, sheet, shift


def device_report(cal, labels: np.ndarray, eye, views: int, focal: float, distance: float,
                  cone_deg: float, *, lenses: int | None = APERTURE_LENSES, rows: int = 1) -> dict:
    """Per eye on a Looking Glass: the view each lens shows over its aperture (``aperture_views``) against
    the view of the eye's slot in the shader's phase at the landing points (the view the display shows
    there), and against the view whose vendor camera is nearest the eye's direction (``quilt.view_offsets``:
    view ``q`` at the angle ``(q / (N - 1) - 1/2) cone``; the cameras step the cone in N - 1 steps, the
    slots in N, so camera ``q`` stands ``(q - (N - 1)/2) / (N (N - 1))`` of the cone off its slot's
    centre: on a slot boundary at the edge views)."""
    lens_sheet, lens_shift, sheet, shift = device_sheet(cal, focal, distance)
    e = np.asarray(eye, np.float64)
    angle = math.degrees(math.atan2(e[0], -e[2]))
    camera = int(np.clip(round((angle / cone_deg + 0.5) * (views - 1)), 0, views - 1))

    def at(points: np.ndarray) -> np.ndarray:
        return device_slots_at(cal, points, views)

    kw: dict[str, Any] = dict(panel_sheet=(sheet, shift), view_at=at, lenses=lenses, rows=rows)
    out = aperture_views(lens_sheet, lens_shift, labels, e, views, **kw)
    cam = aperture_views(lens_sheet, lens_shift, labels, e, views, expected=camera, **kw)
    # the landing point of the ray through the axis of the lenticule nearest the screen's centre
    lx, pitch = lens_sheet.lenses_x, lens_sheet.pitch_x
    j = round(lx / 2 - 0.5 - lens_shift / pitch)
    axis = np.stack(lens_sheet.from_lattice(np.array((j + 0.5 - lx / 2) * pitch + lens_shift), np.array(0.0)), axis=-1)
    out["eye_slot"] = float(device_slots_at(cal, axis + (axis - e[:2]) * (focal / abs(e[2])), views))
    out["camera_view"] = camera
    for key in ("dominant_view_share", "dominant_within_one_view_share", "dominant_within_one_view_share_across_lobes"):
        out["camera_" + key] = cam[key]
    return out


# -- the real lenslets against the slits: the view each lens shows in a picture -----------------------------
VIEW_CODE = 1000  # a subpixel of view v is coded (v + 1) VIEW_CODE in its own channel (16 bit)


def view_codes(views: np.ndarray) -> np.ndarray:
    """The panel (H, W, 3) uint16 whose every subpixel codes the view it shows: ``(v + 1) VIEW_CODE``."""
    return ((np.asarray(views, np.int64) + 1) * VIEW_CODE).astype(np.uint16)


def decode_views(picture: np.ndarray) -> np.ndarray:
    """The view (H, W) each picture pixel of a ``view_codes`` panel shows (its one lit channel); -1 dark.
    A code between two (a pixel antialiased across a subpixel edge) rounds to the nearest view."""
    lit = picture[..., :3].astype(np.float64).max(axis=-1)
    return np.where(lit > VIEW_CODE / 2, np.rint(lit / VIEW_CODE) - 1, -1).astype(np.int64)


def sheet_slots(sheet: LensArray, shift: float, offset: tuple[float, bool], views: int):
    """The slot coordinate (float: view ``k``'s slot is ``[k, k + 1)``) of panel points under a mapped
    panel's sheet, as ``aperture_views`` reads it (``offset`` from ``label_centre_offset``)."""
    centre, reverse = offset

    def at(points: np.ndarray) -> np.ndarray:
        lx, _ = sheet.to_lattice(points[..., 0], points[..., 1])
        u = (lx - shift) / sheet.pitch_x + sheet.lenses_x / 2
        frac = u - np.floor(u)
        return np.mod(views * (1 - frac if reverse else frac) - centre + 0.5, views)

    return at


def lens_picture_agreement(lens_views: np.ndarray, slit: Replay, views: int, slots, rows: int = 1,
                           min_pixels: int = 4, sheet: tuple[LensArray, float] | None = None) -> dict:
    """Per lens of a picture (the cells of ``slit.lens``, lenticule ``j`` x ``rows`` panel rows): the views
    the real lenslets show (``lens_views``, decoded from a ``view_codes`` picture through them) against the
    views the slits show (``slit``, the NumPy replay of the same panel, eye and picture size).  A lens
    shows the mean of its picture pixels' views (wrapped across lobes, as ``aperture_views``'s
    ``mean_view_share``) and its commonest view; the two optics show the same view when their means lie
    within half a view.  A lens counts when the slits' landing points on its pixels lie in one slot
    (``slots``: the slot coordinate of panel points, ``sheet_slots`` or ``device_slots_at``) on at least
    ``min_pixels`` lit pixels.  ``sheet`` (the lens sheet and its shift): also the share of pixels showing
    the same view in five bands across the lenticule, by the distance of their lens-plane point from its
    axis (0 to 0.1 pitch, ... 0.4 to 0.5): a lenslet's aberrations grow toward its edges."""
    slit_views = decode_views(slit.image)
    j, i = slit.lens[..., 0], slit.lens[..., 1]
    ok = (j >= 0) & (slit_views >= 0)
    key = (i[ok] // rows).astype(np.int64) * (int(j.max()) + 1) + j[ok]
    uniq, inv = np.unique(key, return_inverse=True)
    pix = np.bincount(inv)
    slot = np.floor(slots(slit.landing[ok])).astype(np.int64) % views
    lo = np.full(uniq.size, 1 << 30, np.int64)
    hi = np.full(uniq.size, -1, np.int64)
    np.minimum.at(lo, inv, slot)
    np.maximum.at(hi, inv, slot)

    def shown(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The mean view (from the slot's, wrapped) and the commonest view of each lens's lit pixels."""
        lit = v >= 0
        wrapped = np.mod(v - lo[inv] + views / 2, views) - views / 2
        mean = np.bincount(inv, np.where(lit, wrapped, 0.0), uniq.size) / np.maximum(np.bincount(inv, lit, uniq.size), 1)
        counts = np.zeros((uniq.size, views + 1), np.int64)  # the last column: dark
        np.add.at(counts, (inv, np.where(lit, v, views)), 1)
        return mean, counts[:, :views].argmax(axis=1)

    lens_mean, lens_top = shown(lens_views[ok])
    slit_mean, slit_top = shown(slit_views[ok])
    counted = (lo == hi) & (pix >= min_pixels)
    d = np.abs(lens_top - slit_top)
    d = np.minimum(d, views - d)
    gap = np.abs(lens_mean - slit_mean)
    n = int(counted.sum())
    return {"lenses": int(uniq.size), "measured": n, "aperture_rows": rows,
            "same_view_share": float((counted & (gap < 0.5)).sum() / n) if n else None,
            "mean_view_gap": [float(v) for v in np.percentile(gap[counted], (50, 99, 100))] if n else None,
            "same_commonest_view_share": float((counted & (d == 0)).sum() / n) if n else None,
            "commonest_within_one_view_share": float((counted & (d <= 1)).sum() / n) if n else None,
            "pixels_same_view_share": float((lens_views[ok] == slit_views[ok]).mean()) if ok.any() else None,
            **({"pixels_same_view_share_across": _across_bands(lens_views, slit_views, ok, *sheet)} if sheet else {})}


def _across_bands(lens_views: np.ndarray, slit_views: np.ndarray, ok: np.ndarray, sheet: LensArray,
                  shift: float) -> list[float | None]:
    x, y = window_points(sheet, (ok.shape[1], ok.shape[0]))
    X, _ = sheet.to_lattice(x, y)
    u = np.abs(((X - shift) / sheet.pitch_x + sheet.lenses_x / 2) % 1 - 0.5)  # from the axis, in pitches
    same = lens_views == slit_views
    out: list[float | None] = []
    for lo in (0.0, 0.1, 0.2, 0.3, 0.4):
        band = ok & (u >= lo) & (u < lo + 0.1)
        out.append(float(same[band].mean()) if band.any() else None)
    return out
