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

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ConfigError, param
from ..geometry.camera_mesh import CameraMesh
from ..geometry.view_bank import stack_shots
from ..geometry.lens_array import LensArray, Panel
from ..image.colour import mean_in_linear_light

if TYPE_CHECKING:  # the method (renderer.methods.registry) builds the camera; this module only reads it
    from ..geometry.phase_tiles import PhaseTiles
    from .mappings import Mapping
    from .mappings.slanted import Slanted


def subpixel_array(lens_array: LensArray) -> LensArray:
    """The same sheet over the subpixel panel: ``3 W x H`` cells of ``s/3 x s`` mm."""
    la = lens_array
    if la.grid != "lenticular":
        raise ConfigError(f"{param('method')} subpixel renders lenticular sheets, got a {la.grid} grid; "
                          f"use {param('grid')} lenticular (with {param('lens_rotation')} for a slanted sheet)")
    p = la.panel
    panel = Panel(3 * p.width, p.height, p.pitch_x / 3, p.pitch_y)
    return LensArray("lenticular", la.lenses_x, la.lenses_y, la.pitch_x, la.pitch_y, la.focal, panel, la.rotation)


def slanted_sheet(mapping: Mapping, panel: Panel, focal: float) -> tuple[LensArray, float]:
    """The lens sheet a slanted subpixel mapping describes, centred on its panel, and the
    mapping offset ``k_off`` that puts the mapping's sheet where this one lies.

    The mapping's sheet spans ``X`` subpixels along a row and moves ``slope`` subpixels
    right per row down (``display.mappings.slanted``): it leans ``atan(slope s_x / (3 s_y))`` from
    vertical (counter-clockwise, as ``--lens-rotation``), ``X s_x/3 cos a`` mm across.
    A subpixel whose centre lies ``t`` lens pitches across the centred sheet has the
    mapping's phase ``X t - 1/2`` (the phase is its left edge), hence ``k_off``.
    """
    mapping = _check_subpixel_mapping(mapping)
    sheet, t = _centred(mapping, panel, focal, spare=1)
    return sheet, round((mapping.per_lens * t - 0.5) % mapping.per_lens, 9) % mapping.per_lens


def placed_sheet(mapping: Mapping, panel: Panel, focal: float) -> tuple[LensArray, float]:
    """The sheet of ``mapping`` where its own offset puts it: the sheet and its ``shift``, the mm its
    lenticules lie across from the centred sheet's (``phase_tiles``, ``lattice_mesh``).

    The centred sheet has the mapping phase of ``slanted_sheet``'s ``k_off``; moving it ``s``
    pitches across lowers every subpixel's ``t`` by ``s``, so ``s = (k_off - offset) / X`` (the
    least such, modulo whole lenses) gives every subpixel the mapping's own phase.  Two spare
    lenses keep the panel covered whichever way it moves.
    """
    mapping = _check_subpixel_mapping(mapping, reverse_ok=True)
    sheet, t = _centred(mapping, panel, focal, spare=3)
    x = mapping.per_lens
    s = ((x * t - 0.5 - mapping.offset) / x + 0.5) % 1.0 - 0.5
    return sheet, s * sheet.pitch_x


def _check_subpixel_mapping(mapping: Mapping, reverse_ok: bool = False) -> Slanted:
    from .mappings.slanted import Slanted  # only the CLI asks: keeps the render's import chain short

    if not isinstance(mapping, Slanted) or mapping.unit != "subpixel" or (mapping.reverse and not reverse_ok):
        raise ConfigError(f"{param('method')} subpixel traces the sheet of a slanted subpixel mapping; {mapping.name!r} "
                          f"is not one: give the sheet with {param('grid')} lenticular {param('ppl')} {param('lens_rotation')} instead")
    return mapping


def _centred(mapping: Any, panel: Panel, focal: float, spare: int) -> tuple[LensArray, float]:
    """The centred sheet of ``mapping`` (``spare`` lenses past the panel's reach) and how many
    pitches across it the centre of subpixel ``(0, 0)`` lies."""
    sx, sy = panel.pitch_x, panel.pitch_y
    turn = math.atan(mapping.slope * sx / (3 * sy))
    pitch = mapping.per_lens * sx / 3 * math.cos(turn)
    reach = panel.width * sx * math.cos(turn) + panel.height * sy * abs(math.sin(turn))
    sheet = LensArray("lenticular", math.ceil(reach / pitch) + spare, panel.height, pitch, sy, focal, panel,
                      math.degrees(turn))
    x, _ = sheet.to_lattice(np.array((0.5 / 3 - panel.width / 2) * sx), np.array((panel.height / 2 - 0.5) * sy))
    return sheet, float(x) / pitch + sheet.lenses_x / 2


def sheet_phase(sheet: LensArray, shift: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Lenticule and position across it (0..1, left to right) of every subpixel centre ``(H, 3W)``
    under ``sheet`` moved ``shift`` mm across (docs/geometry.md, "The ray of a pixel")."""
    sub = subpixel_array(sheet)
    x, _ = sub.to_lattice(*np.meshgrid(*sub.panel.pixel_centres()))
    t = (x - shift) / sheet.pitch_x + sheet.lenses_x / 2
    lens = np.floor(t + 1e-9)
    return lens.astype(np.int64), t - lens


def subpixel_image(mesh: CameraMesh, tiles: PhaseTiles | None, images: list[np.ndarray]) -> np.ndarray:
    """The ``(H, 3W, C)`` image of every subpixel's ray out of the rendered frame."""
    image = stack_shots(images)
    return mesh.crop(image) if tiles is None else tiles.to_panel(image)


def assemble(mesh: CameraMesh, tiles: PhaseTiles | None, images: list[np.ndarray],
             outside: np.ndarray | None = None) -> np.ndarray:
    """The ``(H, W, 3)`` panel image from the rendered subpixel frames (tiles: one gather a
    frame; several frames are footprint samples, averaged in linear light).

    ``outside`` (``(H, 3W)`` bool, tiles only): subpixels outside every lenticule, made
    black (a tile's rays run on past the sheet's edge; a strip camera finds no face there).
    """
    if tiles is None:
        return subpixels_to_panel(subpixel_image(mesh, tiles, images))
    rows, cols = tiles.panel_index()          # of every subpixel column 3 col + c
    w = cols.size // 3
    channel = np.arange(3)
    panels = np.stack([image[1:, :-1][rows[:, None, None], cols.reshape(w, 3)[None], channel[None, None, :]]
                       for image in images])
    panel = mean_in_linear_light(panels) if len(panels) > 1 else panels[0]
    if outside is not None:
        panel[outside.reshape(len(rows), w, 3)] = 0
    return panel


def panel_to_subpixels(image: np.ndarray) -> np.ndarray:
    """A panel image ``(H, W, C)`` as its subpixel panel ``(H, 3W, C)``: column ``3 col + c`` lit in channel
    ``c`` alone with pixel ``col``'s value, the others black (R, G, B stripes, left to right)."""
    h, w = image.shape[:2]
    out = np.zeros((h, 3 * w) + image.shape[2:], image.dtype)
    for c in range(3):
        out[:, c::3, c] = image[:, :, c]
    return out


def subpixels_to_panel(image: np.ndarray) -> np.ndarray:
    """``(H, 3W, C)`` subpixel image -> ``(H, W, 3)`` panel: channel ``c`` from column ``3 col + c``."""
    h, w3 = image.shape[:2]
    if w3 % 3:
        raise ValueError(f"a subpixel image is 3 W columns wide, got {w3}")
    cells = image[..., :3].reshape(h, w3 // 3, 3, 3)     # (H, W, subpixel c, channel)
    return np.ascontiguousarray(np.einsum("hwcc->hwc", cells))


def sheet_record(lens_array: LensArray, tiles: PhaseTiles | None, samples: int = 1, shift: float = 0.0) -> dict[str, Any]:
    sub = subpixel_array(lens_array)
    return {"subpixel_panel_px": [sub.panel.width, sub.panel.height],
            "slant_deg": lens_array.rotation, "sheet_shift_mm": shift,
            "subpixels_per_lens_along_row": 3 * lens_array.ppl_x / math.cos(math.radians(lens_array.rotation)),
            "camera": (f"phase tiles {tiles.period[0]}x{tiles.period[1]}" if tiles else "one strip per lenticule"),
            "footprint_samples": samples}
