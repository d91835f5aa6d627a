"""A volume as POV-Ray participating media, the numbers: its samples, colour maps and sampling.

Pure functions of a ``Volume`` and a ``Transfer``: ``classify`` quantises the
values through the transfer's window into df3 samples and colour maps,
``sampling_for`` chooses POV-Ray's ``intervals`` and ``samples``, and
``uniform_scale`` / ``pov_matrix`` check and format the placement.  The files and
the stage scene are written by ``renderer/content/volume_media.py``; what POV-Ray integrates is
in docs/volume-rendering.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ConfigError, param
from .df3 import quantise
from .grid import Volume
from .transfer import MAX_LABEL_ENTRIES, Transfer

#: POV-Ray 3.7 holds at most 256 media intervals per ray (MEDIA_INTERVAL_VECTOR_SIZE; more is
#: "internal nesting limit reached"), two of which it may add itself; finer sampling takes more
#: samples per interval instead.
MAX_INTERVALS = 250


def uniform_scale(world_to_display: np.ndarray) -> float:
    """The scale of a similarity (rotation or reflection times a scale); other maps are refused,
    since media coefficients per mm only keep their meaning under a uniform scale."""
    m = np.asarray(world_to_display, dtype=np.float64)
    if m.shape != (4, 4) or not np.all(np.isfinite(m)) or not np.allclose(m[3], [0, 0, 0, 1]):
        raise ConfigError("world_to_display must be a finite affine (4, 4) matrix")
    a = m[:3, :3]
    scale = abs(np.linalg.det(a)) ** (1.0 / 3.0)
    if scale <= 0 or not np.allclose(a.T @ a, scale**2 * np.eye(3), rtol=1e-6, atol=1e-9 * scale**2):
        raise ConfigError("the volume's placement on the display must be a rotation and one uniform scale")
    return float(scale)


def pov_matrix(m: np.ndarray) -> list[float]:
    """POV-Ray's ``matrix <12 numbers>`` for the column-vector map ``p' = m @ (p, 1)``:
    POV-Ray's rows are the images of the axes, then the translation."""
    m = np.asarray(m, dtype=np.float64)
    return [*m[:3, :3].T.ravel().tolist(), *m[:3, 3].tolist()]


def present_labels(values: np.ndarray) -> np.ndarray:
    if np.issubdtype(values.dtype, np.integer) and values.min() >= 0:
        return np.flatnonzero(np.bincount(values.ravel(order="K")))  # K: no copy of a VTK (Fortran) array
    return np.unique(values)


def _window_samples(values: np.ndarray, lo: float, hi: float, bits: int) -> np.ndarray:
    """``(values - lo) / (hi - lo)`` quantised, a slab of slices at a time (a CT is hundreds of MB
    as float32); NaN counts as ``lo``."""
    samples = np.empty(values.shape, dtype=np.uint8 if bits == 8 else np.uint16, order="F")  # as df3 is laid out
    slab = max(1, 4_000_000 // max(1, values.shape[0] * values.shape[1]))
    for k in range(0, values.shape[2], slab):
        fractions = np.asarray(values[:, :, k:k + slab], dtype=np.float32) - np.float32(lo)
        fractions /= np.float32(hi - lo)
        samples[:, :, k:k + slab] = quantise(np.nan_to_num(fractions, copy=False), bits)
    return samples


def classify(volume: Volume, transfer: Transfer, bits: int) -> dict[str, Any]:
    """The quantised df3 samples, the colour maps (density -> emission, extinction) and how to sample.

    Scalar transfers: the density is the value's place in the transfer's window
    (its first to last control value), clipped, so colour map entries sit at the
    control points and POV-Ray's linear colour-map blending is the transfer's own.
    Labels: the density is the label itself (``label / (2^bits - 1)``) sampled at
    the nearest voxel, with one colour map entry for each value present.
    """
    values = volume.values
    top = (1 << bits) - 1
    if transfer.kind == "labels":
        present = present_labels(values)
        if present.min() < 0 or present.max() > top or np.any(present != np.rint(present)):
            raise ConfigError(f"label values must be whole numbers within 0..{top} for {param('df3_bits')} {bits}, "
                              f"the volume has {present.min():g}..{present.max():g}"
                              + (f"; use {param('df3_bits')} 16" if bits == 8 and present.max() <= 65535 else ""))
        entries = np.union1d(present, [0]).astype(np.int64)
        if len(entries) > MAX_LABEL_ENTRIES:
            raise ConfigError(f"the volume holds {len(entries)} distinct labels; POV-Ray's colour maps hold "
                              f"{MAX_LABEL_ENTRIES}: render surfaces with {param('labels')} instead")
        listed = {int(v): k for k, v in enumerate(transfer.values)}
        emission, extinction = transfer.emission, np.asarray(transfer.extinction, dtype=np.float64)
        rows = [(int(v), emission[listed[v]] if v in listed else np.zeros(3),
                 extinction[listed[v]] if v in listed else 0.0) for v in entries.tolist()]
        samples = values.astype(np.uint8 if bits == 8 else np.uint16)
        positions = entries / top
        window = [0.0, float(top)]
        interpolate = 0
        emission_map = [(t, r[1]) for t, r in zip(positions, rows)]
        extinction_map = [(t, r[2]) for t, r in zip(positions, rows)]
    else:
        control = transfer.data_values(values)
        lo, hi = float(control[0]), float(control[-1])
        samples = _window_samples(values, lo, hi, bits)
        positions = (control - lo) / (hi - lo)
        positions[0], positions[-1] = 0.0, 1.0
        window = [lo, hi]
        interpolate = 1
        emission_map = list(zip(positions.tolist(), transfer.emission))
        extinction_map = list(zip(positions.tolist(), np.asarray(transfer.extinction, dtype=np.float64).tolist()))
    return {"samples": samples, "window": window, "interpolate": interpolate,
            "emission_map": [(float(t), [float(x) for x in c]) for t, c in emission_map],
            "extinction_map": [(float(t), float(s)) for t, s in extinction_map]}


def sub_intervals(samples: int) -> int:
    """How many sub-intervals POV-Ray's method 3 cuts an interval into for ``samples`` (media.cpp,
    ComputeMediaAdaptiveSampling: ``max(2, samples // 2 + 1)``)."""
    return max(2, samples // 2 + 1)


def sampling_for(volume: Volume, step: float) -> tuple[int, int]:
    """POV-Ray's ``intervals`` and ``samples`` that cut the longest chord through the box into
    sub-intervals of at most ``step`` of the smallest voxel side (POV-Ray spreads a fixed count
    over every chord, so shorter chords are sampled more finely)."""
    if not (np.isfinite(step) and step > 0):
        raise ConfigError(f"the media step must be a positive number of voxels, got {step!r}")
    size = np.asarray(volume.shape, dtype=np.float64) * np.asarray(volume.spacing, dtype=np.float64)
    sub = int(np.ceil(float(np.linalg.norm(size)) / (step * min(volume.spacing))))
    intervals = max(1, min(MAX_INTERVALS, -(-sub // 2)))
    per = max(2, -(-sub // intervals))
    samples = 2 * (per - 1)
    assert sub_intervals(samples) == per
    return intervals, samples
