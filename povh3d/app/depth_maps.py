"""``--depth-maps DIR``: per view, the distance along each ray to the first surface, and its disparity.

For view ``(l, k)`` (docs/geometry.md: direction ``(u_k, v_l, f)``), pixel
``(i, j)`` is the ray through lens ``(j, i)``.  ``d_LLL_KKK.npy`` holds, as
float32 millimetres of the display frame, the distance along that ray from the
screen (where the ray crosses ``z = 0``) to the first surface: negative in
front of the screen, NaN where nothing is hit.  ``p_LLL_KKK.npy`` holds the
matching disparity in view pixels (lenses) per view step, ``z s / (f p)`` with
``z`` the hit's depth ``d / |(u/f, v/f, 1)|``: a point at depth ``z`` moves by
that many lenses from one view to the next.  ``depth_maps.json`` says all this
and records the frame.  Every file is written atomically.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import OutputError
from ..geometry.lens_array import LensArray
from ..image.io import atomic_path


def check_depth_dir(folder: Path) -> None:
    """Before any work: the folder exists or can be made, and is a folder."""
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"--depth-maps {str(folder)!r} is a file; give a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create --depth-maps folder {str(folder)!r}: {exc.strerror}") from None


def disparity(depth: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """(Ny, Nx, Ly, Lx) ray distances (mm) -> disparity in lenses per view step (horizontal)."""
    ny, nx = depth.shape[:2]
    s, f, p = lens_array.panel.pitch_x, lens_array.focal, lens_array.pitch_x
    a = (np.arange(nx) + 0.5 - nx / 2) * s / f
    b = (ny / 2 - np.arange(ny) - 0.5) * lens_array.panel.pitch_y / f
    length = np.sqrt(a[None, :] ** 2 + b[:, None] ** 2 + 1.0)
    z = depth / length[:, :, None, None]
    return (z * s / (f * p)).astype(np.float32)


def write_depth_maps(folder: Path, depth: np.ndarray, lens_array: LensArray, record: dict[str, Any]) -> None:
    """Write ``d_*.npy``, ``p_*.npy`` and ``depth_maps.json`` into ``folder``."""
    par = disparity(depth, lens_array)
    ny, nx = depth.shape[:2]
    for l in range(ny):
        for k in range(nx):
            for prefix, data in (("d", depth[l, k]), ("p", par[l, k])):
                buffer = io.BytesIO()
                np.save(buffer, data)
                with atomic_path(folder / f"{prefix}_{l:03d}_{k:03d}.npy") as tmp:
                    tmp.write_bytes(buffer.getvalue())
    info = {"views": [ny, nx], "size_px": [depth.shape[3], depth.shape[2]],
            "depth": "d_LLL_KKK.npy: float32 mm of the display frame along each ray, from the screen "
                     "(z = 0, at the lens centre) to the first surface; negative in front; NaN: nothing hit",
            "disparity": "p_LLL_KKK.npy: float32 lenses per view step, z s / (f p), z = d / |(u/f, v/f, 1)|",
            "pixel_pitch_mm": lens_array.panel.pitch_x, "focal_mm": lens_array.focal,
            "lens_pitch_mm": lens_array.pitch_x, "display_frame": record.get("display_frame"),
            "method": "two renders per view with a constant fog of colour 0 and 1 (engine/depth.py)",
            "nan_fraction": float(np.isnan(depth).mean())}
    with atomic_path(folder / "depth_maps.json") as tmp:
        tmp.write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
