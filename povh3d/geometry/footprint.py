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


#: Sobol' direction numbers of the footprint's four axes (Joe and Kuo's table: the first axis is
#: van der Corput's, then each axis's primitive polynomial degree ``s``, its coefficients ``a`` and
#: its first ``m``), and the bits each point carries (``GRID`` needs 11).
_SOBOL_AXES = ((1, 0, (1,)), (1, 0, (1,)), (2, 1, (1, 3)), (3, 1, (1, 3, 1)))
_SOBOL_BITS = 32


def _sobol_directions() -> np.ndarray:
    """``(4, _SOBOL_BITS)`` direction numbers ``v_k = m_k 2^(B - k)`` (k from 1)."""
    out = np.zeros((4, _SOBOL_BITS), np.uint64)
    for axis, (s, a, m0) in enumerate(_SOBOL_AXES):
        m = [1] * _SOBOL_BITS if axis == 0 else list(m0)
        while len(m) < _SOBOL_BITS:   # m_k = 2 a_1 m_(k-1) ^ 4 a_2 m_(k-2) ^ ... ^ 2^s m_(k-s) ^ m_(k-s)
            k = len(m)
            new = m[k - s] ^ (m[k - s] << s)
            for i in range(1, s):
                if (a >> (s - 1 - i)) & 1:
                    new ^= m[k - i] << i
            m.append(new)
        out[axis] = [mk << (_SOBOL_BITS - 1 - k) for k, mk in enumerate(m)]
    return out


def scrambled_sobol(count: int, seed: int | None, start: int = 0) -> np.ndarray:
    """Points ``start`` to ``start + count`` of a Sobol' sequence of the 4D footprint, scrambled by
    ``seed`` (a random lower-triangular bit matrix and a random digital shift per axis, as Matousek's
    linear scrambling): ``(count, 4)`` in ``[-0.5, 0.5)`` on the ``1/GRID`` grid.

    Each point is uniform (unbiased), another seed is independent, and any ``2^m`` points from a
    multiple of ``2^m`` hit each of ``2^m`` strata of every axis once, and stratify the axes' planes
    too: a footprint integral converges faster than from a Latin hypercube, which stratifies only
    the axes.  Continuing from ``start`` extends the same sequence.  ``seed`` None: the sequence
    itself, unscrambled (Gray code order)."""
    bits = _SOBOL_BITS
    rng = np.random.default_rng(seed)
    # Bit r (from the most significant) of a scrambled number is the parity of its bits 0..r under row r.
    lower = np.tril(rng.integers(0, 2, (4, bits, bits), dtype=np.uint8), -1) | np.eye(bits, dtype=np.uint8)
    shift = rng.integers(0, 2 ** bits, 4, dtype=np.uint64)
    if seed is None:
        lower, shift = np.broadcast_to(np.eye(bits, dtype=np.uint8), (4, bits, bits)), np.zeros(4, np.uint64)
    weights = np.uint64(1) << np.arange(bits - 1, -1, -1, dtype=np.uint64)   # bit r's value
    direction_bits = ((_sobol_directions()[..., None] >> (np.uint64(bits - 1) - np.arange(bits, dtype=np.uint64)))
                      & np.uint64(1)).astype(np.uint8)   # (axis, k, bit from the most significant)
    scrambled = np.einsum("akc,arc->akr", direction_bits, lower.astype(np.int64)) % 2
    directions = (scrambled.astype(np.uint64) * weights).sum(axis=-1, dtype=np.uint64)   # (axis, k)
    index = np.arange(start, start + count, dtype=np.uint64)
    index ^= index >> np.uint64(1)   # Gray code order (as Antonov and Saleev; the same 2^m sets)
    points = np.zeros((count, 4), np.uint64)
    for k in range(bits):
        points ^= ((index >> np.uint64(k)) & np.uint64(1))[:, None] * directions[:, k]
    unit = (points ^ shift).astype(np.float64) / 2.0 ** bits
    # Floor onto the grid: a uniform point in [0, 1) lands on each of GRID cells alike.
    return np.floor(unit * GRID) / GRID - 0.5
