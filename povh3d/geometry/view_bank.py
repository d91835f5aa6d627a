"""The view bank: whole-PPL views tiled into mesh-camera shots, one bank per footprint
sample, and the shots cut back into banks.

Pure: a LensArray in, ``CameraMesh`` values out (``geometry.cameras`` holds the mesh
and the single-shot cameras).
"""

from __future__ import annotations

import math
from dataclasses import replace

from typing import TYPE_CHECKING

import numpy as np

from ..errors import ConfigError, param
from .camera_mesh import CameraMesh, _quad_mesh, check_front_clearance
from .footprint import CENTRE, GRID

if TYPE_CHECKING:
    from .lens_array import LensArray


# How many footprint banks go into one mesh-camera shot.  POV-Ray 3.7 finds a
# ray's face by scanning every face of the mesh (measured with 64 views at 480x272:
# 38 ms a bank with 8 banks a shot, 88 ms with 128, about 2.5e-11 s per face per
# ray), while each further shot of a run costs about 0.25 s (parse, start of shot).
# The banks per shot that minimise the sum: sqrt(FRAME_SECONDS / (rays x faces x SCAN_SECONDS)).
FRAME_SECONDS = 0.25
SCAN_SECONDS = 2.5e-11


def bank_groups(samples: np.ndarray, faces_per_bank: int, rays_per_bank: int) -> list[np.ndarray]:
    """Footprint samples split into equal groups, one mesh-camera shot each.

    All groups have one size (a batch's shots share one image size): the largest
    divisor of the count not above the cheapest size (see ``FRAME_SECONDS``), so a
    small probe takes 64 banks a shot, a 480x272 panel 16 and a 1920x1088 one 4.
    """
    samples = _per_bank(samples)
    best = math.sqrt(FRAME_SECONDS / (SCAN_SECONDS * max(1, rays_per_bank) * max(1, faces_per_bank)))
    size = max(d for d in range(1, min(max(1, int(best)), len(samples)) + 1) if len(samples) % d == 0)
    return [samples[i:i + size] for i in range(0, len(samples), size)]


def _per_bank(samples: np.ndarray) -> np.ndarray:
    """Footprint samples ``(K, 4)``, one per bank, or ``(K, Ny, Nx, 4)``, one per bank and view
    (views whose samples are independent: --quality auto's seeds, ``renderer.methods.auto_seeds``)."""
    samples = np.asarray(samples, dtype=np.float64)
    return samples if samples.ndim == 4 else samples.reshape(-1, 4)


def view_bank_shots(lens_array: LensArray, front_clearance: float, samples: np.ndarray | None = None,
                     plan=None, gutter: int = 0, viewing_distance: float | None = None) -> list[CameraMesh]:
    """The meshes of the shots that trace a view bank per footprint sample (``bank_groups``).

    Each mesh is the orthographic camera bank as one mesh camera, one quad per view
    (or, with a ``crop.CropPlan``, per kept column segment times kept row segment):
    the image is the views tiled side by side, ``tiled[l*Ly + i, k*Lx + j] =
    view[l, k][i, j]``, one bank per footprint sample of the group, stacked top to
    bottom.  Within a view the ray origin is linear in the lens index and the
    direction constant, so one quad per view is exact; every corner is exact in
    single precision (``bank_front_clearance``), so a cropped pixel gets the very ray the
    uncropped mesh gives it.

    ``gutter`` > 0 (a render whose antialiasing samples pixel borders): that many
    pixels between any two quads (``_bank_mesh``), cut off by ``stack_shots``.

    ``viewing_distance`` D (mm, a lenticular array): every pixel row seen from an eye at the screen
    centre's height D in front of the lens plane, one face a strip of rows (``strip_rows``); None: the
    orthographic views.
    """
    cols, rows, size = _bank_tiles(lens_array, plan)
    samples = _per_bank(CENTRE if samples is None else samples)
    strips = len(rows) if viewing_distance is None else \
        int((-(-(rows[:, 2] - rows[:, 1]) // strip_rows(lens_array, viewing_distance))).sum())
    groups = bank_groups(samples, 2 * len(cols) * strips, size[0] * size[1])
    return [_bank_mesh(lens_array, front_clearance, group, cols, rows, size, gutter, viewing_distance)
            for group in groups]


def _bank_tiles(lens_array: LensArray, plan) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Column and row segments ``(view, first lens, stop lens, image column/row)`` and the
    image size of one bank: whole views, or the tiles a ``crop.CropPlan`` keeps."""
    if plan is not None:
        return plan.col_segments(), plan.row_segments(), plan.size
    ny, nx = lens_array.require_views()
    lx, ly = lens_array.lenses_x, lens_array.lenses_y
    cols = np.array([(k, 0, lx, k * lx) for k in range(nx)])
    rows = np.array([(l, 0, ly, l * ly) for l in range(ny)])
    return cols, rows, (lx * nx, ly * ny)


def bank_front_clearance(lens_array: LensArray, front_clearance: float) -> float:
    """The front clearance a view bank uses: ``front_clearance`` rounded up to a multiple of ``f * lcm(Nx, Ny)``.

    Then every view's origin shift ``u * front_clearance / f``, in lens pitches, is a
    multiple of 1/2 (times the samples' 1/GRID grid), so the bank's corners,
    written in lens pitches, are exact in POV-Ray's single precision.
    """
    ny, nx = lens_array.require_views()
    unit = lens_array.focal * math.lcm(nx, ny)
    return math.ceil(front_clearance / unit * (1 - 1e-12)) * unit


def eye_clearance(lens_array: LensArray, viewing_distance: float) -> float:
    """The front clearance of rows seen from ``viewing_distance``: the last of the view bank's steps
    (``bank_front_clearance``) before the eye, which sees nothing behind itself."""
    ny, nx = lens_array.require_views()
    unit = lens_array.focal * math.lcm(nx, ny)
    steps = math.ceil(viewing_distance / unit * (1 - 1e-12)) - 1
    if steps < 1:
        raise ConfigError(f"a viewing distance of {viewing_distance:g} mm is inside the view bank's first step "
                          f"({unit:g} mm, focal x views); give a {param('viewing_distance')} over {unit:g} mm")
    return steps * unit


def _bank_mesh(lens_array: LensArray, front_clearance: float, samples: np.ndarray | None, cols: np.ndarray,
               rows: np.ndarray, size: tuple[int, int], gutter: int = 0,
               viewing_distance: float | None = None) -> CameraMesh:
    """Quads over column segments x row segments of the tiled views, one bank per sample.

    ``cols``/``rows`` are ``(n, 4)``: ``(view, first lens, stop lens, image column/row)``.
    Vertices are in lens pitches (x, y) and mm (z), the mesh scaled by ``(px, py, 1)``:
    a corner ``j`` lenses from the array's centre, shifted by the view's origin
    offset, is a multiple of 1/GRID and stored exactly (see ``CameraMesh``).

    ``gutter``: pixels between neighbouring quads (and banks), each quad reaching
    half of it past its outer lenses.  POV-Ray's adaptive antialiasing (``+AM2``)
    traces every pixel's corners, and POV-Ray gives a ray on the edge two quads
    share to the first quad of the mesh: without gutters the first row and column
    of a view took their outer corners from the view above and to the left (a
    quarter of their samples at ``+R3``).  Within a quad the ray is linear in the
    image position, so the corners of its outer pixels, half a pixel out, are the
    rays through the lens border of that same view: inside the pixel's footprint.
    """
    ny, nx = lens_array.require_views()
    front_clearance = bank_front_clearance(lens_array, front_clearance)
    check_front_clearance(lens_array, front_clearance)
    px, py, f = lens_array.pitch_x, lens_array.pitch_y, lens_array.focal
    s_x, s_y = lens_array.panel.pitch_x, lens_array.panel.pitch_y
    samples = _per_bank(CENTRE if samples is None else samples)
    width, height = size
    if gutter:
        # Segment n moves n gutters on (segments are in image order), banks one more each.
        cols, rows = cols.copy(), rows.copy()
        kept_cols = _with_gutters(cols, width, gutter)
        kept_rows = _with_gutters(rows, height, gutter)
        width, height = width + (len(cols) - 1) * gutter, height + (len(rows) - 1) * gutter + gutter
        kept_rows = (np.arange(len(samples))[:, None] * height + kept_rows[None, :]).reshape(-1)
    reach = gutter / 2   # lens pitches (one image pixel is one lens) past the outer lens borders
    # Each row segment with its reach past its top and bottom lens borders (a strip inside a segment: none).
    rows = np.column_stack([rows, np.full((len(rows), 2), reach)]) if viewing_distance is None else \
        _row_strips(rows, reach, strip_rows(lens_array, viewing_distance))
    b = np.repeat(np.arange(len(samples)), len(cols) * len(rows))[:, None]
    r = np.tile(np.repeat(rows, len(cols), axis=0), (len(samples), 1))   # every row segment ...
    c = np.tile(cols, (len(rows) * len(samples), 1))                      # ... times every column segment, per bank
    k, j0, j1, col0 = (c[:, n:n + 1] for n in range(4))
    l, i0, i1, row0 = (r[:, n:n + 1].astype(np.int64) for n in range(4))
    reach_top, reach_bottom = r[:, 4:5], r[:, 5:6]
    if samples.ndim == 2:
        ax, ay, du, dv = (samples[b, n] for n in range(4))               # (quads, 1) each
    else:   # a sample per bank and view
        ax, ay, du, dv = (samples[b, l, k, n] for n in range(4))
    if viewing_distance is not None:   # a row's vertical direction is the eye's: its footprint spans the row's height only
        dv = np.zeros_like(dv)
    # Corners counter-clockwise from bottom left, half a lens outside the kept lens
    # centres, in lens pitches (the conventions' centres, on the 1/GRID grid: exact).
    centres = lens_array.lens_centres()
    cx = np.round(centres[0, :, 0] / px * GRID) / GRID
    cy = np.round(centres[:, 0, 1] / py * GRID) / GRID
    left, right = cx[j0] - 0.5 - reach, cx[j1 - 1] + 0.5 + reach
    top, bottom = cy[i0] + 0.5 + reach_top, cy[i1 - 1] - 0.5 - reach_bottom
    x = np.concatenate([left, right, right, left], axis=1) + ax
    y = np.concatenate([bottom, bottom, top, top], axis=1) + ay
    # The origin shift u * front_clearance / f in lens pitches: u = (k - (Nx-1)/2 + du) s and
    # px = Nx s, so (k - (Nx-1)/2 + du) * front_clearance / (f Nx), a whole multiple of the offset.
    units = round(front_clearance / (f * math.lcm(nx, ny)))
    mx, my = units * math.lcm(nx, ny) // nx, units * math.lcm(nx, ny) // ny
    turn_x = k - (nx - 1) / 2 + du
    turn_y = (ny - 1) / 2 - l + dv
    origin_x, origin_y = x - turn_x * mx, y - turn_y * my
    v = turn_y * s_y * py
    if viewing_distance is not None:
        origin_y, v = _seen_from(y, origin_y - y, v, py, f, front_clearance, viewing_distance)
    j = np.concatenate([j0 - reach, j1 + reach, j1 + reach, j0 - reach], axis=1) - 0.5  # lens index of each corner
    i = np.concatenate([i1 + reach_bottom, i1 + reach_bottom, i0 - reach_top, i0 - reach_top], axis=1) - 0.5
    mesh = _quad_mesh(origin_x, origin_y, turn_x * s_x * px, v,
                      col0 + (j - j0), b * height + row0 + (i - i0),
                      (width, height * len(samples) - (gutter if gutter else 0)), front_clearance, f, (px, py, 1.0))
    return replace(mesh, kept=(kept_cols, kept_rows)) if gutter else mesh


#: The most a strip's traced vertical slope may stray from the row's (``strip_rows``): at a metre's depth,
#: a micrometre, about 1 % of any preset's pixel row.
SLOPE_TOLERANCE = 1e-6


def strip_rows(lens_array: LensArray, viewing_distance: float) -> int:
    """How many lens rows one mesh face may span when rows are seen from ``viewing_distance``.

    POV-Ray's mesh camera makes each written vertex normal a unit vector before it blends them
    (measured: a quad with normals (0, 0, 1) below and (0, 1, 1) above traced the slope 0.414 halfway,
    where the linear blend is 0.5).  A view bank writes the normal of slope ``s`` as ``(u px, s f py,
    f)`` (its mesh ``scale``), so across a face whose corner slopes differ by ``ds`` about the mean
    ``s`` the normals' lengths differ by at most ``py^2 s ds`` of their own, the blend's weight at ``t``
    strays by ``t (1 - t)`` times that, and the slope by at most ``py^2 s ds^2 / 4``.  A face spans as
    many rows as keep that within ``SLOPE_TOLERANCE``.
    """
    f, py = lens_array.focal, lens_array.pitch_y
    per_row = py / (viewing_distance + f)                         # slope step of one lens row
    steepest = lens_array.lenses_y * py / 2 / (viewing_distance + f)
    if steepest == 0:
        return lens_array.lenses_y
    return max(1, int(math.sqrt(4 * SLOPE_TOLERANCE / steepest) / py / per_row))


def _row_strips(rows: np.ndarray, reach: float, per_strip: int) -> np.ndarray:
    """Row segments ``(n, 4)`` cut into strips of ``per_strip`` lens rows (``strip_rows``), ``(m, 6)``:
    ``(view, first row, stop row, image row, reach past its top, reach past its bottom)``, the reach only
    at a segment's own ends."""
    out = []
    for l, i0, i1, row0 in rows.tolist():
        for i in range(i0, i1, per_strip):
            stop = min(i + per_strip, i1)
            out.append((l, i, stop, row0 + i - i0, reach if i == i0 else 0.0, reach if stop == i1 else 0.0))
    return np.array(out, dtype=np.float64).reshape(-1, 6)


def _seen_from(y: np.ndarray, shift: np.ndarray, v: np.ndarray, py: float, f: float, front_clearance: float,
               distance: float) -> tuple[np.ndarray, np.ndarray]:
    """The origins' y and the written directions' v of corners whose row an eye sees from ``distance``.

    ``y``: a corner's height on the panel in lens pitches (``py`` mm each); ``shift`` and ``v``: the
    orthographic ray's origin shift and written vertical direction.  An eye at height 0, ``distance`` mm
    in front of the lens plane, sees the panel point ``y`` (``f`` behind the lens plane) through the
    lens-plane point ``y D / (D + f)`` along the slope ``y / (D + f)``: the sheet does not bend a ray
    vertically.  The ray starts ``front_clearance`` mm in front of the lens plane.
    """
    crossing = y * (distance / (distance + f))              # lens pitches
    slope = crossing * py / distance
    if abs(front_clearance - distance) <= 1e-9 * distance:  # every origin on one line: the mesh would collapse
        raise ConfigError(f"the rays start {front_clearance:g} mm in front of the screen, at the viewing distance "
                          f"itself; give another {param('front_clearance')}")
    return crossing - slope * front_clearance / py + shift, v + f * slope * py


def _with_gutters(segments: np.ndarray, size: int, gutter: int) -> np.ndarray:
    """Move ``segments`` (``(n, 4)``, image position last, in image order) ``gutter``
    pixels apart, in place; the image positions that hold pixels."""
    order = np.argsort(segments[:, 3], kind="stable")
    shift = np.empty(len(segments), dtype=np.int64)
    shift[order] = np.arange(len(segments)) * gutter
    kept = np.arange(size) + np.repeat(shift[order], np.diff(np.append(segments[order, 3], size)))
    segments[:, 3] += shift
    return kept


def stack_shots(images: list[np.ndarray], meshes: list[CameraMesh] | None = None) -> np.ndarray:
    """Rendered mesh-camera shots stacked top to bottom, each without the extra first
    row and last column of ``CameraMesh`` (and without the gutters of its mesh, if given)."""
    cut = [im[1:, :-1] for im in images]
    if meshes is not None:
        cut = [mesh.without_gutters(im) for mesh, im in zip(meshes, cut)]
    return cut[0] if len(cut) == 1 else np.concatenate(cut)
