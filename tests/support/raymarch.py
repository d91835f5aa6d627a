"""A NumPy ray-march of the emission-absorption integral: the oracle of the direct volume render.

For a ray ``p(s) = o + s d`` (display mm, ``|d| = 1``) through a volume placed by
``world_to_display``, with emission ``e`` and extinction ``sigma`` from the
transfer function (per mm of the volume, so per display mm divided by the
placement's scale),

    C = integral e(s) T(s) ds + B T(L),     T(s) = exp(-integral_0^s sigma).

The values along the ray are the voxel values clipped to the transfer's window,
trilinearly interpolated between voxel centres and held constant to the box
faces (voxel centres +- half a voxel); for a label volume, the label of the
nearest voxel centre.  The march takes steps of ``h`` mm and
treats ``e`` and ``sigma`` as constant within a step (their values at its
middle), integrating that step exactly: ``T e (1 - exp(-sigma h)) / sigma``.
The error is second order in ``h``.  Written from the definition, sharing no
code with ``povh3d.renderer.content.volume_media``.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import map_coordinates

from povh3d.volume.grid import Volume
from povh3d.volume.transfer import Transfer


def square_pixel_rays(lens_array, cols: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lens centre (on ``z = 0``) and unit direction of pixels ``(col, row)`` of a square array with
    whole pixels per lens and no margin, straight from the conventions' formulas."""
    la, p = lens_array, lens_array.panel
    nx, ny = round(la.pitch_x / p.pitch_x), round(la.pitch_y / p.pitch_y)
    j, i = cols // nx, rows // ny
    X = (cols + 0.5 - p.width / 2) * p.pitch_x
    Y = (p.height / 2 - rows - 0.5) * p.pitch_y
    cx = (j + 0.5 - la.lenses_x / 2) * la.pitch_x
    cy = (la.lenses_y / 2 - i - 0.5) * la.pitch_y
    d = np.stack([X - cx, Y - cy, np.full(X.shape, la.focal)], axis=-1)
    return np.stack([cx, cy, np.zeros_like(cx)], axis=-1), d / np.linalg.norm(d, axis=-1, keepdims=True)


def march(volume: Volume, world_to_display: np.ndarray, transfer: Transfer, centres: np.ndarray,
          directions: np.ndarray, *, background=(0.0, 0.0, 0.0), step: float = 0.01) -> np.ndarray:
    """(K, 3) linear RGB each ray ``centres + s directions`` (s from -inf) shows; ``step`` in display mm."""
    w = np.asarray(world_to_display, dtype=np.float64)
    scale = abs(np.linalg.det(w[:3, :3])) ** (1 / 3)
    to_index = np.linalg.inv(w @ volume.index_to_world())
    o = centres @ to_index[:3, :3].T + to_index[:3, 3]
    d = directions @ to_index[:3, :3].T
    # Slabs of the physical box in index space.
    lo, hi = -0.5, np.asarray(volume.shape, dtype=np.float64) - 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - o) / d, (hi - o) / d
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    control = np.asarray(transfer.values, dtype=np.float64)
    emission = np.asarray(transfer.colour) * np.asarray(transfer.extinction)[:, None] / scale
    extinction = np.asarray(transfer.extinction, dtype=np.float64) / scale
    if transfer.kind == "relative":
        raise NotImplementedError("the oracle takes absolute and label transfers")
    labels = transfer.kind == "labels"
    if labels:  # nearest voxel; a label the transfer does not list is clear
        top = int(max(control.max(), np.max(volume.values))) + 1
        table_e, table_s = np.zeros((top, 3)), np.zeros(top)
        table_e[control.astype(int)], table_s[control.astype(int)] = emission, extinction
        window = np.asarray(volume.values)
    else:
        window = np.clip(np.asarray(volume.values, dtype=np.float64), control[0], control[-1])
    colour = np.zeros((len(o), 3))
    for k in np.flatnonzero(far > near):
        n = max(1, int(np.ceil((far[k] - near[k]) / step)))
        h = (far[k] - near[k]) / n
        s = near[k] + (np.arange(n) + 0.5) * h
        points = o[k][:, None] + d[k][:, None] * s  # (3, n) voxel index
        if labels:
            v = window[tuple(np.clip(np.floor(points + 0.5).astype(int), 0, np.array(window.shape)[:, None] - 1))]
            sig, e = table_s[v], table_e[v]
        else:
            v = map_coordinates(window, points, order=1, mode="nearest")
            sig = np.interp(v, control, extinction)
            e = np.stack([np.interp(v, control, emission[:, c]) for c in range(3)], axis=1)
        tau = sig * h
        before = np.exp(-np.concatenate([[0.0], np.cumsum(tau)[:-1]]))
        through = np.where(tau > 1e-12, -np.expm1(-tau) / np.where(sig > 0, sig, 1.0), h)
        colour[k] = (e * (before * through)[:, None]).sum(axis=0) + np.asarray(background) * np.exp(-tau.sum())
    miss = ~(far > near)
    colour[miss] = background
    return colour
