"""Direct volume rendering: a volume as POV-Ray participating media (``density_file df3``).

Interface shared by the volume stage (``app/volume.py``) and the set-up picture;
being built (issue 15).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..geometry.lens_array import LensArray
from ..volume.grid import Volume


def media_stage(volume: Volume, world_to_display: np.ndarray, lens_array: LensArray, *,
                transfer: str = "ct-soft", bits: int = 16, folder: Path) -> tuple[Path, dict[str, Any]]:
    """Write the df3 file(s) and a stage scene (no camera) into ``folder``; return the scene and its record.

    ``world_to_display`` (4, 4) maps the volume's LPS world mm to display-frame mm
    (``volume.orient.world_to_display``); ``transfer`` is a preset name or a file.
    """
    raise NotImplementedError("direct volume rendering is being built")
