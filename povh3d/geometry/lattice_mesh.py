"""The mesh camera of any lattice: one polygon per lens cell, turned with the lattice.

``cameras.camera_mesh`` lays out upright square and lenticular arrays; this
module adds hex cells (hexagons) and turned lattices (docs/geometry.md,
"Rotated lattices"), and ``lens_mesh`` picks between the two.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .cameras import TIE_SHIFT, camera_mesh, sampled_corners
from .camera_mesh import CameraMesh, _quad_mesh, check_front_clearance
from .lattice import lattice_coordinates
from .lens_array import LensArray
from .rays import pixel_rays


def lens_mesh(lens_array: LensArray, front_clearance: float, shift: float = 0.0, sample=None) -> CameraMesh:
    """One cell per lens: ``lattice_mesh`` for hex, turned, general or shifted lattices, else ``camera_mesh``.
    ``sample`` ``(ax, ay, du, dv)``: every ray moved to that footprint sample (``cameras.sampled_corners``)."""
    if lens_array.rotation or lens_array.grid in ("hex", "lattice") or shift:
        return lattice_mesh(lens_array, front_clearance, shift, sample)
    return camera_mesh(lens_array, front_clearance, sample)


def lattice_mesh(lens_array: LensArray, front_clearance: float, shift: float = 0.0, sample=None) -> CameraMesh:
    """``camera_mesh`` of a rotated lattice, a hex one or a general one: one polygon per lens cell.

    The cell of every lens (square: its pitch rectangle; hex: its hexagon, all six
    corners ``px / sqrt(3)`` from the centre; lenticular: a strip ``px`` wide along
    the lenticule, past the panel at both ends; general lattice: the parallelogram
    ``c +- a1/2 +- a2/2``) is laid out in the lattice's own frame and turned by
    ``rotation``.  Origin and direction stay linear in the
    offset ``(u, v)`` and every corner offset of a lens has one length, so the face
    interpolation is exact as in ``camera_mesh``.  A pixel centre lies on a cell
    edge only by accident of a rotated lattice, and no tie shift is made for it.

    Only cells that own a pixel are written.  POV-Ray aborts on UV outside 0..1,
    and cells at the panel's edge reach past it, so the image is a canvas
    ``margin`` pixels larger on every side (``CameraMesh.crop`` cuts it back).

    ``shift`` (lenticular only): the lenticules' axes lie that many mm further across
    (the lattice's ``x``) than the centred sheet's: a calibrated sheet's phase.
    """
    check_front_clearance(lens_array, front_clearance)
    la = lens_array
    panel = la.panel
    W, H = panel.width, panel.height
    f = la.focal
    hx, hy = la.pitch_x / 2, la.pitch_y / 2
    if shift and la.grid != "lenticular":
        raise ValueError("only a lenticular sheet is shifted across its lenticules")
    if la.grid == "lenticular":
        # Each strip runs along its lenticule as far as its pixels, and a pixel diagonal on.
        # Along a strip the extremes of the panel's pixels lie on the panel's border (the
        # strip and the panel are convex), so only border pixels are looked at.
        xs, ys = panel.pixel_centres()
        border = np.concatenate([np.stack(np.broadcast_arrays(xs, ys[0]), -1), np.stack(np.broadcast_arrays(xs, ys[-1]), -1),
                                 np.stack(np.broadcast_arrays(xs[0], ys), -1), np.stack(np.broadcast_arrays(xs[-1], ys), -1)])
        bx, by = la.to_lattice(border[:, 0], border[:, 1])
        col = np.floor((bx - shift) / la.pitch_x + la.lenses_x / 2 + 1e-9).astype(np.int64)  # pixel_rays' rule
        ok = (col >= 0) & (col < la.lenses_x)
        col, by = col[ok], by[ok]
        cx = la.lattice_centres()[0, :, 0] + shift
        low, high = np.full(la.lenses_x, np.inf), np.full(la.lenses_x, -np.inf)
        np.minimum.at(low, col, by)
        np.maximum.at(high, col, by)
        keep = np.flatnonzero(np.isfinite(low))
        ends = np.stack([low[keep], high[keep]], axis=1)
        reach = math.hypot(panel.pitch_x, panel.pitch_y)
        cx = cx[keep]
        cu = np.array([-hx, hx, hx, -hx])
        lx = cx[:, None] + cu[None, :]
        ly = np.stack([ends[:, 0] - reach] * 2 + [ends[:, 1] + reach] * 2, axis=1)  # along the lenticule
        ou, ov = np.broadcast_to(cu, lx.shape), np.zeros(lx.shape)  # v across the lenticule is 0
        olx, oly = cx[:, None] - ou * (front_clearance / f), ly
    else:
        X, Y = la.to_lattice(*np.meshgrid(*panel.pixel_centres()))
        owner, inside = _pixel_owners(la, X, Y)
        c = la.lattice_centres().reshape(-1, 2)[np.unique(owner[inside])]
        if la.grid == "lattice":  # the parallelogram spanned by the two vectors
            (a1x, a1y), (a2x, a2y) = la.basis_vectors()
            cs, ct = np.array([-0.5, 0.5, 0.5, -0.5]), np.array([-0.5, -0.5, 0.5, 0.5])
            cs, ct = cs - _tie_shift(la, X, Y, 0), ct + _tie_shift(la, X, Y, 1)
            cu, cv = cs * a1x + ct * a2x, cs * a1y + ct * a2y
        elif la.grid == "hex":
            r = la.pitch_x / math.sqrt(3)
            cu = np.array([-hx, 0.0, hx, hx, 0.0, -hx])
            cv = np.array([-r / 2, -r, -r / 2, r / 2, r, r / 2])
        else:
            cu, cv = np.array([-hx, hx, hx, -hx]), np.array([-hy, -hy, hy, hy])
        lx, ly = c[:, 0:1] + cu[None, :], c[:, 1:2] + cv[None, :]
        ou, ov = np.broadcast_to(cu, lx.shape), np.broadcast_to(cv, lx.shape)
        olx, oly = c[:, 0:1] - ou * (front_clearance / f), c[:, 1:2] - ov * (front_clearance / f)
    x, y = la.from_lattice(lx, ly)
    u, v = la.from_lattice(ou, ov)
    origin_x, origin_y = la.from_lattice(olx, oly)
    col = x / panel.pitch_x + W / 2 - 0.5
    row = H / 2 - 0.5 - y / panel.pitch_y
    mx = max(0, math.ceil(max(-col.min(), col.max() - (W - 1)))) + 1
    my = max(0, math.ceil(max(-row.min(), row.max() - (H - 1)))) + 1
    shear, z, direction_shear = None, None, None
    if sample is not None:
        origin_x, origin_y, z, direction_shear = sampled_corners(la, sample, origin_x, origin_y, front_clearance)
    if la.grid == "lattice":
        shear, origin_x, origin_y, u, v = _unshear(la, origin_x, origin_y, u, v)
    mesh = _quad_mesh(origin_x, origin_y, u, v, col + mx, row + my, (W + 2 * mx, H + 2 * my), front_clearance, f, z=z)
    return replace(mesh, margin=(mx, my), shear=shear, direction_shear=direction_shear)


def _tie_shift(la: LensArray, X: np.ndarray, Y: np.ndarray, axis: int) -> float:
    """How far (in lattice units along ``a1`` or ``a2``) to move every cell off pixel centres
    that lie on its edges: ``TIE_SHIFT`` of a pixel, so that such a pixel is looked up inside
    the lens ``pixel_rays`` gives it (right, below), as ``camera_mesh`` does; 0 without ties."""
    st = lattice_coordinates(*la.basis_vectors(), X, Y)[axis]
    edge = st + (la.lenses_x if axis == 0 else la.lenses_y) / 2
    if not np.any(np.abs(edge - np.rint(edge)) < 1e-7):
        return 0.0
    return TIE_SHIFT * la.panel.pitch_x / float(np.hypot(*la.basis_vectors()[axis]))


def _unshear(la: LensArray, ox: np.ndarray, oy: np.ndarray, u: np.ndarray, v: np.ndarray):
    """A general lattice's mesh written through a shear ``K`` (``CameraMesh.shear``).

    POV-Ray normalises vertex normals before it interpolates them, which is exact only
    where a face's corner offsets ``(u, v, f)`` share one length: true of rectangles and
    hexagons, not of a parallelogram (a 30 deg skew put rays 0.25 mm off 4 mm behind the
    screen).  So the mesh is written with ``K^T = diag(|a1|, |a2|) B^-1`` (``B = [a1 a2]``)
    applied to the offsets, which makes every cell a rectangle, and origins by ``K^-1``;
    POV-Ray maps origins back by ``K`` and directions by ``K^-T``, both linear, so every
    ray is the exact one again.
    """
    b = np.array(la.basis, dtype=np.float64).T  # columns a1, a2
    kt = np.diag(np.linalg.norm(b, axis=0)) @ np.linalg.inv(b)
    k_inv = np.linalg.inv(kt.T)
    uo, vo = kt[0, 0] * u + kt[0, 1] * v, kt[1, 0] * u + kt[1, 1] * v
    xo, yo = k_inv[0, 0] * ox + k_inv[0, 1] * oy, k_inv[1, 0] * ox + k_inv[1, 1] * oy
    return tuple(float(a) for a in kt.T.ravel()), xo, yo, uo, vo


def _pixel_owners(la: LensArray, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flat lens index ``i * Lx + j`` of the lens owning each pixel, and whether one does."""
    centres, _, inside = pixel_rays(la)
    if la.grid == "lattice":
        s, t = lattice_coordinates(*la.basis_vectors(), centres[..., 0], centres[..., 1])
        owner = np.where(inside, np.rint(la.lenses_y / 2 - 0.5 - t) * la.lenses_x + np.rint(s + la.lenses_x / 2 - 0.5), -1)
        return owner.astype(np.int64), inside
    lattice = la.lattice_centres()
    cx, cy = la.to_lattice(centres[..., 0], centres[..., 1])
    j = np.rint((cx - lattice[0, 0, 0]) / la.pitch_x - (np.rint((lattice[0, 0, 1] - cy) / la.pitch_y) % 2) * 0.5 * (la.grid == "hex"))
    i = np.zeros_like(j) if la.grid == "lenticular" else np.rint((lattice[0, 0, 1] - cy) / la.pitch_y)
    owner = np.where(inside, i * la.lenses_x + j, -1)
    return owner.astype(np.int64), inside
