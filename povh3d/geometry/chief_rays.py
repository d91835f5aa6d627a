"""The capture ray of every panel pixel through the single-stage lenslet array: pure NumPy.

A collimated capture camera reaches only the rays through the lenslets' focal points,
which on a hex or fractional-PPL array leaves most pixel rays between samples.  Here
each pixel gets its own capture ray instead, worked out backwards from the ray it must
show (docs/geometry.md, "The ray of a pixel"): the line ``L`` through its lens centre
``c`` (display plane) with direction ``d = normalize(u, v, f)``.

1. ``L`` meets the vertex plane of the virtual array at ``p``; the lenslet whose cell
   (the same Voronoi / pitch cell as the CSG aperture) holds ``p`` is the one it leaves.
2. ``L`` meets that lenslet's curved face (``x^2 + y^2 + (1 + K) z^2 + 2 R z = 0``) at
   ``E``; there Snell's law run backwards gives the ray inside the glass.
3. That ray meets the flat face at ``B``; Snell again gives the ray in air before it.

POV-Ray, tracing the capture ray from just before ``B``, refracts it at ``B`` and at
``E`` and so sends it out along ``L`` exactly (to float precision), whatever the
lenslet's shape, index or distortion.  A pixel whose backward ray would leave its
lenslet through a side wall, or meet total internal reflection, cannot be traced
through the array: ``served`` is False there.

Single-stage rendering (``renderer.methods.single_stage``, point 6) builds on this: the capture
camera is a ``mesh_camera`` with one face per (sub-)pixel (``chief_mesh``), the
lenslets sit off the display's lattice by an irrational fraction of a pitch
(``lenslet_offset``), and the index is a real one (``PHYSICAL_IOR``); the pixels whose
ray cannot pass (``unserved_count``) decide whether the render is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, param
from .capture_bank import border_margin
from .lens_array import LensArray, Panel
from .optics import Lenslet
from .rays import nearest_hex_lens, pixel_rays


@dataclass(frozen=True)
class ChiefRays:
    """Capture rays, one per pixel ray asked for.

    Attributes
    ----------
    origins : (..., 3) float, mm      just before the lenslet's flat face
    directions : (..., 3) float       unit direction in air, toward +z
    served : (...) bool               the backward trace stayed in one lenslet (no side wall, no TIR)
    """

    origins: np.ndarray
    directions: np.ndarray
    served: np.ndarray


def nearest_lens(array: LensArray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre ``(cx, cy)`` of the lens of ``array`` whose cell holds each point (unrotated array)."""
    centres = array.lattice_centres()
    Lx, Ly = array.lenses_x, array.lenses_y
    px, py = array.pitch_x, array.pitch_y
    if array.grid == "hex":
        c = centres[nearest_hex_lens(centres, x, y, px, py)]
        return c[..., 0], c[..., 1]
    j = np.clip(np.floor(x / px + Lx / 2).astype(np.int64), 0, Lx - 1)
    if array.grid == "lenticular":
        return centres[0, j, 0], y.copy()
    i = np.clip(np.floor(Ly / 2 - y / py).astype(np.int64), 0, Ly - 1)
    c = centres[i, j]
    return c[..., 0], c[..., 1]


def in_cell(grid: str, pitch_x: float, pitch_y: float, du: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """Whether offsets ``(du, dv)`` from a lens centre lie inside its cell (edges included)."""
    ax, ay = np.abs(du), np.abs(dv)
    slack = 1 + 1e-9
    if grid == "hex":
        return (ax <= pitch_x / 2 * slack) & (ax / 2 + math.sqrt(3) / 2 * ay <= pitch_x / 2 * slack)
    if grid == "lenticular":
        return ax <= pitch_x / 2 * slack
    return (ax <= pitch_x / 2 * slack) & (ay <= pitch_y / 2 * slack)


def chief_rays(capture: LensArray, lenslet: Lenslet, z_vertex: float, centres: np.ndarray,
               directions: np.ndarray, air_gap: float, offset: tuple[float, float] = (0.0, 0.0),
               through_walls: bool = False) -> ChiefRays:
    """The capture ray that leaves ``capture``'s lenslets along each given line.

    Parameters
    ----------
    capture : LensArray            the virtual array (unrotated); its lenslets' curved vertices at ``z_vertex``
    lenslet : Lenslet
    z_vertex : float, mm
    centres : (..., 2) float, mm   where each line crosses the display plane ``z = 0``
    directions : (..., 3) float    unit directions, ``z`` component > 0
    air_gap : float, mm            how far before the flat face each capture ray starts
    offset : (ox, oy), mm          the virtual array's lenslets sit this far from ``capture``'s centres
    """
    n, R, K = lenslet.ior, lenslet.radius, lenslet.conic
    thick = lenslet.thickness
    b = 0.0 if capture.grid == "lenticular" else 1.0
    d = directions
    # The lenslet L leaves through: under L somewhere between the vertex plane and the
    # flat face (L slants, and dips into a neighbour near an edge).  Try the lenslets
    # under L at four depths, keeping the first whose curved face L meets inside its cell.
    E = np.full(d.shape, np.nan)
    t = np.full(d.shape[:-1], -np.inf)
    cx, cy = np.zeros(t.shape), np.zeros(t.shape)
    found = np.zeros(t.shape, bool)
    for depth in (0.0, thick / 3, 2 * thick / 3, thick):
        z = z_vertex - depth
        p = centres + d[..., :2] * (z / d[..., 2:3])
        lx, ly = nearest_lens(capture, p[..., 0] - offset[0], p[..., 1] - offset[1])
        lx, ly = lx + offset[0], ly + offset[1]
        e, tt = _curved_face_hit(centres, d, lx, ly, z_vertex, R, K, b, thick)
        hit = ~found & np.isfinite(tt) & in_cell(capture.grid, capture.pitch_x, capture.pitch_y, e[..., 0], e[..., 1])
        E, t = np.where(hit[..., None], e, E), np.where(hit, tt, t)
        cx, cy = np.where(hit, lx, cx), np.where(hit, ly, cy)
        found |= hit
    with np.errstate(invalid="ignore", divide="ignore"):
        N = np.stack([E[..., 0], b * E[..., 1], (1 + K) * E[..., 2] + R], axis=-1)
        N /= np.linalg.norm(N, axis=-1, keepdims=True)
    # Snell backwards at E: the tangential part shrinks by n inside the glass.
    dn = np.sum(d * N, axis=-1, keepdims=True)
    gt = (d - dn * N) / n
    g = gt + np.sqrt(np.clip(1 - np.sum(gt * gt, axis=-1, keepdims=True), 0, None)) * N
    s = (-thick - E[..., 2]) / g[..., 2]
    Bf = E + s[..., None] * g  # on the flat face
    a_xy = n * g[..., :2]
    sin2 = np.sum(a_xy * a_xy, axis=-1)
    a = np.concatenate([a_xy, np.sqrt(np.clip(1 - sin2, 0, None))[..., None]], axis=-1)
    served = (np.isfinite(t) & (sin2 < 1)
              & in_cell(capture.grid, capture.pitch_x, capture.pitch_y, E[..., 0], E[..., 1])
              & (through_walls | in_cell(capture.grid, capture.pitch_x, capture.pitch_y, Bf[..., 0], Bf[..., 1])))
    back = air_gap / np.where(a[..., 2] > 0, a[..., 2], 1.0)
    origins = Bf - back[..., None] * a
    origins = origins + np.stack([cx, cy, np.full(cx.shape, z_vertex)], axis=-1)
    # Not served (the line grazes a lenslet's edge): the line itself, started just past
    # the array's vertices, as if that lenslet were missing.
    z0 = z_vertex + air_gap
    plain = np.concatenate([centres + d[..., :2] * (z0 / d[..., 2:3]), np.full(cx.shape + (1,), z0)], axis=-1)
    ok = served & np.all(np.isfinite(origins), axis=-1) & np.all(np.isfinite(a), axis=-1)
    return ChiefRays(np.where(ok[..., None], origins, plain), np.where(ok[..., None], a, d), ok)


def _curved_face_hit(centres: np.ndarray, d: np.ndarray, cx: np.ndarray, cy: np.ndarray, z_vertex: float,
                     R: float, K: float, b: float, thick: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the line through ``(centres, 0)`` along ``d`` meets the curved face of lenslet ``(cx, cy)``.

    Returns ``E`` (..., 3) in that lenslet's frame (vertex at the origin) and the line
    parameter ``t``; NaN / -inf where the line misses the face within the lens's thickness.
    """
    q = np.stack([centres[..., 0] - cx, centres[..., 1] - cy, np.full(cx.shape, -z_vertex)], axis=-1)
    A = d[..., 0] ** 2 + b * d[..., 1] ** 2 + (1 + K) * d[..., 2] ** 2
    B = 2 * (q[..., 0] * d[..., 0] + b * q[..., 1] * d[..., 1] + (1 + K) * q[..., 2] * d[..., 2]) + 2 * R * d[..., 2]
    C = q[..., 0] ** 2 + b * q[..., 1] ** 2 + (1 + K) * q[..., 2] ** 2 + 2 * R * q[..., 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(B * B - 4 * A * C)
        # Stable roots; the one on the vertex's sheet lies within the lens's thickness.
        qq = -0.5 * (B + np.copysign(root, B))
        roots = np.stack([qq / A, C / qq], axis=-1)
        zr = q[..., 2:3] + roots * d[..., 2:3]
        good = (zr <= 1e-9 * R + 1e-12) & (zr >= -thick)
        t = np.where(good, roots, -np.inf).max(axis=-1)
        return q + t[..., None] * d, t


#: Indices of real lens materials for visible light: water 1.33 up to diamond 2.42 (the
#: densest optical glasses reach about 2.0).  Outside this range no lenslet can be made.
PHYSICAL_IOR = (1.3, 2.5)
#: Share of pixels whose ray may miss every lenslet (at a lens's rim, grazing a corner):
#: they are traced from past the array along their own ray, still exact, not refracted.
UNSERVED_SHARE = 0.005
#: Indices tried, lowest first, when ``--ior`` is not given (1.5: acrylic, crown glass).
DEFAULT_IORS = tuple(round(1.5 + 0.1 * k, 1) for k in range(11))


def check_ior(ior: float | None) -> None:
    """Refuse, in one line, an index of refraction no lens material has (None, 1 and below: the default)."""
    lo, hi = PHYSICAL_IOR
    if ior is not None and ior > 1 and not lo <= ior <= hi:
        raise ConfigError(f"{param('ior')} {ior:g} is no lens material: real lenses have indices from {lo:g} (water 1.33) "
                          f"to {hi:g} (diamond 2.42); raise {param('ior')} above {lo:g} or lower it to {hi:g} at most "
                          f"(1.5 is glass)")


def probe_array(lens_array: LensArray, lenses: int = 24) -> LensArray:
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


def lenslet_offset(lens_array: LensArray) -> tuple[float, float]:
    """Lateral shift of the virtual lenslets (mm), off the display's lattice.

    Per-pixel capture rays do not need the lenslets on the display's centres; off
    them by an irrational fraction of a pitch, no family of pixel rays (a column of
    hex pixels with ``u = 0``, say) runs along a lenslet's edge, where POV-Ray's
    answer depends on rounding.
    """
    la = lens_array
    return (math.sqrt(2) - 1) * 0.5 * la.pitch_x, (0.0 if la.grid == "lenticular" else (math.sqrt(5) - 2) * la.pitch_y)


def capture_rays(lens_array: LensArray, capture_array: LensArray, lenslet: Lenslet, depth: float,
                 supersample: int) -> ChiefRays:
    """The capture ray of every sub-pixel, ``(H k, W k)`` (``chief_rays``), through the
    lenslets of ``capture_array`` whose focal plane is ``z = -depth``."""
    la, k = lens_array, supersample
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
    rays = chief_rays(capture_array, lenslet, -depth - lenslet.focal, cs, dirs,
                      air_gap=1e-3 * lenslet.focal, offset=lenslet_offset(la))
    keep = np.repeat(np.repeat(inside, k, 0), k, 1)
    return ChiefRays(rays.origins, rays.directions, rays.served & keep)


def unserved_count(lens_array: LensArray, rays: ChiefRays, supersample: int) -> int:
    """Pixels clear of their lens border (0.1 pixel) whose ray cannot pass through a lenslet."""
    la, k = lens_array, supersample
    # Sub-pixel rays reach up to (1 - 1/k) / sqrt(2) of a pixel from its centre.
    reach = 0.1 + (1 - 1 / k) / math.sqrt(2)
    clear = np.repeat(np.repeat(border_margin(la) > reach * la.panel.pitch_x, k, 0), k, 1)
    return int(np.sum(clear & ~rays.served))


def chief_mesh(lens_array: LensArray, rays: ChiefRays, supersample: int) -> dict[str, np.ndarray]:
    """One triangle per sub-pixel, centroid at its ray's origin, normal along it.

    ``mesh_camera`` distribution 0 shoots image pixel ``(col, row)`` from the
    centroid of face ``col + (row - 1) W`` along the face's normal (measured:
    row 0 repeats row 1, so the image has one extra row on top, cut off).
    Pixels outside every lens look back (-z) at the background; they are
    blacked out afterwards.
    """
    la, k = lens_array, supersample
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
