"""Direct volume rendering: a volume as POV-Ray participating media (``density_file df3``), its files.

``media_stage`` writes the volume's values, mapped through the transfer
function's value window, as a df3 file, and a stage scene (no camera) whose
hollow box holds two media sharing that density: one emits ``e`` (an RGB
colour map of the density), one absorbs ``sigma`` (a grey one).  The box is
the volume's physical box in voxel index space, moved onto the display by one
``matrix`` (index -> LPS world mm -> display mm).  What POV-Ray integrates and
how it samples a ray is in docs/volume-rendering.md.  The numbers (samples,
colour maps, sampling) come from ``volume/media.py``, the scene text from
``renderer/content/stage_text.py``; this module writes the files.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

import numpy as np

from .stage_text import media_stage_text
from ...jsontext import JSONValue
from ...errors import ConfigError, param
from ...geometry.lens_array import LensArray
from ...image.io import atomic_path, file_sha256
from ...volume.df3 import df3_bytes, padded_shape
from ...volume.grid import Volume
from ...volume.media import present_labels, classify, sampling_for, sub_intervals, uniform_scale
from ...volume.transfer import AUTO, Transfer, auto_transfer, load_transfer


def _write_once(path: Path, data: bytes, sha256: str) -> None:
    """Write ``data`` at ``path`` unless the file there holds it already (its hash is checked: a damaged
    file of the same size is written again, never handed to POV-Ray)."""
    if path.is_file() and path.stat().st_size == len(data) and file_sha256(path) == sha256:
        return
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def media_stage(volume: Volume, world_to_display: np.ndarray, lens_array: LensArray, *,
                transfer: str | Path | Transfer = "ct-soft", bits: int = 16, folder: Path,
                step: float = 1.0, background: tuple[float, float, float] = (0.0, 0.0, 0.0),
                ) -> tuple[Path, dict[str, JSONValue]]:
    """Write the df3 file and a stage scene (no camera) into ``folder``; return the scene and its record.

    ``world_to_display`` (4, 4) maps the volume's LPS world mm to display mm
    (``volume.orient.world_to_display``); ``transfer`` is a preset name, a file or a
    ``Transfer``; ``bits`` the df3 value width; ``step`` the distance between media
    samples along a ray, in voxels (of the smallest side); ``background`` linear RGB.
    Files are named by their content, so an unchanged volume is not written again.
    """
    started = time.perf_counter()
    if not isinstance(transfer, Transfer):
        if str(transfer) == AUTO:
            transfer = auto_transfer(volume.values, bool(volume.label_names))
        labels = present_labels(volume.values).tolist() if str(transfer) == "labels" else None
        transfer = load_transfer(transfer, labels)
    if bits not in (8, 16):
        raise ConfigError(f"{param('df3_bits')} must be 8 or 16, got {bits!r}")
    scale = uniform_scale(world_to_display)
    intervals, samples = sampling_for(volume, step)
    red, green, blue = (float(c) for c in np.broadcast_to(np.asarray(background, dtype=np.float64), 3))
    background = red, green, blue
    if not all(np.isfinite(background)) or min(background) < 0:
        raise ConfigError(f"the background must be three non-negative numbers, got {background}")
    classified = classify(volume, transfer, bits)
    data = df3_bytes(classified.pop("samples"), bits)
    encoded = time.perf_counter()
    digest = hashlib.sha256(data).hexdigest()
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    df3_path = folder / f"volume-{digest[:16]}.df3"
    _write_once(df3_path, data, digest)
    text = media_stage_text(volume, world_to_display, classified, transfer, df3_name=df3_path.name,
                            intervals=intervals, samples=samples, background=background).encode()
    text_digest = hashlib.sha256(text).hexdigest()
    stage = folder / f"volume-media-{text_digest[:16]}.pov"
    _write_once(stage, text, text_digest)
    record: dict[str, JSONValue] = {"kind": "media", "volume": volume.as_record(), "transfer": transfer.as_record(),
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
