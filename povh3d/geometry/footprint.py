"""Where inside a pixel's footprint the rays of a render go (pure NumPy).

docs/geometry.md, "Pixel footprint": a panel pixel behind a lens sends light
through the whole lens aperture over the angular range of its own width.  A
sample is one point of that 4D box, given as fractions in ``[-0.5, 0.5)``:
``(ax, ay)`` of the lens pitch across the aperture and ``(du, dv)`` of the
pixel pitch across the angle.  The ray of the sample goes through
``c + (ax*px, ay*py, 0)`` with direction ``(u + du*s, v + dv*s, f)``; the
sample ``(0, 0, 0, 0)`` is the ray of the pixel itself.
"""

from __future__ import annotations

import numpy as np

CENTRE = np.zeros((1, 4))
#: Samples sit on a grid of 1/GRID: a view bank's corners (``cameras.bank_front_clearance``)
#: then stay exact in POV-Ray's single precision, and a cropped bank traces the very
#: rays of the uncropped one.
GRID = 2048


def on_grid(samples: np.ndarray, low: np.ndarray | float = -0.5, high: np.ndarray | float = 0.5) -> np.ndarray:
    """Samples rounded to the nearest multiple of ``1/GRID`` within ``[low, high)``
    (an interval at least ``1/GRID`` long, so one exists: a stratum keeps its sample)."""
    q = np.round(np.asarray(samples, dtype=np.float64) * GRID) / GRID
    q = np.where(q < low, np.ceil(np.asarray(low) * GRID) / GRID, q)
    return np.where(q >= high, (np.ceil(np.asarray(high) * GRID) - 1) / GRID, q)


def angular_grid(n: int) -> np.ndarray:
    """``n x n`` sub-views per view: the pixel's angular width cut in a grid.

    The aperture is left to POV-Ray's antialiasing, which an orthographic view
    pixel spans; the angle is what it cannot reach.

    Returns
    -------
    (n*n, 4) float: ``(0, 0, du, dv)`` at the centres of the grid cells (``on_grid``).
    """
    if n < 1:
        raise ValueError(f"sub-views per axis must be at least 1, got {n}")
    steps = (np.arange(n) + 0.5) / n - 0.5
    du, dv = np.meshgrid(steps, steps, indexing="xy")
    zeros = np.zeros(n * n)
    return on_grid(np.stack([zeros, zeros, du.ravel(), dv.ravel()], axis=1))


def latin_hypercube(count: int, seed: int = 0) -> np.ndarray:
    """``count`` jittered samples of the whole 4D footprint, stratified per axis.

    Each axis is cut into ``count`` strata, each hit exactly once at a random
    point, the strata paired at random across axes: a reference converges
    faster than with independent uniform samples and stays unbiased.

    Returns
    -------
    (count, 4) float in ``[-0.5, 0.5)``, on the ``1/GRID`` grid.
    """
    if not 1 <= count <= GRID:
        raise ValueError(f"footprint samples must be 1 to {GRID}, got {count}")
    rng = np.random.default_rng(seed)
    strata = np.stack([rng.permutation(count) for _ in range(4)], axis=1)
    # Each sample stays in its stratum (1/count >= 1/GRID wide) on the grid.
    return on_grid((strata + rng.random((count, 4))) / count - 0.5, strata / count - 0.5, (strata + 1) / count - 0.5)
