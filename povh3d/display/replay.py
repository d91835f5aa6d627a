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

import numpy as np

from ..errors import ConfigError, param
from ..geometry.lens_array import LensArray
from ..geometry.rays import nearest_hex_lens

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
    Lx, Ly = lens_array.lenses_x, lens_array.lenses_y
    px, py = lens_array.pitch_x, lens_array.pitch_y
    if lens_array.grid == "hex":
        i, j = nearest_hex_lens(centres, X, Y, px, py)
        dx, dy = np.abs(X - centres[i, j, 0]), np.abs(Y - centres[i, j, 1])
        half = px / 2 * (1 + 1e-9)
        inside = (dx <= half) & (dx / 2 + math.sqrt(3) / 2 * dy <= half)
    else:
        fj, fi = X / px + Lx / 2 + 1e-9, Ly / 2 - Y / py + 1e-9
        if lens_array.grid == "lattice":
            from ..geometry.lattice import lattice_coordinates

            s, t = lattice_coordinates(*np.array(lens_array.basis), X, Y)
            fj, fi = s + Lx / 2 + 1e-9, Ly / 2 - t + 1e-9
        j, i = np.floor(fj).astype(np.int64), np.floor(fi).astype(np.int64)
        if lens_array.grid == "lenticular":
            inside = (j >= 0) & (j < Lx)
            if not lens_array.rotation:  # upright, the sheet ends with the panel's rows
                inside &= (i >= 0) & (i < Ly)
        else:
            inside = (j >= 0) & (j < Lx) & (i >= 0) & (i < Ly)
        j, i = np.clip(j, 0, Lx - 1), np.clip(i, 0, Ly - 1)
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
    """What an eye at ``eye`` (mm, display frame) sees of ``h3d`` on its display (module docstring).

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


def light_shares(seen: np.ndarray, lens_array: LensArray, eye, size: tuple[int, int]) -> dict:
    """Where the light of each lens's aperture comes from, from a picture ``seen`` (H, W, >=2) of
    ``coded_panel`` replayed at ``size`` from ``eye``: the share of picture pixels (inside a lens whose
    chief ray lands on the panel) showing the chief pixel, another pixel of the same lens's elemental
    image (a neighbouring view), a pixel of another lens's image (crosstalk), or nothing."""
    chief = replay(coded_panel(lens_array), lens_array, eye, size=size)
    counted = (chief.lens[..., 0] >= 0) & (chief.pixel[..., 0] >= 0)
    pix = seen[..., :2].astype(np.int64) - 1
    dark = (pix < 0).any(axis=-1)
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
