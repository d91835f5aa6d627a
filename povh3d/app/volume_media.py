"""Direct volume rendering: a volume as POV-Ray participating media (``density_file df3``).

``media_stage`` writes the volume's values, mapped through the transfer
function's value window, as a df3 file, and a stage scene (no camera) whose
hollow box holds two media sharing that density: one emits ``e`` (an RGB
colour map of the density), one absorbs ``sigma`` (a grey one).  The box is
the volume's physical box in voxel index space, moved onto the display by one
``matrix`` (index -> LPS world mm -> display mm).  What POV-Ray integrates and
how it samples a ray is in docs/volume-rendering.md.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import ConfigError
from ..geometry.lens_array import LensArray
from ..image.io import atomic_path
from ..povray.templates import render_template
from ..volume.df3 import SAMPLE_SHIFT, df3_bytes, padded_shape, quantise
from ..volume.grid import Volume
from ..volume.transfer import AUTO, MAX_LABEL_ENTRIES, Transfer, auto_transfer, load_transfer

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


def _present_labels(values: np.ndarray) -> np.ndarray:
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
        present = _present_labels(values)
        if present.min() < 0 or present.max() > top or np.any(present != np.rint(present)):
            raise ConfigError(f"label values must be whole numbers within 0..{top} for --df3-bits {bits}, "
                              f"the volume has {present.min():g}..{present.max():g}"
                              + ("; use --df3-bits 16" if bits == 8 and present.max() <= 65535 else ""))
        entries = np.union1d(present, [0]).astype(np.int64)
        if len(entries) > MAX_LABEL_ENTRIES:
            raise ConfigError(f"the volume holds {len(entries)} distinct labels; POV-Ray's colour maps hold "
                              f"{MAX_LABEL_ENTRIES}: render surfaces with --labels instead")
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


def stage_text(volume: Volume, world_to_display: np.ndarray, classified: dict[str, Any], transfer: Transfer, *,
               df3_name: str, intervals: int, samples: int, background: tuple[float, float, float]) -> str:
    scale = uniform_scale(world_to_display)
    index_to_display = np.asarray(world_to_display, dtype=np.float64) @ volume.index_to_world()
    n = np.asarray(volume.shape, dtype=np.float64)
    offset = 1.0 + SAMPLE_SHIFT[classified["interpolate"]]
    return render_template(
        "volume_media.pov.j2", version=__version__, volume_name=volume.name, transfer=transfer.name,
        interpolate=classified["interpolate"], scale=scale, background=background, df3=df3_name,
        grid=padded_shape(volume.shape), offset=offset, intervals=intervals, samples=samples,
        box_lo=(-0.5, -0.5, -0.5), box_hi=tuple((n - 0.5).tolist()), coefficient=1.0 / scale,
        emission_map=classified["emission_map"], extinction_map=classified["extinction_map"],
        matrix=pov_matrix(index_to_display))


def _write_once(path: Path, data: bytes) -> None:
    if not path.is_file() or path.stat().st_size != len(data):
        with atomic_path(path) as tmp:
            tmp.write_bytes(data)


def media_stage(volume: Volume, world_to_display: np.ndarray, lens_array: LensArray, *,
                transfer: str | Path | Transfer = "ct-soft", bits: int = 16, folder: Path,
                step: float = 1.0, background: tuple[float, float, float] = (0.0, 0.0, 0.0),
                ) -> tuple[Path, dict[str, Any]]:
    """Write the df3 file and a stage scene (no camera) into ``folder``; return the scene and its record.

    ``world_to_display`` (4, 4) maps the volume's LPS world mm to display-frame mm
    (``volume.orient.world_to_display``); ``transfer`` is a preset name, a file or a
    ``Transfer``; ``bits`` the df3 value width; ``step`` the distance between media
    samples along a ray, in voxels (of the smallest side); ``background`` linear RGB.
    Files are named by their content, so an unchanged volume is not written again.
    """
    started = time.perf_counter()
    if not isinstance(transfer, Transfer):
        if str(transfer) == AUTO:
            transfer = auto_transfer(volume.values, bool(volume.label_names))
        labels = _present_labels(volume.values).tolist() if str(transfer) == "labels" else None
        transfer = load_transfer(transfer, labels)
    if bits not in (8, 16):
        raise ConfigError(f"--df3-bits must be 8 or 16, got {bits!r}")
    scale = uniform_scale(world_to_display)
    intervals, samples = sampling_for(volume, step)
    background = tuple(float(c) for c in np.broadcast_to(np.asarray(background, dtype=np.float64), 3))
    if not all(np.isfinite(background)) or min(background) < 0:
        raise ConfigError(f"the background must be three non-negative numbers, got {background}")
    classified = classify(volume, transfer, bits)
    data = df3_bytes(classified.pop("samples"), bits)
    encoded = time.perf_counter()
    digest = hashlib.sha256(data).hexdigest()[:16]
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    df3_path = folder / f"volume-{digest}.df3"
    _write_once(df3_path, data)
    text = stage_text(volume, world_to_display, classified, transfer, df3_name=df3_path.name,
                      intervals=intervals, samples=samples, background=background)
    stage = folder / f"volume-media-{hashlib.sha256(text.encode()).hexdigest()[:16]}.pov"
    _write_once(stage, text.encode())
    record = {"kind": "media", "volume": volume.as_record(), "transfer": transfer.as_record(),
              "df3": {"path": str(df3_path), "bits": bits, "shape": list(padded_shape(volume.shape)),
                      "bytes": len(data), "interpolate": classified["interpolate"],
                      "window": classified["window"]},
              "scale": scale, "media": {
                  "method": 3, "intervals": intervals, "samples": samples,
                  "sub_intervals": intervals * sub_intervals(samples), "step_voxels": float(step)},
              # How many voxels one lens (the display's 3D pixel) spans: detail finer than that is lost.
              "voxels_per_lens": round(lens_array.pitch_x / (min(volume.spacing) * scale), 3),
              "seconds": {"df3_encode": round(encoded - started, 4),
                          "write": round(time.perf_counter() - encoded, 4)}}
    return stage, record
