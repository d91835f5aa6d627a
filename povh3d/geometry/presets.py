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

from ..errors import ConfigError

if TYPE_CHECKING:  # imported where used: listing presets needs no NumPy
    from .lens_array import LensArray

FIELDS = ("description", "grid", "panel", "pixel_pitch", "lens_pitch", "ppl", "lenses",
          "rows", "focal", "views", "slant_deg", "mapping", "lens_rotation")

# Overriding any of these re-derives the panel from the lens array, unless the
# panel itself is given.
_ARRAY_FIELDS = ("grid", "lenses", "ppl", "rows", "lens_pitch")

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


def _pair(name: str, value: Any, *, integral: bool = False) -> tuple[float, float]:
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
        # A custom array renders as given: the preset's mapping no longer applies.
        for key in ("views", "mapping", "slant_deg"):
            merged.pop(key, None)
    if "ppl" in given and "lens_pitch" not in given:
        merged.pop("lens_pitch", None)
    merged.update(given)
    return merged


def lens_array_from_fields(fields: dict[str, Any]) -> LensArray:
    """Resolve display fields into a LensArray.

    A preset with ``views`` and ``mapping`` describes a panel whose lens sheet
    spans a fractional number of pixels; what gets rendered is the unmapped H3D
    image in view space: ``views`` pixels per lens, one pixel row per panel row.
    """
    from .lens_array import MAX_PANEL_PIXELS, LensArray, Panel

    grid = fields.get("grid", "square")
    if "focal" not in fields:
        raise ConfigError("the focal length is missing; give it with --focal (mm)")
    if "pixel_pitch" not in fields:
        raise ConfigError("the pixel pitch is missing; give it with --pixel-pitch (mm)")
    sx, sy = _pair("pixel pitch (--pixel-pitch)", fields["pixel_pitch"])
    panel_size = _pair("panel size (--panel)", fields["panel"], integral=True) if "panel" in fields else None

    if fields.get("views") and fields.get("mapping") and panel_size is not None and "lens_pitch" in fields:
        views = int(fields["views"])
        lens_pitch = float(fields["lens_pitch"])
        lenses = math.floor(panel_size[0] * sx / lens_pitch + _EPS)
        panel = Panel(lenses * views, int(panel_size[1]), lens_pitch / views, sy)
        return LensArray(grid, lenses, panel.height, lens_pitch, sy, float(fields["focal"]), panel)

    if "ppl" in fields:
        nx, ny = _pair("pixels per lens (--ppl)", fields["ppl"])
        px, py = nx * sx, ny * sy
    elif "lens_pitch" in fields:
        px = py = _pair("lens pitch", fields["lens_pitch"])[0]
    else:
        raise ConfigError("the lens pitch is missing; give pixels per lens with --ppl")
    if grid == "lenticular":
        py = sy
    elif grid == "hex":
        py = px * math.sqrt(3) / 2

    rows = fields.get("rows")
    if "lenses" in fields:
        if grid == "lenticular":
            if isinstance(fields["lenses"], (list, tuple)):
                raise ConfigError("a lenticular array takes one lens count (--lenses 60) and the rows with --rows")
            lx = fields["lenses"]
            ly = rows if rows is not None else (panel_size[1] if panel_size else None)
            if ly is None:
                raise ConfigError("a lenticular array needs the panel height; give it with --rows")
        else:
            lx, ly = _pair("lens count (--lenses)", fields["lenses"], integral=True)
    elif panel_size is not None:
        lx = math.floor(panel_size[0] * sx / px + _EPS) if grid != "hex" else math.floor((panel_size[0] * sx - px / 2) / px + _EPS)
        ly = panel_size[1] if grid == "lenticular" else math.floor(panel_size[1] * sy / py + _EPS)
    else:
        raise ConfigError("the lens count is missing; give it with --lenses")
    if grid == "lenticular" and rows is not None:
        ly = rows
    lx, ly = int(lx), int(ly)
    rotation = fields.get("lens_rotation", 0.0)
    if rotation and "lenses" not in fields and panel_size is not None:
        lx, ly = _covering_counts(grid, rotation, panel_size[0] * sx, panel_size[1] * sy, px, py, lx, ly)
    if lx < 1 or ly < 1:
        raise ConfigError(f"the lens array would have {lx}x{ly} lenses; it needs at least one each way: give "
                          "--lenses (and --rows for lenticular), a larger --panel or fewer pixels per lens (--ppl)")
    for length in (sx, sy, px, py):
        _length(length)
    if lx * ly > MAX_PANEL_PIXELS:
        raise ConfigError(f"{lx}x{ly} lenses are more than povh3d can render; use fewer lenses (--lenses)")

    if panel_size is not None:
        w, h = int(panel_size[0]), int(panel_size[1])
    else:
        extra = px / 2 if grid == "hex" and ly > 1 else 0.0
        w = math.ceil((lx * px + extra) / sx - _EPS)
        h = ly if grid == "lenticular" else math.ceil(ly * py / sy - _EPS)
    return LensArray(grid, lx, ly, px, py, float(fields["focal"]), Panel(w, h, sx, sy), rotation)


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
    from .lens_array import LENGTH_RANGE_MM

    low, high = LENGTH_RANGE_MM
    if not low <= value <= high:
        raise ConfigError(f"pitches must be between {low:g} and {high:g} mm, got {value:g}; "
                          "check --pixel-pitch and --ppl")


def describe_fields(fields: dict[str, Any]) -> dict[str, Any]:
    """The display fields that are not geometry (mapping, slant, physical panel)."""
    out = {k: fields[k] for k in ("description", "views", "slant_deg", "mapping") if k in fields}
    if "panel" in fields and fields.get("mapping"):
        sx, sy = _pair("pixel pitch (--pixel-pitch)", fields["pixel_pitch"])
        out["physical_panel"] = {"size_px": list(fields["panel"]), "pixel_pitch_mm": [sx, sy]}
    return out


def lens_array_from_record(record: dict[str, Any]) -> LensArray:
    """The LensArray a sidecar's ``lens_array`` entry (``LensArray.describe()``) describes."""
    from .lens_array import LensArray, Panel

    try:
        panel = Panel(*record["panel"]["size_px"], *record["panel"]["pixel_pitch_mm"])
        return LensArray(record["grid"], *record["lenses"], *record["lens_pitch_mm"], record["focal_mm"], panel,
                         record.get("rotation_deg", 0.0))
    except (KeyError, TypeError) as exc:
        raise ConfigError(f"the sidecar's lens array is incomplete ({exc}); give --ppl NxxNy") from None
