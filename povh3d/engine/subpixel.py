"""Exact subpixel rendering of a slanted lenticular panel (``--method subpixel``).

A slanted sheet puts every R, G and B subpixel at its own offset from its
lenticule's axis.  The view-then-map route renders N upright views and gives
each subpixel the nearest of N directions; this method gives each subpixel its
own ray instead (docs/geometry.md, "Rotated lattices"):

- the subpixel is a pixel of the *subpixel panel*: ``3 W x H`` cells of
  ``s/3 x s`` mm, subpixel ``c`` of panel pixel ``(col, row)`` at column
  ``3 col + c`` (R, G, B left to right, docs/geometry.md "Panel pixels");
- its ray is the ray of that pixel under the same turned lenticular array:
  through the point of its lenticule's axis beside it, direction
  ``normalize(R(u', 0), f)`` with ``u'`` its offset across the lenticule;
- all ``3 W x H`` rays are traced in one POV-Ray pass through the mesh camera
  of the turned lattice (one strip per lenticule, ``lattice_mesh``);
- the panel image takes channel ``c`` of column ``3 col + c``: written directly,
  no views and no mapping.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ConfigError
from ..geometry.lens_array import LensArray, Panel


def subpixel_array(lens_array: LensArray) -> LensArray:
    """The same sheet over the subpixel panel: ``3 W x H`` cells of ``s/3 x s`` mm."""
    la = lens_array
    if la.grid != "lenticular":
        raise ConfigError(f"--method subpixel renders lenticular sheets, got a {la.grid} grid; "
                          "use --grid lenticular (with --lens-rotation for a slanted sheet)")
    p = la.panel
    panel = Panel(3 * p.width, p.height, p.pitch_x / 3, p.pitch_y)
    return LensArray("lenticular", la.lenses_x, la.lenses_y, la.pitch_x, la.pitch_y, la.focal, panel, la.rotation)


def subpixels_to_panel(image: np.ndarray) -> np.ndarray:
    """``(H, 3W, C)`` subpixel image -> ``(H, W, 3)`` panel: channel ``c`` from column ``3 col + c``."""
    h, w3 = image.shape[:2]
    if w3 % 3:
        raise ValueError(f"a subpixel image is 3 W columns wide, got {w3}")
    cells = image[..., :3].reshape(h, w3 // 3, 3, 3)     # (H, W, subpixel c, channel)
    return np.ascontiguousarray(np.einsum("hwcc->hwc", cells))


def describe(lens_array: LensArray) -> dict[str, Any]:
    sub = subpixel_array(lens_array)
    return {"subpixel_panel_px": [sub.panel.width, sub.panel.height],
            "slant_deg": lens_array.rotation, "subpixels_per_lens": 3 * lens_array.ppl_x}
