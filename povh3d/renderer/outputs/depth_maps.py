"""``--depth-maps DIR``: per view, the distance along each ray to the first surface, and its disparity.

For view ``(l, k)`` (docs/geometry.md: direction ``(u_k, v_l, f)``), pixel
``(i, j)`` is the ray through lens ``(j, i)``.  ``d_LLL_KKK.npy`` holds, as
float32 display millimetres, the distance along that ray from the
screen (where the ray crosses ``z = 0``) to the first surface: negative in
front of the screen, NaN where nothing is hit.  ``p_LLL_KKK.npy`` holds the
matching disparity in view pixels (lenses) per view step, ``z s / (f p)`` with
``z`` the hit's depth ``d / |(u/f, v/f, 1)|``: a point at depth ``z`` moves by
that many lenses from one view to the next (``geometry.rays.disparity``).
``depth_maps.json`` says all this and records the placement.  The folder is replaced whole
(``views.replaced_whole``): the maps of an older render never stay beside the new manifest, and a
non-empty folder without povh3d's ``depth_maps.json`` is refused, never deleted.

With ``--depth-format png`` the maps are 16-bit greyscale PNGs instead
(``d_LLL_KKK.png``, ``p_LLL_KKK.png``): code 0 is "nothing hit" (NaN), codes
1..65535 are ``offset + (code - 1) * scale``, one scale and offset for all the
views of a kind, recorded in ``depth_maps.json``; the rounding is at most half
a ``scale`` (``image.depth_codes``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import OutputError, param, plain, warn
from ...geometry.lens_array import LensArray
from ...geometry.rays import disparity
from ...image.depth_codes import quantise
from ..._version import __version__
from .views import check_replaced_dir, replaced_whole
from ...image.sidecar import Sidecar
from ...jsontext import JSONValue


def check_depth_dir(folder: Path) -> None:
    """Before any work: the folder new, empty or a depth-maps folder povh3d wrote (it is replaced whole)."""
    check_replaced_dir(folder, MANIFEST, _ours, param("depth_maps"))


MANIFEST = "depth_maps.json"


def _ours(record: Mapping[str, JSONValue]) -> bool:
    # povh3d_version since issue 38; before, the fields only depth_maps.json has
    return record.get("kind") == "depth_maps" or {"depth", "disparity", "views", "method"} <= record.keys()


DEPTH_FORMATS = ("npy", "png")


def write_depth_maps(folder: Path, depth: np.ndarray, lens_array: LensArray, record: Sidecar,
                     fmt: str = "npy") -> None:
    """Write ``d_*.npy``, ``p_*.npy`` (``fmt`` 'png': 16-bit PNGs) and ``depth_maps.json`` into ``folder``."""
    from ...image.io import write_png

    if not np.isfinite(depth).any():   # never a silent all-NaN folder
        warn(f"the depth maps in {str(folder)!r} are all NaN: the depth pass measured no pixel (nothing in the "
             "field, or every ray starts inside a solid); check the scene and the placement")
    par = disparity(depth, lens_array)
    ny, nx = depth.shape[:2]
    codes = {"d": quantise(depth), "p": quantise(par)} if fmt == "png" else {}
    info: dict[str, JSONValue] = {
            "povh3d_version": __version__, "kind": "depth_maps",
            "views": [ny, nx], "size_px": [depth.shape[3], depth.shape[2]], "format": fmt,
            "depth": "d_LLL_KKK: display mm along each ray, from the screen "
                     "(z = 0, at the lens centre) to the first surface; negative in front; NaN: nothing hit",
            "disparity": "p_LLL_KKK: lenses per view step, z s / (f p), z = d / |(u/f, v/f, 1)|",
            "pixel_pitch_mm": lens_array.panel.pitch_x, "focal_mm": lens_array.focal,
            "lens_pitch_mm": lens_array.pitch_x, "placement": record.get("placement"),
            "method": ("two renders of every view's rays (one mesh camera) with a constant fog of colour 0 and 1 "
                       "(renderer/passes/depth.py)"),
            "nan_fraction": float(np.isnan(depth).mean())}
    if fmt == "png":
        png: dict[str, JSONValue] = {name: {"scale": codes[p][1], "offset": codes[p][2]}
                                     for name, p in (("depth", "d"), ("disparity", "p"))}
        png["decode"] = ("16-bit greyscale: code 0 = nothing hit (NaN); else value = offset + "
                         "(code - 1) * scale (mm for d_, lenses per view step for p_), within scale / 2")
        info["png"] = png
    else:
        info["npy"] = "float32 arrays (numpy.load), NaN where nothing is hit"
    try:
        with replaced_whole(folder, "depth-maps") as tmp:   # never old maps beside the new manifest
            for l in range(ny):
                for k in range(nx):
                    for prefix, data in (("d", depth[l, k]), ("p", par[l, k])):
                        if fmt == "png":
                            write_png(tmp / f"{prefix}_{l:03d}_{k:03d}.png", codes[prefix][0][l, k])
                            continue
                        np.save(tmp / f"{prefix}_{l:03d}_{k:03d}.npy", data)
            (tmp / MANIFEST).write_text(json.dumps(plain(info), indent=2) + "\n", encoding="utf-8")
    except OSError as exc:
        raise OutputError(f"cannot write the depth maps in {str(folder)!r}: {exc.strerror or exc}; the previous "
                          "maps, if any, are unchanged") from None
