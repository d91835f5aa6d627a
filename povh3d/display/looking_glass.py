"""Looking Glass devices: the vendor's calibration file (``visual.json``) and device table.

A Looking Glass is a slanted lenticular sheet on an LCD.  Each unit carries its own
calibration, ``visual.json``: the sheet (``pitch`` lenticules per inch, ``slope``
pixel rows per pixel of lens-edge shift, ``center`` phase), the panel (``screenW``,
``screenH``, ``DPI``), how the picture is oriented (``flipImageX``, ``flipImageY``,
``invView``), the view cone in degrees, and on third-generation units the positions
of the RGB subpixels inside a pixel (``subpixelCells``, ``CellPatternMode``).
The vendor writes every number as ``{"value": x}``; older tools wrote bare numbers,
and both are read.

``DEVICES`` holds each model's factory calibration and default quilt, taken from
the vendor's public device table (docs/displays.md cites each number).  The 27" has no
public factory calibration: its entries hold the quilt alone (from VTK's
``vtkLookingGlassInterface``), and its sheet comes from the unit's own ``visual.json``.
"""

from __future__ import annotations

from .. import jsontext
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..errors import ConfigError, InputError, param, warn

MM_PER_INCH = 25.4
CELL_PATTERNS = (0, 1, 2, 3, 4)   # the vendor's cellPatternType values

#: The numeric visual.json fields, file name -> Calibration attribute.
_NUMBERS = {"pitch": "pitch", "slope": "slope", "center": "center", "DPI": "dpi",
            "screenW": "screen_w", "screenH": "screen_h", "viewCone": "view_cone",
            "invView": "inv_view", "flipImageX": "flip_x", "flipImageY": "flip_y",
            "flipSubp": "flip_subp", "fringe": "fringe", "verticalAngle": "vertical_angle",
            "CellPatternMode": "cell_pattern"}
_TEXT = {"serial": "serial", "configVersion": "config_version"}
#: Read, but not used by the quilt -> panel mapping: a non-zero value is worth a warning.
_UNUSED = ("flipSubp", "fringe", "verticalAngle")
#: Fields of a ``povh3d calibrate --lattice lenticular`` file, read by display.mappings.slanted.
_POVH3D = {"kind", "pitch_px", "slant_deg", "phase_px", "k1", "image_size", "residual_rad", "tiles",
           "seconds", "white_image"}
_CELL_KEYS = ("ROffsetX", "ROffsetY", "GOffsetX", "GOffsetY", "BOffsetX", "BOffsetY")


@dataclass(frozen=True)
class Calibration:
    """One unit's ``visual.json``.

    pitch : float            lenticules per inch, measured across the lenticules
    slope : float            panel rows per pixel the lens edge moves across (signed)
    center : float           phase of the sheet at the panel's bottom-left, in lenticules
    dpi : float              panel pixels per inch
    screen_w, screen_h : int panel size, pixels
    view_cone : float        degrees between the outermost views
    inv_view : bool          view 0 on the right of a lenticule (every shipped unit: True)
    flip_x, flip_y : bool    the panel shows the picture mirrored
    subpixel_cells : tuple   per cell, (R x, R y, G x, G y, B x, B y) offsets in pixels
    cell_pattern : int       which cell each pixel uses (0: one cell, 1 checker, 2 columns,
                             3 four-row, 4 rows), the vendor's cellPatternType
    """

    pitch: float
    slope: float
    center: float
    dpi: float
    screen_w: int
    screen_h: int
    view_cone: float = 40.0
    inv_view: bool = True
    flip_x: bool = False
    flip_y: bool = False
    flip_subp: float = 0.0
    fringe: float = 0.0
    vertical_angle: float = 0.0
    cell_pattern: int = 0
    subpixel_cells: tuple[tuple[float, ...], ...] = ()
    serial: str = ""
    config_version: str = "3.0"

    def __post_init__(self) -> None:
        for name in ("pitch", "slope", "center", "dpi", "view_cone"):
            if not math.isfinite(getattr(self, name)):
                raise ConfigError(f"calibration {name} must be a finite number, got {getattr(self, name)!r}")
        if self.pitch <= 0 or self.dpi <= 0 or self.slope == 0:
            raise ConfigError(f"calibration pitch ({self.pitch:g}) and DPI ({self.dpi:g}) must be positive and "
                              f"slope ({self.slope:g}) non-zero; check the visual.json")
        if self.screen_w < 1 or self.screen_h < 1:
            raise ConfigError(f"calibration screen size {self.screen_w}x{self.screen_h} must be positive; "
                              "check screenW and screenH")
        if not 0 < self.view_cone < 180:
            raise ConfigError(f"calibration viewCone {self.view_cone:g} deg must lie in (0, 180)")
        if self.cell_pattern not in CELL_PATTERNS:
            raise ConfigError(f"calibration CellPatternMode {self.cell_pattern} is none of {CELL_PATTERNS}")
        for cell in self.subpixel_cells:
            if len(cell) != 6 or not all(math.isfinite(v) for v in cell):
                raise ConfigError("each of subpixelCells needs six finite offsets "
                                  f"({', '.join(_CELL_KEYS)}), got {cell!r}")
        needed = {0: 1, 1: 2, 2: 2, 3: 4, 4: 2}[self.cell_pattern]
        if self.subpixel_cells and len(self.subpixel_cells) < needed:
            raise ConfigError(f"CellPatternMode {self.cell_pattern} uses {needed} subpixelCells but the "
                              f"calibration has {len(self.subpixel_cells)}")

    @property
    def pixel_pitch_mm(self) -> float:
        return MM_PER_INCH / self.dpi

    @property
    def size_mm(self) -> tuple[float, float]:
        """The active area (width, height), mm."""
        return (self.screen_w * self.pixel_pitch_mm, self.screen_h * self.pixel_pitch_mm)

    @property
    def slant_deg(self) -> float:
        """Angle of the lenticules from vertical (positive: top leans right), degrees."""
        return math.degrees(math.atan(1.0 / self.slope))

    @property
    def lenticules_across(self) -> float:
        """Lenticules met along one panel row (the shader's processed pitch)."""
        return self.pitch * self.screen_w / self.dpi * math.cos(math.atan(1.0 / self.slope))

    @property
    def lens_pitch_mm(self) -> float:
        """Lenticule pitch along a panel row, mm (across the lenticules: times cos(slant))."""
        return self.size_mm[0] / self.lenticules_across


# -- reading ---------------------------------------------------------------------------------------
def _number(key: str, raw: Any) -> float:
    value = raw.get("value") if isinstance(raw, dict) else raw
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"calibration field {key!r} must be a number or {{\"value\": number}}, got {raw!r}")
    if abs(value) > _LARGEST:   # no field of a display is near it: a 1e308 centre makes a degenerate image
        raise ConfigError(f"calibration field {key!r} is {value:g}, beyond +-{_LARGEST:g}; copy the unit's "
                          "visual.json again")
    return float(value)


def _cells(raw: Any) -> tuple[tuple[float, ...], ...]:
    if not isinstance(raw, list):
        raise ConfigError(f"subpixelCells must be a list of cells, got {raw!r}")
    cells = []
    for cell in raw:
        if not isinstance(cell, dict) or any(k not in cell for k in _CELL_KEYS):
            raise ConfigError(f"each of subpixelCells needs {', '.join(_CELL_KEYS)}, got {cell!r}")
        cells.append(tuple(_number(k, cell[k]) for k in _CELL_KEYS))
    return tuple(cells)


#: The largest magnitude of a calibration number (pitch ~50, DPI ~300, screen 1536..7680 pixels).
_LARGEST = 1e6


def parse_visual(data: Any) -> Calibration:
    """The Calibration of a parsed ``visual.json`` (numbers bare or as ``{"value": x}``).

    A field povh3d does not use (an unknown key, or a non-zero ``fringe``,
    ``verticalAngle`` or ``flipSubp``) is one warning; a missing or malformed
    field one ConfigError.
    """
    if not isinstance(data, dict):
        raise ConfigError("a Looking Glass calibration is a JSON object (visual.json)")
    missing = [k for k in ("pitch", "slope", "center", "DPI", "screenW", "screenH") if k not in data]
    if missing:
        raise ConfigError(f"the Looking Glass calibration lacks {', '.join(missing)}; copy the unit's "
                          "visual.json from its drive or from Looking Glass Bridge")
    values: dict[str, Any] = {}
    for key, attr in _NUMBERS.items():
        if key in data:
            values[attr] = _number(key, data[key])
    if "cellPatternMode" in data and "CellPatternMode" not in data:  # the vendor reads both spellings
        values["cell_pattern"] = _number("cellPatternMode", data["cellPatternMode"])
    for key, attr in _TEXT.items():
        if key in data:
            values[attr] = str(data[key])
    for attr in ("screen_w", "screen_h", "cell_pattern"):
        if attr in values:
            if values[attr] != int(values[attr]):
                raise ConfigError(f"calibration {attr} must be a whole number, got {values[attr]!r}")
            values[attr] = int(values[attr])
    for attr in ("inv_view", "flip_x", "flip_y"):
        if attr in values:
            values[attr] = values[attr] >= 0.5   # the vendor's shaders test >= 0.5
    if "subpixelCells" in data:
        values["subpixel_cells"] = _cells(data["subpixelCells"])
    known = set(_NUMBERS) | set(_TEXT) | _POVH3D | {"subpixelCells", "cellPatternMode"}
    ignored = sorted(set(data) - known)
    ignored += [k for k in _UNUSED if k in data and _number(k, data[k]) != 0]
    if ignored:
        warn(f"the calibration's {', '.join(ignored)} {'is' if len(ignored) == 1 else 'are'} not used by "
             "povh3d; the panel image ignores them")
    return Calibration(**values)


def read_visual(path: str | Path) -> Calibration:
    """Read a ``visual.json`` file."""
    try:
        data = jsontext.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"cannot read the calibration {str(path)!r}: {exc.strerror}") from None
    except ValueError as exc:
        raise InputError(f"the calibration {str(path)!r} is not JSON: {exc}") from None
    return parse_visual(data)


# -- writing ---------------------------------------------------------------------------------------
def visual_fields(cal: Calibration) -> dict[str, Any]:
    """The vendor's ``visual.json`` object: every number as ``{"value": x}``."""
    def v(x: float | int | bool) -> dict[str, Any]:
        return {"value": int(x) if isinstance(x, bool) else x}

    out: dict[str, Any] = {"configVersion": cal.config_version, "serial": cal.serial,
                           "pitch": v(cal.pitch), "slope": v(cal.slope), "center": v(cal.center),
                           "viewCone": v(cal.view_cone), "invView": v(cal.inv_view),
                           "verticalAngle": v(cal.vertical_angle), "DPI": v(cal.dpi),
                           "screenW": v(cal.screen_w), "screenH": v(cal.screen_h),
                           "flipImageX": v(cal.flip_x), "flipImageY": v(cal.flip_y),
                           "flipSubp": v(cal.flip_subp), "fringe": v(cal.fringe)}
    if cal.subpixel_cells or cal.cell_pattern:
        out["CellPatternMode"] = v(cal.cell_pattern)
        out["subpixelCells"] = [dict(zip(_CELL_KEYS, cell)) for cell in cal.subpixel_cells]
    return out


def visual_json(cal: Calibration) -> str:
    return json.dumps(visual_fields(cal), indent=4) + "\n"


# -- devices ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Device:
    """A Looking Glass model: its factory calibration and the vendor's default quilt.

    calibration : the factory calibration, or None where none is public (the 27"): the
                  unit's own ``visual.json`` gives the sheet
    quilt_size : (width, height) px of the vendor's quilt; may exceed cols x tile (padding)
    grid : (cols, rows) views in the quilt
    aspect : the view's aspect (width / height), the panel's own
    diagonal_in, default_cone : without a factory calibration, the nominal diagonal (inches)
                  and the view cone (degrees) a quilt is rendered for until the unit's
                  calibration gives its own
    """

    name: str                 # povh3d's name (a preset)
    vendor_name: str          # the vendor's device type
    calibration: Calibration | None
    quilt_size: tuple[int, int]
    grid: tuple[int, int]
    aspect: float
    serial_prefix: str = field(default="", compare=False)
    diagonal_in: float = 0.0
    default_cone: float = 0.0

    def no_calibration(self) -> ConfigError:
        return no_calibration(self.vendor_name)

    @property
    def nominal_size_mm(self) -> tuple[float, float]:
        """The screen (width, height) mm: the factory calibration's, else the nominal diagonal at the aspect."""
        if self.calibration is not None:
            return self.calibration.size_mm
        diagonal = self.diagonal_in * MM_PER_INCH
        return (diagonal * self.aspect / math.hypot(self.aspect, 1.0), diagonal / math.hypot(self.aspect, 1.0))

    @property
    def views(self) -> int:
        return self.grid[0] * self.grid[1]

    @property
    def tile_size(self) -> tuple[int, int]:
        """(width, height) px of one quilt tile: the quilt divided by the grid, rounded down."""
        return (self.quilt_size[0] // self.grid[0], self.quilt_size[1] // self.grid[1])

    def check(self, cal: Calibration) -> None:
        """Refuse a calibration of another model: another panel size, DPI or view cone (without a
        factory calibration: a screen of another aspect)."""
        own = self.calibration
        if own is None:
            if not math.isclose(cal.screen_w / cal.screen_h, self.aspect, rel_tol=0.01):
                raise ConfigError(f"the calibration is of a {cal.screen_w}x{cal.screen_h} panel, not the "
                                  f"{self.vendor_name}'s aspect {self.aspect:g}; give this unit's visual.json "
                                  "or the device it belongs to")
            return
        if (cal.screen_w, cal.screen_h) != (own.screen_w, own.screen_h):
            raise ConfigError(f"the calibration is for a {cal.screen_w}x{cal.screen_h} panel but the "
                              f"{self.vendor_name} is {own.screen_w}x{own.screen_h}; give this unit's visual.json "
                              "or the device it belongs to")
        if not math.isclose(cal.dpi, own.dpi, rel_tol=0.02):
            raise ConfigError(f"the calibration's DPI {cal.dpi:g} is not the {self.vendor_name}'s {own.dpi:g}; "
                              "give this unit's visual.json or the device it belongs to")
        if not math.isclose(cal.view_cone, own.view_cone, abs_tol=0.5):
            raise ConfigError(f"the calibration's viewCone {cal.view_cone:g} deg is not the {self.vendor_name}'s "
                              f"{own.view_cone:g} deg; give this unit's visual.json or the device it belongs to")


def no_calibration(model: str) -> ConfigError:
    """The one-line refusal of what needs the sheet of a model with no public factory calibration."""
    return ConfigError(f"the {model} has no public factory calibration (pitch, slope, center, DPI), so its "
                       f"sheet is the unit's own; give the unit's visual.json with {param('calibration')}")


def _cal(pitch: float, slope: float, center: float, dpi: float, w: int, h: int, cone: float,
         serial: str, pattern: int = 0, cells: tuple[tuple[float, ...], ...] = ()) -> Calibration:
    return Calibration(pitch, slope, center, dpi, w, h, cone, True, cell_pattern=pattern,
                       subpixel_cells=cells, serial=serial)


# Gen3 subpixel cells as the vendor's device table gives them (R x, R y, G x, G y, B x, B y), pixels.
_CELLS_COLUMNS = ((-0.31, 0.25, 0.28, 0.25, 0.0, -0.25), (-0.31, -0.25, 0.28, -0.25, 0.0, 0.25))
_CELLS_ROWS = ((-0.25, -0.31, -0.25, 0.28, 0.25, 0.0), (0.25, -0.31, 0.25, 0.28, -0.25, 0.0))

DEVICES: dict[str, Device] = {d.name: d for d in (
    Device("looking-glass-portrait", "Looking Glass Portrait", _cal(52, -7, 0.5, 324, 1536, 2048, 40, "LKG-PORT-"),
           (3360, 3360), (8, 6), 0.75, "LKG-P"),
    Device("looking-glass-go", "Looking Glass Go", _cal(80.7, -6.3, -0.3, 491, 1440, 2560, 54, "LKG-E"),
           (4092, 4092), (11, 6), 0.5625, "LKG-E"),
    Device("looking-glass-16-landscape", "Looking Glass 16\" Spatial Display (landscape)",
           _cal(44.72, -6.9, 0.5, 283, 3840, 2160, 50, "LKG-J", 2, _CELLS_COLUMNS),
           (5999, 5999), (7, 7), 1.77778, "LKG-J"),
    Device("looking-glass-16-portrait", "Looking Glass 16\" Spatial Display (portrait)",
           _cal(44.72, -7.45, 0.0, 283, 2160, 3840, 50, "LKG-H", 4, _CELLS_ROWS),
           (5995, 6000), (11, 6), 0.5625, "LKG-H"),
    Device("looking-glass-32-landscape", "Looking Glass 32\" Spatial Display (landscape)",
           _cal(75, -7.2, -0.2, 280, 7680, 4320, 50, "LKG-L"), (8190, 8190), (7, 7), 1.77778, "LKG-L"),
    Device("looking-glass-32-portrait", "Looking Glass 32\" Spatial Display (portrait)",
           _cal(80.7, -6.3, -0.3, 280, 4320, 7680, 54, "LKG-K", 2, _CELLS_COLUMNS),
           (8184, 8184), (11, 6), 0.5625, "LKG-K"),
    Device("looking-glass-65", "Looking Glass 65\"", _cal(42, -6, 0.3, 136, 7680, 4320, 40, "LKG-D"),
           (8192, 8192), (8, 9), 1.77778, "LKG-D"),
    # The 27": quilts from VTK's vtkLookingGlassInterface ("27_gen3_l", "27_gen3_p"; its 1.777 is the
    # 16:9 that [T] writes 1.77778); no factory calibration is public.  The cone until the unit's
    # calibration gives its own: the Gen3 family's, 50 deg as the 16" and 32" landscape.
    Device("looking-glass-27-landscape", "Looking Glass 27\" Light Field Display (landscape)", None,
           (7680, 4320), (8, 6), 1.77778, diagonal_in=27.0, default_cone=50.0),
    Device("looking-glass-27-portrait", "Looking Glass 27\" Light Field Display (portrait)", None,
           (7680, 4320), (12, 4), 0.5625, diagonal_in=27.0, default_cone=50.0),
)}


def device(name: str) -> Device:
    if name not in DEVICES:
        raise ConfigError(f"unknown Looking Glass device {name!r}; choose one of: {', '.join(DEVICES)}")
    return DEVICES[name]


def device_of(cal: Calibration) -> Device | None:
    """The model a calibration belongs to, by its serial's prefix, else by panel size and DPI."""
    for d in DEVICES.values():
        if d.serial_prefix and cal.serial.upper().startswith(d.serial_prefix):
            return d
    for d in DEVICES.values():
        own = d.calibration
        if own is not None and (cal.screen_w, cal.screen_h) == (own.screen_w, own.screen_h) \
                and math.isclose(cal.dpi, own.dpi, rel_tol=0.02):
            return d
    return None


def with_overrides(cal: Calibration, **changes: Any) -> Calibration:
    """A copy with fields changed, validated again."""
    return replace(cal, **changes)


def check_view_cone(cal: Calibration, cone_deg: float, *, tolerance_deg: float = 0.5) -> None:
    """Refuse rendering for a cone other than the calibration's ``viewCone``."""
    if not math.isclose(cal.view_cone, cone_deg, abs_tol=tolerance_deg):
        raise ConfigError(f"the calibration's viewCone is {cal.view_cone:g} deg but the views span {cone_deg:.4g} deg; "
                          "give the device's preset (its focal length spans the cone) or this display's calibration")


def check_panel(cal: Calibration, size_px: tuple[int, int], pixel_pitch_mm: float | None = None) -> None:
    """Refuse a calibration of another panel: ``size_px = (W, H)``, pixel pitch in mm."""
    if (cal.screen_w, cal.screen_h) != tuple(size_px):
        raise ConfigError(f"the calibration is of a {cal.screen_w}x{cal.screen_h} pixel screen but the panel is "
                          f"{size_px[0]}x{size_px[1]}; give this panel's calibration, or its size with {param('panel')}")
    if pixel_pitch_mm is not None and not math.isclose(cal.pixel_pitch_mm, pixel_pitch_mm, rel_tol=0.02):
        raise ConfigError(f"the calibration's DPI {cal.dpi:g} means {cal.pixel_pitch_mm:.4g} mm pixels but the panel's "
                          f"are {pixel_pitch_mm:.4g} mm; give this panel's calibration, or {param('pixel_pitch')}")
