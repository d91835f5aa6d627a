"""What every pixel mapping is: an index map from panel subpixels to view-space subpixels.

A mapping reads the *unmapped* H3D image in view space (``rows x lenses*views``
RGB pixels, the layout the camera bank renders and docs/geometry.md interleaves) and
writes the panel image (``H x W`` RGB).  It is described once as an index map
``(H, W, 3)`` of flat indices into the source; applying it is then one
fancy-indexing gather, so the per-image cost is one pass over the panel.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from functools import lru_cache
from typing import Any

import numpy as np

from ...errors import ConfigError, param
from ...geometry.lens_array import LensArray, Panel
from ...image.colour import from_linear, to_linear
from .plan import build_plan
from .sampling import Sampling, Source

# Floors of phases that are whole numbers in exact arithmetic must not fall to
# the integer below through rounding (e.g. (1 - 1/3) * 3 = 1.9999999999999998).
EPS = 1e-9


def whole(name: str, value: Any, low: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer, float)) or float(value) != int(value) \
            or int(value) < low:
        raise ConfigError(f"{name} must be a whole number of at least {low}, got {value!r}")
    return int(value)


class Mapping(ABC):
    """A panel pixel mapping (frozen dataclass subclasses; hashable, so index maps cache)."""

    name: str

    @abstractmethod
    def source(self, panel: tuple[int, int]) -> Source:
        """The view-space image this mapping reads for a ``(W, H)`` panel."""

    @abstractmethod
    def _sample(self, panel: tuple[int, int]) -> Sampling:
        """Build the index map (called once per panel size, then cached)."""

    @abstractmethod
    def view_pitch(self, pitch: tuple[float, float]) -> tuple[float, float, float]:
        """``(lens pitch, view-pixel pitch, view-row height)`` in mm on a panel of pixel pitch ``(sx, sy)``.

        The lens pitch is the one whose centres the view pixels sample; the
        view-pixel pitch sets the view directions ``u/f`` (see ``render_array``).
        """

    # -- derived ------------------------------------------------------------------------
    def sample(self, panel: tuple[int, int]) -> Sampling:
        return _cached_sampling(self, (int(panel[0]), int(panel[1])))

    def render_array(self, panel: Panel, focal: float) -> LensArray:
        """The lenticular view-space array to render so that ``map`` fills ``panel`` exactly.

        Its views are exactly the ones the mapping reads, at the size it reads them.
        """
        src = self.source((panel.width, panel.height))
        lens_pitch, view_pitch, row_h = self.view_pitch((panel.pitch_x, panel.pitch_y))
        # The render array samples lens centres at ``lens_pitch`` and has ``views``
        # pixels of ``lens_pitch / views`` under each; scaling the focal by
        # ``(lens_pitch / views) / view_pitch`` gives each view the direction
        # ``normalize(u_view, 0, f)`` it has on the display.
        render_pixel = lens_pitch / src.views
        f = focal * render_pixel / view_pitch
        vpanel = Panel(src.lenses * src.views, src.rows, render_pixel, row_h)
        return LensArray("lenticular", src.lenses, src.rows, lens_pitch, row_h, f, vpanel)

    @abstractmethod
    def resolution_3d(self, panel: tuple[int, int]) -> tuple[int, int]:
        """The thesis's 3D resolution ``(horizontal, vertical)`` on a ``(W, H)`` panel."""

    def figures(self, panel: Panel) -> dict[str, Any]:
        """Panel figures for ``povh3d info``: 3D resolution, 3D pixel distance, 3D-PPI.

        The 3D pixel distance is the thesis's (Table 5.9): the spacing of
        neighbouring view pixels along a row, ``lens pitch / views``; the 3D-PPI
        is the 3D resolution over the panel size in inches (the thesis truncates it).
        """
        size = (panel.width, panel.height)
        src = self.source(size)
        res = self.resolution_3d(size)
        lens_pitch, view_pitch, _ = self.view_pitch((panel.pitch_x, panel.pitch_y))
        w_in, h_in = (v / 25.4 for v in panel.size_mm)
        return {
            "mapping": self.name,
            "resolution_3d": [int(res[0]), int(res[1])],
            "pixel_distance_3d_mm": view_pitch,
            "ppi_3d": [res[0] / w_in, res[1] / h_in],
            "mapping_lens_pitch_mm": lens_pitch,
            "mapping_views": src.views,
            "mapping_source_px": [src.lenses * src.views, src.rows],
        }

    def apply(self, h3d: np.ndarray, panel: tuple[int, int], *, reference: bool = False) -> np.ndarray:
        """Map an unmapped view-space H3D image onto a ``(W, H)`` panel.

        ``reference=True`` gathers with the full index map of ``sample`` (NumPy
        fancy indexing) instead of the compiled plan: the tests' oracle.

        Parameters
        ----------
        h3d : (rows, lenses*views, 3 or 4) uint8 or uint16
            Alpha, if any, is dropped.
        panel : (W, H)

        Returns
        -------
        (H, W, 3) array of the same dtype.
        """
        src = self.source(panel)
        h3d = np.asarray(h3d)
        if h3d.ndim == 2:
            h3d = h3d[..., None]
        if h3d.shape[:2] != src.shape[:2]:
            raise ConfigError(
                f"mapping {self.name!r} on a {panel[0]}x{panel[1]} panel reads a view-space image of "
                f"{src.shape[1]}x{src.shape[0]} pixels ({src.lenses} lenses x {src.views} views, "
                f"{src.rows} rows), got {h3d.shape[1]}x{h3d.shape[0]}; render it with {param('mapping')} "
                f"{self.name} or give the panel size with {param('panel')}")
        if h3d.shape[2] == 1:
            h3d = np.repeat(h3d, 3, axis=2)
        elif h3d.shape[2] == 4:
            h3d = h3d[..., :3]
        flat = np.ascontiguousarray(h3d).reshape(-1)
        plan = None if reference else _cached_plan(self, (int(panel[0]), int(panel[1])))
        if plan is not None:  # the compiled row gather (display/mappings/plan.py); the rest is the reference
            out = np.empty((panel[1], panel[0], 3), h3d.dtype)
            plan.apply(flat, out)
            return out
        s = self.sample(panel)
        out = flat[s.index]
        if s.index2 is not None and s.weight is not None:  # set together (Sampling)

            lin = (1 - s.weight) * to_linear(out, np.float32) + s.weight * to_linear(flat[s.index2], np.float32)
            out = from_linear(lin, h3d.dtype)
        if s.black is not None:
            out[s.black] = 0
        return out


@lru_cache(maxsize=16)
def _cached_sampling(mapping: Mapping, panel: tuple[int, int]) -> Sampling:
    s = mapping._sample(panel)
    for a in (s.index, s.index2, s.black, s.weight):
        if a is not None:
            a.setflags(write=False)
    return s


@lru_cache(maxsize=16)
def _cached_plan(mapping: Mapping, panel: tuple[int, int]):
    """The compressed plan of a non-blended mapping (None for blended ones: they mix two sources).

    Built from an uncached ``_sample`` so the 200 MB int64 map of a 4K panel is not kept.
    """
    if getattr(mapping, "blend", False):
        return None
    s = mapping._sample(panel)
    return None if s.index2 is not None else build_plan(s)


def centred_margin(width: int, lens: int) -> tuple[int, int]:
    """``(lens count, first column)`` of lenses ``lens`` units wide centred on ``width`` units."""
    count = width // lens
    if count < 1:
        raise ConfigError(f"a lens of {lens} does not fit a panel {width} wide; use fewer pixels per lens ({param('ppl')})")
    return count, (width - count * lens) // 2
