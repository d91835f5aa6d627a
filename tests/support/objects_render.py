"""A synthetic animation with object masks at analytic places (no POV-Ray): the oracle of the
3DCDP header and the hyperlinker's tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from povh3d.renderer.outputs.objects import ObjectTable, write_masks
from povh3d.renderer.records import base_record
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.interleave import interleave
from povh3d.image.io import write_image_pair

NY, NX, LY, LX = 4, 4, 12, 16            # 4x4 views of 16x12: a 64x48 panel
FRAMES = [0, 1, 2, 3]


def moving_objects_render(folder: Path) -> Path:
    """A 4-frame animation: a box (id 1) moving right in every frame, a ball (id 2) in frames 0 and 3."""
    la = LensArray("square", LX, LY, 0.4, 0.4, 1.0, Panel(NX * LX, NY * LY, 0.1, 0.1))
    masks = {}
    for n in FRAMES:
        ids = np.zeros((NY, NX, LY, LX), np.uint16)
        ids[:, :, 2:6, 3 + n:8 + n] = 1               # rows 2..5, columns 3+n..7+n in every view
        if n in (0, 3):
            ids[:, :, 8:11, 1:3] = 2                  # rows 8..10, columns 1..2
        masks[n] = ids
        colour = np.repeat((ids * 100)[..., None], 3, axis=-1).astype(np.uint8)
        record = {**base_record("h3d", la), "animation": {"frame": n, "frames": [0, 3]}}
        write_image_pair(folder / f"clip_{n:04d}.png", interleave(colour), record)
    write_masks(folder / "objects", ObjectTable({1: "box", 2: "ball"}, tuple(FRAMES), (NY, NX), (LY, LX)), masks)
    return folder / "clip.png"
