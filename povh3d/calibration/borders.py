"""Dark-border correction driven by the lens grid (thesis 4.3).

The white image taught the grid each lens's response: the template micro-image
(peak 1) and the lens's gain.  A capture is divided by that response wherever
the lens passes at least ``threshold`` of its peak (flat-fielding: the gradual
darkening toward the borders and the vignetting go); the remaining thin band
between micro-images is the MLA's dark border, which the thesis does not erase
but "refines" so it aligns with the playback array: here it becomes uniformly
black (``fill='black'``) or takes the nearest corrected pixel
(``fill="nearest"``; near a lens corner that pixel may belong to the neighbour).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..errors import ConfigError, InputError
from ..image.colour import from_linear, to_linear
from .gridfile import Grid
from .template import Template

FILLS = ("black", "nearest")


def white_response(grid: Grid) -> np.ndarray:
    """The grid's prediction of the white image, ``(H, W)`` linear."""
    if grid.template is None or grid.gain is None:
        raise InputError("this grid has no white-response template; make it with 'povh3d calibrate' from a white image")
    w, h = grid.image_size
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    pts = np.stack([xx, yy], axis=-1)
    i, j, centre = grid.lens_of_pixels(pts)
    # The template lives in the ideal (undistorted) frame, like the lattice.
    d = pts - centre if grid.distortion.is_identity else grid.distortion.undistort(pts) - grid.distortion.undistort(centre)
    t, _, _ = Template(grid.template, grid.template_step).sample(d[..., 0], d[..., 1])
    rows, cols = grid.table
    gain = grid.gain[np.clip(i, 0, rows - 1), np.clip(j, 0, cols - 1)]
    return t * gain


def correct_borders(image: np.ndarray, grid: Grid, *, threshold: float = 0.5,
                    fill: str = "black") -> tuple[np.ndarray, np.ndarray]:
    """Flat-field the micro-images and clean the borders between them.

    Returns the corrected image (same dtype) and the ``(H, W)`` bool border mask.
    """
    if not 0 < threshold < 1:
        raise ConfigError(f"threshold must be between 0 and 1 (a fraction of the lens's peak), got {threshold!r}")
    if fill not in FILLS:
        raise ConfigError(f"fill must be one of {', '.join(FILLS)}, got {fill!r}")
    grid.check_image(image.shape)
    response = white_response(grid)
    assert grid.gain is not None  # white_response raised otherwise
    w, h = grid.image_size
    rows, cols = grid.table
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    i, j, _ = grid.lens_of_pixels(np.stack([xx, yy], axis=-1))
    gain = grid.gain[np.clip(i, 0, rows - 1), np.clip(j, 0, cols - 1)]
    border = response < threshold * np.maximum(gain, 1e-12)
    lin, dtype = to_linear(image), image.dtype
    scale = np.where(border, 0.0, 1.0 / np.maximum(response, 1e-12))
    out = lin * (scale if lin.ndim == 2 else scale[..., None])
    if fill == "nearest" and border.any() and not border.all():
        idx = ndimage.distance_transform_edt(border, return_distances=False, return_indices=True)
        out = out[idx[0], idx[1]]
    return from_linear(out, dtype), border
