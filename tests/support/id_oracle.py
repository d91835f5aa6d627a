"""Object-id oracle: the id of the first analytic shape (sphere, axis-aligned box) along each
pixel's conventions ray, and the pixels clear enough of lens borders and object edges to score."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from povh3d.geometry.lens_array import LensArray
from povh3d.geometry.rays import pixel_rays
from tests.support.hit_oracle import border_margin_px

# ("sphere", centre, radius) or ("box", min corner, max corner), display mm; id = place in the list + 1
Shape = tuple[str, Sequence[float], object]


def first_hit_ids(origins: np.ndarray, directions: np.ndarray, shapes: Sequence[Shape]) -> np.ndarray:
    """(H, W) id of the first shape along the whole line ``origins + t directions`` (also in front of
    the screen), 0 where it meets none."""
    best = np.full(origins.shape[:2], np.inf)
    ids = np.zeros(origins.shape[:2], np.int64)
    for ident, (kind, a, b) in enumerate(shapes, start=1):
        if kind == "sphere":
            oc = origins - np.asarray(a)
            proj = (oc * directions).sum(-1)
            disc = proj * proj - ((oc * oc).sum(-1) - float(b) ** 2)
            t = np.where(disc > 0, -proj - np.sqrt(np.maximum(disc, 0)), np.inf)
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                t0, t1 = (np.asarray(a) - origins) / directions, (np.asarray(b) - origins) / directions
            near = np.nanmax(np.minimum(t0, t1), -1)
            far = np.nanmin(np.maximum(t0, t1), -1)
            t = np.where(near < far, near, np.inf)
        ids = np.where(t < best, ident, ids)
        best = np.minimum(best, t)
    return ids


def expected_ids(lens_array: LensArray, shapes: Sequence[Shape]) -> tuple[np.ndarray, np.ndarray]:
    """The ids of every pixel's ray and where they can be scored: away from lens borders and from
    object edges (the id is the same for the ray moved half a lens pitch each way)."""
    c, d, inside = pixel_rays(lens_array)
    origins = np.concatenate([np.nan_to_num(c), np.zeros(c.shape[:2] + (1,))], axis=-1)
    d = np.nan_to_num(d, nan=1.0)
    want = first_hit_ids(origins, d, shapes)
    clear = inside & (border_margin_px(lens_array) > 0.1)
    step = lens_array.pitch_x / 2
    for shift in ((step, 0, 0), (-step, 0, 0), (0, step, 0), (0, -step, 0)):
        clear &= first_hit_ids(origins + np.array(shift), d, shapes) == want
    return want, clear
