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
                     plan=None, gutter: int = 0) -> list[CameraMesh]:
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
    """
    cols, rows, size = _bank_tiles(lens_array, plan)
    samples = _per_bank(CENTRE if samples is None else samples)
    groups = bank_groups(samples, 2 * len(cols) * len(rows), size[0] * size[1])
    return [_bank_mesh(lens_array, front_clearance, group, cols, rows, size, gutter) for group in groups]


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


def _bank_mesh(lens_array: LensArray, front_clearance: float, samples: np.ndarray | None, cols: np.ndarray,
               rows: np.ndarray, size: tuple[int, int], gutter: int = 0) -> CameraMesh:
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
    b = np.repeat(np.arange(len(samples)), len(cols) * len(rows))[:, None]
    r = np.tile(np.repeat(rows, len(cols), axis=0), (len(samples), 1))   # every row segment ...
    c = np.tile(cols, (len(rows) * len(samples), 1))                      # ... times every column segment, per bank
    k, j0, j1, col0 = (c[:, n:n + 1] for n in range(4))
    l, i0, i1, row0 = (r[:, n:n + 1] for n in range(4))
    if samples.ndim == 2:
        ax, ay, du, dv = (samples[b, n] for n in range(4))               # (quads, 1) each
    else:   # a sample per bank and view
        ax, ay, du, dv = (samples[b, l, k, n] for n in range(4))
    # Corners counter-clockwise from bottom left, half a lens outside the kept lens
    # centres, in lens pitches (the conventions' centres, on the 1/GRID grid: exact).
    centres = lens_array.lens_centres()
    cx = np.round(centres[0, :, 0] / px * GRID) / GRID
    cy = np.round(centres[:, 0, 1] / py * GRID) / GRID
    reach = gutter / 2   # lens pitches (one image pixel is one lens) past the outer lens borders
    left, right = cx[j0] - 0.5 - reach, cx[j1 - 1] + 0.5 + reach
    top, bottom = cy[i0] + 0.5 + reach, cy[i1 - 1] - 0.5 - reach
    x = np.concatenate([left, right, right, left], axis=1) + ax
    y = np.concatenate([bottom, bottom, top, top], axis=1) + ay
    # The origin shift u * front_clearance / f in lens pitches: u = (k - (Nx-1)/2 + du) s and
    # px = Nx s, so (k - (Nx-1)/2 + du) * front_clearance / (f Nx), a whole multiple of the offset.
    units = round(front_clearance / (f * math.lcm(nx, ny)))
    mx, my = units * math.lcm(nx, ny) // nx, units * math.lcm(nx, ny) // ny
    turn_x = k - (nx - 1) / 2 + du
    turn_y = (ny - 1) / 2 - l + dv
    origin_x, origin_y = x - turn_x * mx, y - turn_y * my
    j = np.concatenate([j0 - reach, j1 + reach, j1 + reach, j0 - reach], axis=1) - 0.5  # lens index of each corner
    i = np.concatenate([i1 + reach, i1 + reach, i0 - reach, i0 - reach], axis=1) - 0.5
    mesh = _quad_mesh(origin_x, origin_y, turn_x * s_x * px, turn_y * s_y * py,
                      col0 + (j - j0), b * height + row0 + (i - i0),
                      (width, height * len(samples) - (gutter if gutter else 0)), front_clearance, f, (px, py, 1.0))
    return replace(mesh, kept=(kept_cols, kept_rows)) if gutter else mesh


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
