"""The lens sheet of a lenticular calibration, for ``--method subpixel --calibration FILE``.

A calibration file (``povh3d calibrate --lattice lenticular`` output, with or without
the Looking Glass fields, or a Looking Glass ``visual.json``) is read exactly as
``map --mapping slanted --calibration`` reads it (``display.mappings.slanted.from_calibration``):
subpixels per lens ``X``, slope and offset ``k_off``.  That mapping's sheet, placed
where its offset puts it (``subpixel.placed_sheet``), is the sheet traced, so the
subpixel render and the view-then-map route address one sheet.

The file must be of this panel (its screen size, and its DPI where it has one), and
where the display already names a sheet (a preset's mapping, or ``--grid lenticular``)
the calibration may refine it, not replace it: it wins within ``PITCH_TOLERANCE`` and
``SLANT_TOLERANCE_DEG``, and is refused beyond (the wrong file or the wrong display).
"""

from __future__ import annotations

import math
from typing import Any

from .looking_glass import check_view_cone
from ..errors import ConfigError, param
from ..geometry.lens_array import LensArray, Panel
from .subpixel import placed_sheet

#: A calibrated pitch this far (relative) from the display's own is another sheet's.
PITCH_TOLERANCE = 0.02
#: ... and a slant this far (degrees).
SLANT_TOLERANCE_DEG = 1.0
#: The file's DPI against the panel's pixel pitch (relative).
DPI_TOLERANCE = 0.02


def calibrated_sheet(calibration: dict[str, Any], panel: Panel, focal: float,
                     nominal: LensArray | None = None) -> tuple[LensArray, float, dict[str, Any]]:
    """The calibrated sheet over ``panel``, its shift across (mm, ``placed_sheet``) and a record
    of it for the sidecar.  ``nominal``: the display's own sheet, which the calibration refines."""
    # Only a render with a calibration asks: keeps the render's import chain short.
    from .mappings.slanted import from_calibration

    mapping = from_calibration(calibration, 1)
    _check_panel(calibration, panel)
    sheet, shift = placed_sheet(mapping, panel, focal)
    cone = _view_cone(calibration, panel)
    if cone is not None:
        if nominal is None:  # the file's cone decides the views: the focal length that spans it
            focal = row_pitch(sheet) / (2 * math.tan(math.radians(cone.view_cone) / 2))
            sheet, shift = placed_sheet(mapping, panel, focal)
        check_view_cone(cone, view_cone_deg(sheet))
    record: dict[str, Any] = {"from_calibration": True, "mapping_offset": round(mapping.offset, 12),
                              "subpixels_per_lens": mapping.per_lens, "slope": mapping.slope,
                              "pitch_mm": sheet.pitch_x, "slant_deg": sheet.rotation, "shift_mm": shift}
    if nominal is not None:
        _check_nominal(sheet, nominal)
        record["nominal"] = {"pitch_mm": nominal.pitch_x, "slant_deg": nominal.rotation}
    return sheet, shift, record


def row_pitch(sheet: LensArray) -> float:
    """The lenticule pitch along a panel row, mm (``pitch_x`` is across the lenticules)."""
    return sheet.pitch_x / math.cos(math.radians(sheet.rotation))


def view_cone_deg(sheet: LensArray) -> float:
    """The cone a lenticular sheet's views span, degrees: ``2 atan(row pitch / 2 f)``, the
    definition the Looking Glass presets' focal lengths are made from (docs/displays.md)."""
    return math.degrees(2 * math.atan(row_pitch(sheet) / (2 * sheet.focal)))


def _view_cone(calibration: dict[str, Any], panel: Panel) -> Any:
    """The parsed Looking Glass calibration when the file states a ``viewCone``, else None.
    Parsing it also checks it whole (``display.looking_glass.parse_visual``) and against the panel."""
    if "pitch" not in calibration:
        return None
    from .looking_glass import check_panel, parse_visual

    cal = parse_visual(calibration)
    check_panel(cal, (panel.width, panel.height), panel.pitch_x)
    return cal if "viewCone" in calibration else None


def _field(calibration: dict[str, Any], key: str) -> Any:
    value = calibration.get(key)
    return value.get("value") if isinstance(value, dict) else value


def _check_panel(calibration: dict[str, Any], panel: Panel) -> None:
    """The file's screen (``screenW`` x ``screenH``, else ``image_size``) is the panel, and its DPI
    gives the panel's pixel pitch: the phase is measured from the screen's centre."""
    size: object
    if "screenW" in calibration:
        size = [_field(calibration, "screenW"), _field(calibration, "screenH")]
    else:
        size = calibration.get("image_size")
    if size != [panel.width, panel.height]:
        shown = "x".join(f"{v:g}" for v in size) if isinstance(size, list) else repr(size)
        raise ConfigError(f"the calibration is of a {shown} pixel screen but the panel is {panel.width}x"
                          f"{panel.height}; give this panel's calibration, or its size with {param('panel')}")
    dpi = _field(calibration, "DPI")
    if dpi is not None and abs(25.4 / dpi / panel.pitch_x - 1) > DPI_TOLERANCE:
        raise ConfigError(f"the calibration's DPI {dpi:g} means {25.4 / dpi:.4g} mm pixels but the panel's are "
                          f"{panel.pitch_x:.4g} mm; give this panel's calibration, or its pitch with {param('pixel_pitch')}")


def _check_nominal(sheet: LensArray, nominal: LensArray) -> None:
    pitch, slant = sheet.pitch_x, sheet.rotation
    if abs(pitch / nominal.pitch_x - 1) > PITCH_TOLERANCE or abs(slant - nominal.rotation) > SLANT_TOLERANCE_DEG:
        raise ConfigError(
            f"the calibration's sheet (pitch {pitch:.5g} mm, slant {slant:.4g} deg) is not this display's "
            f"(pitch {nominal.pitch_x:.5g} mm, slant {nominal.rotation:.4g} deg): more than "
            f"{100 * PITCH_TOLERANCE:g} % or {SLANT_TOLERANCE_DEG:g} deg apart; give this display's calibration, "
            f"or the display it was made for ({param('preset')}, or {param('grid')} lenticular {param('ppl')} {param('lens_rotation')})")
