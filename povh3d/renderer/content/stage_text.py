"""The stage scenes povh3d writes around a user's model or volume (no camera): their POV-Ray text.

``model_stage_text`` puts a converted model (or a volume's surfaces) on the
default stage (``templates/stage.pov.j2``: background, two lights, the model
placed by a ``geometry.fit.Fit``); ``media_stage_text`` puts a volume's
df3 medium in its box (``templates/volume_media.pov.j2``).  Script text is the
engine's (it alone talks to ``povray/``); ``renderer/content/model.py`` and
``renderer/content/volume_media.py`` write the files.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..._version import __version__
from ...geometry.fit import Fit
from ...geometry.lens_array import LensArray
from ...scene.templates import render_template
from ...volume.df3 import SAMPLE_SHIFT, padded_shape
from ...volume.grid import Volume
from ...volume.media import pov_matrix, uniform_scale
from ...volume.transfer import Transfer


def model_stage_text(include: str, ident: str, fit: Fit, lens_array: LensArray, *, model: str) -> str:
    """The stage scene (no camera): background, two lights, the placed model."""
    width, height = lens_array.panel.size_mm
    reach = max(width, height)
    return render_template(
        "stage.pov.j2", version=__version__, model=model, include=include, ident=ident,
        shift=fit.shift, scale=fit.scale, size=fit.size, limit=fit.limit,
        depth=fit.depth,
        key_light=(-0.6 * reach, 0.9 * reach, -1.5 * reach), fill_light=(0.9 * reach, 0.2 * reach, -1.0 * reach))



def media_stage_text(volume: Volume, world_to_display: np.ndarray, classified: dict[str, Any], transfer: Transfer, *,
               df3_name: str, intervals: int, samples: int, background: tuple[float, float, float]) -> str:
    """The media stage scene (no camera): the df3 file ``df3_name`` in its box, moved onto the display."""
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
