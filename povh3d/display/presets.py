"""Display presets (shipped as TOML) and turning display fields into a LensArray.

A preset and the CLI's lens-array options are the same thing: a flat dict of
display fields.  ``lens_array_from_fields`` resolves them, deriving whatever
is not given (lens count from the panel, panel from the lens count).
"""

from __future__ import annotations

import math
import tomllib
from functools import cache
from importlib import resources
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError, param

if TYPE_CHECKING:  # imported where used: listing presets needs no NumPy
    from ..geometry.lens_array import LensArray, Panel

FIELDS = ("description", "grid", "panel", "pixel_pitch", "lens_pitch", "ppl", "lenses",
          "rows", "focal", "views", "slant_deg", "mapping", "lens_rotation", "lattice",
          "viewing_distance_mm", "viewing_distance_source", "sheet_from")

# Overriding any of these re-derives the panel from the lens array, unless the
# panel itself is given.
_ARRAY_FIELDS = ("grid", "lenses", "ppl", "rows", "lens_pitch", "lattice")

_EPS = 1e-9


@cache
def load_presets() -> dict[str, dict[str, Any]]:
    """All presets by name, as plain dicts of display fields."""
    text = resources.files(__package__).joinpath("presets.toml").read_text(encoding="utf-8")
    presets = tomllib.loads(text)
    for name, fields in presets.items():
        unknown = set(fields) - set(FIELDS)
        if unknown:  # a typo in shipped data is a bug: fail loudly in tests
            raise ConfigError(f"preset {name!r} has unknown fields {sorted(unknown)}")
    return presets


def get_preset(name: str) -> dict[str, Any]:
    presets = load_presets()
    if name not in presets:
        raise ConfigError(f"unknown preset {name!r}; choose one of: {', '.join(presets)}")
    return dict(presets[name])


def names() -> tuple[str, ...]:
    """The preset names, in the order ``povh3d presets`` lists them."""
    return tuple(load_presets())


def lens_array(name: str, **overrides: Any) -> LensArray:
    """The lens array of preset ``name``, with display fields overridden by keyword
    (``lens_array("demo", ppl=6, focal=2.0)``; see ``FIELDS``)."""
    return lens_array_from_fields(merge_overrides(get_preset(name), overrides))


#: Pixels per lens: below a millionth, or above a million, the lens count leaves the float range.
PPL_RANGE = (1e-6, 1e6)


def _pair(name: str, value: Any, *, integral: bool = False, bounds: tuple[float, float] | None = None,
          unit: str = "") -> tuple[float, float]:
    """A scalar or a 2-list as (x, y); a scalar means the same value both ways."""
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise ConfigError(f"{name} takes one value or two (x, y), got {value!r}")
        x, y = value
    else:
        x = y = value
    for v in (x, y):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ConfigError(f"{name} must be numbers, got {value!r}")
        if not math.isfinite(float(v)) or v <= 0:
            raise ConfigError(f"{name} must be positive finite numbers, got {value!r}")
        if bounds is not None and not bounds[0] <= v <= bounds[1]:   # a lens count past the float range
            raise ConfigError(f"{name} must be between {bounds[0]:g} and {bounds[1]:g} {unit}, got {v:g}")
        if integral and float(v) != int(v):
            raise ConfigError(f"{name} must be whole numbers, got {value!r}")
    return (x, y)


def merge_overrides(fields: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """Apply CLI overrides field by field; a changed array re-derives the panel.

    An override that names no display field (a misspelling) is refused by name.
    """
    unknown = sorted(set(overrides) - set(FIELDS))
    if unknown:
        raise ConfigError(f"unknown display field {', '.join(map(repr, unknown))}; the fields are: "
                          f"{', '.join(FIELDS)}")
    merged = dict(fields)
    given = {k: v for k, v in overrides.items() if v is not None}
    if any(k in given for k in _ARRAY_FIELDS) and "panel" not in given:
        # A lens count re-derives the panel; a new PPL or pitch alone keeps the
        # preset's panel and re-derives the lens count (ipad-retina --ppl 22).
        if any(k in given for k in ("lenses", "rows")):
            merged.pop("panel", None)
        else:
            merged.pop("lenses", None)
        if "ppl" in given:
            merged.pop("lens_pitch", None)
        # A custom array renders as given: the preset's mapping and design distance no longer apply.
        for key in ("views", "mapping", "slant_deg", "viewing_distance_mm", "viewing_distance_source"):
            merged.pop(key, None)
    if "ppl" in given and "lens_pitch" not in given:
        merged.pop("lens_pitch", None)
    # Lattice vectors replace the grid and its pitches; any other grid drops them.
    if "lattice" in given:
        if "ppl" in given or "lens_pitch" in given or given.get("grid", "lattice") != "lattice":
            raise ConfigError(f"{param('lattice')} gives the lens cells itself; drop {param('ppl')} and {param('grid')}")
        given["grid"] = "lattice"
    elif given.get("grid", "lattice") != "lattice" or "ppl" in given:
        merged.pop("lattice", None)
        if merged.get("grid") == "lattice" and "grid" not in given:
            merged["grid"] = "square"
    merged.update(given)
    return merged


def lens_array_from_fields(fields: dict[str, Any]) -> LensArray:
    """Resolve display fields into a LensArray.

    A preset with ``views`` and ``mapping`` describes a panel whose lens sheet
    spans a fractional number of pixels; what gets rendered is the unmapped H3D
    image in view space: ``views`` pixels per lens, one pixel row per panel row.
    """
    from ..geometry.lens_array import LENGTH_RANGE_MM, MAX_PANEL_PIXELS, LensArray, Panel

    grid = fields.get("grid", "square")
    if fields.get("sheet_from") == "calibration" and "lens_pitch" not in fields:
        from .looking_glass import no_calibration

        raise no_calibration(str(fields.get("description", "this display")).split(":")[0])
    if "focal" not in fields:
        raise ConfigError(f"the focal length is missing; give it with {param('focal')} (mm)")
    if "pixel_pitch" not in fields:
        raise ConfigError(f"the pixel pitch is missing; give it with {param('pixel_pitch')} (mm)")
    sx, sy = _pair(f"pixel pitch ({param('pixel_pitch')})", fields["pixel_pitch"], bounds=LENGTH_RANGE_MM, unit="mm")
    panel_size = _pair(f"panel size ({param('panel')})", fields["panel"], integral=True) if "panel" in fields else None

    if fields.get("views") and fields.get("mapping") and panel_size is not None and "lens_pitch" in fields:
        views = int(fields["views"])
        lens_pitch = float(fields["lens_pitch"])
        lenses = math.floor(panel_size[0] * sx / lens_pitch + _EPS)
        panel = Panel(lenses * views, int(panel_size[1]), lens_pitch / views, sy)
        return LensArray(grid, lenses, panel.height, lens_pitch, sy, float(fields["focal"]), panel)

    if grid == "lattice" or "lattice" in fields:
        return _lattice_from_fields(fields, sx, sy, panel_size)
    if "ppl" in fields:
        nx, ny = _pair(f"pixels per lens ({param('ppl')})", fields["ppl"], bounds=PPL_RANGE, unit="pixels")
        px, py = nx * sx, ny * sy
    elif "lens_pitch" in fields:
        px = py = _pair("lens pitch", fields["lens_pitch"], bounds=LENGTH_RANGE_MM, unit="mm")[0]
    else:
        raise ConfigError(f"the lens pitch is missing; give pixels per lens with {param('ppl')}")
    if grid == "lenticular":
        py = sy
    elif grid == "hex":
        py = px * math.sqrt(3) / 2

    rows = fields.get("rows")
    if "lenses" in fields:
        if grid == "lenticular":
            if isinstance(fields["lenses"], (list, tuple)):
                raise ConfigError(f"a lenticular array takes one lens count ({param('lenses')} 60) and the rows with {param('rows')}")
            lx = fields["lenses"]
            ly = rows if rows is not None else (panel_size[1] if panel_size else None)
            if ly is None:
                raise ConfigError(f"a lenticular array needs the panel height; give it with {param('rows')}")
        else:
            lx, ly = _pair(f"lens count ({param('lenses')})", fields["lenses"], integral=True)
    elif panel_size is not None:
        lx = math.floor(panel_size[0] * sx / px + _EPS) if grid != "hex" else math.floor((panel_size[0] * sx - px / 2) / px + _EPS)
        ly = panel_size[1] if grid == "lenticular" else math.floor(panel_size[1] * sy / py + _EPS)
    else:
        raise ConfigError(f"the lens count is missing; give it with {param('lenses')}")
    if grid == "lenticular" and rows is not None:
        ly = rows
    if not (math.isfinite(lx) and math.isfinite(ly)) or max(lx, ly) > MAX_PANEL_PIXELS:
        raise ConfigError(f"the display has {lx:g} x {ly:g} lenses; check {param('ppl')}, {param('pixel_pitch')} and {param('panel')}")
    lx, ly = int(lx), int(ly)
    rotation = fields.get("lens_rotation", 0.0)
    if rotation and "lenses" not in fields and panel_size is not None:
        lx, ly = _covering_counts(grid, rotation, panel_size[0] * sx, panel_size[1] * sy, px, py, lx, ly)
    if lx < 1 or ly < 1:
        raise ConfigError(f"the lens array would have {lx}x{ly} lenses; it needs at least one each way: give "
                          f"{param('lenses')} (and {param('rows')} for lenticular), a larger {param('panel')} or fewer pixels per lens ({param('ppl')})")
    for length in (sx, sy, px, py):
        _length(length)
    if lx * ly > MAX_PANEL_PIXELS:
        raise ConfigError(f"{lx}x{ly} lenses are more than povh3d can render; use fewer lenses ({param('lenses')})")

    if panel_size is not None:
        w, h = int(panel_size[0]), int(panel_size[1])
    else:
        extra = px / 2 if grid == "hex" and ly > 1 else 0.0
        w = math.ceil((lx * px + extra) / sx - _EPS)
        h = ly if grid == "lenticular" else math.ceil(ly * py / sy - _EPS)
    return LensArray(grid, lx, ly, px, py, float(fields["focal"]), Panel(w, h, sx, sy), rotation)


def parse_lattice(value: Any) -> tuple[tuple[float, float], tuple[float, float]]:
    """Lattice vectors (mm) from a ``lattice`` field or ``--lattice`` (docs/geometry.md, "General lattices").

    ``'A1X,A1Y;A2X,A2Y'`` or ``[[a1x, a1y], [a2x, a2y]]``: the two vectors;
    ``'cross:P,SLANT'`` or ``'cross:PV,PH,SLANT'``: a vertical lenticular sheet of pitch
    ``PV`` crossed with a horizontal one of pitch ``PH`` whose lenticules are slanted
    ``SLANT`` degrees (thesis 5.3).
    """
    from ..geometry.lattice import cross_lenticular_basis, lattice_vectors

    example = "give two vectors in mm, '0.6,0;0.1,0.6', or crossed sheets, 'cross:2.12,6.34'"
    if isinstance(value, str):
        text = value.strip()
        try:
            if text.lower().startswith("cross:"):
                numbers = [float(t) for t in text[6:].split(",")]
                if len(numbers) not in (2, 3) or not all(math.isfinite(n) for n in numbers):
                    raise ValueError
                pv, ph, slant = numbers if len(numbers) == 3 else (numbers[0], *numbers)
                if pv <= 0 or ph <= 0:
                    raise ConfigError(f"cross-lenticular pitches must be positive (mm), got {text!r}; {example}")
                return cross_lenticular_basis(pv, ph, slant)
            value = [[float(t) for t in vector.split(",")] for vector in text.split(";")]
        except ValueError:
            raise ConfigError(f"{param('lattice')} cannot read {value!r}; {example}") from None
    a1, a2 = lattice_vectors(value)
    return (float(a1[0]), float(a1[1])), (float(a2[0]), float(a2[1]))


def _lattice_from_fields(fields: dict[str, Any], sx: float, sy: float,
                         panel_size: tuple[float, float] | None) -> LensArray:
    """A ``grid='lattice'`` LensArray: vectors turned by any ``lens_rotation``; lens counts that
    cover the panel unless given (``lenses``), or the panel that holds the counted cells."""
    import numpy as np

    from ..geometry.lattice import lattice_coordinates, lattice_vectors
    from ..geometry.lens_array import MAX_PANEL_PIXELS, Panel, lattice_array, lens_rotation

    if "lattice" not in fields:
        raise ConfigError(f"grid 'lattice' needs its two lattice vectors; give them with {param('lattice')}")
    if fields.get("grid", "lattice") != "lattice":
        raise ConfigError(f"lattice vectors are a grid of their own, not {fields['grid']!r}; drop {param('grid')} or {param('lattice')}")
    a1, a2 = (np.asarray(a) for a in parse_lattice(fields["lattice"]))
    rotation = lens_rotation(fields.get("lens_rotation") or 0.0)
    if rotation:  # a turned lattice is the lattice of turned vectors
        c, s = math.cos(math.radians(rotation)), math.sin(math.radians(rotation))
        turn = np.array([[c, -s], [s, c]])
        a1, a2 = lattice_vectors((turn @ a1, turn @ a2))
    if "lenses" in fields:
        lx, ly = _pair(f"lens count ({param('lenses')})", fields["lenses"], integral=True)
    elif panel_size is not None:
        half_w, half_h = panel_size[0] * sx / 2, panel_size[1] * sy / 2
        s_, t_ = lattice_coordinates(a1, a2, np.array([-half_w, half_w, half_w, -half_w]),
                                     np.array([-half_h, -half_h, half_h, half_h]))
        lx, ly = (math.ceil(2 * np.abs(v).max() - _EPS) for v in (s_, t_))
    else:
        raise ConfigError(f"a lattice needs the panel size ({param('panel')}) or the lens count ({param('lenses')})")
    lx, ly = int(lx), int(ly)
    if lx * ly > MAX_PANEL_PIXELS:
        raise ConfigError(f"{lx}x{ly} lenses are more than povh3d can render; use fewer lenses ({param('lenses')})")
    if panel_size is None:  # the panel that holds every cell: corners (+-Lx/2) a1 + (+-Ly/2) a2
        reach = lx / 2 * np.abs(a1) + ly / 2 * np.abs(a2)
        panel_size = (math.ceil(2 * reach[0] / sx - _EPS), math.ceil(2 * reach[1] / sy - _EPS))
    return lattice_array((a1, a2), lx, ly, float(fields["focal"]), Panel(int(panel_size[0]), int(panel_size[1]), sx, sy))


def _covering_counts(grid: str, rotation: Any, width: float, height: float, px: float, py: float,
                     lx: int, ly: int) -> tuple[int, int]:
    """Lens counts of a turned lattice that covers a ``width x height`` mm panel (odd counts
    keep a lens centred as in the upright array only by chance; every pixel gets a lens)."""
    if not isinstance(rotation, (int, float)) or isinstance(rotation, bool) or not math.isfinite(rotation):
        return lx, ly  # LensArray refuses it with the one-line message
    c, s = abs(math.cos(math.radians(rotation))), abs(math.sin(math.radians(rotation)))
    reach_x, reach_y = width * c + height * s, width * s + height * c
    lx = math.ceil(reach_x / px - _EPS) + (2 if grid == "hex" else 1)
    return lx, (ly if grid == "lenticular" else math.ceil(reach_y / py - _EPS) + 1)


def _length(value: float) -> None:
    """A pitch in the range LensArray accepts, checked before a panel size is derived from it."""
    from ..geometry.lens_array import LENGTH_RANGE_MM

    low, high = LENGTH_RANGE_MM
    if not low <= value <= high:
        raise ConfigError(f"pitches must be between {low:g} and {high:g} mm, got {value:g}; "
                          f"check {param('pixel_pitch')} and {param('ppl')}")


def physical_panel(fields: dict[str, Any]) -> Panel | None:
    """The physical panel of a preset whose array is its mapping's view space (a ``mapping`` field), else None."""
    from ..geometry.lens_array import Panel

    if "panel" not in fields or not fields.get("mapping"):
        return None
    (w, h), (sx, sy) = fields["panel"], _pair(f"pixel pitch ({param('pixel_pitch')})", fields["pixel_pitch"])
    return Panel(int(w), int(h), float(sx), float(sy))


def calibrated_fields(fields: dict[str, Any], cal: Any) -> dict[str, Any]:
    """A preset whose sheet is the unit's own (``sheet_from = "calibration"``, the 27") completed
    from that unit's ``visual.json`` (a ``looking_glass.Calibration``) the way the other Looking
    Glass presets are made from their factory calibrations (presets.toml): panel, pixel pitch,
    lens pitch along a row, slant and the focal length that spans the unit's cone."""
    from .quilt import sheet_focal

    done = {k: v for k, v in fields.items() if k != "sheet_from"}
    done.update(panel=[cal.screen_w, cal.screen_h], pixel_pitch=cal.pixel_pitch_mm, lens_pitch=cal.lens_pitch_mm,
                focal=sheet_focal(cal), slant_deg=cal.slant_deg)
    return done

