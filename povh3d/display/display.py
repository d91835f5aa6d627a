"""The display a render is for, as one value: ``Display``, built by ``build_display`` (the one
builder the command line and ``povh3d.render`` both call), written to a sidecar by
``Display.as_record`` and read back by ``Display.from_record``.

Why in ``app/``: a display joins a preset (``geometry.presets``), a pixel mapping
(``mappings``), the sheet that ``--method subpixel`` traces (``display.subpixel``,
``display.calibrated_sheet``) and a calibration file the user named.  ``app/`` is the lowest
layer allowed to know all four and to read a user's file; the engine receives from a
``Display`` only what it renders: its ``render_array`` and the sheet's shift (a method option).
"""

from __future__ import annotations

from .. import jsontext
import math
from collections.abc import Mapping as MappingABC
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..errors import ConfigError, InputError, param
from ..geometry.lens_array import LensArray, Panel
from .mappings.base import Mapping


@dataclass(frozen=True)
class Display:
    """A display: its lens array, what its preset says of it, and how its panel is addressed.

    Attributes
    ----------
    lens_array : LensArray         the display's lens array; with ``--method subpixel`` on a
                                   slanted display, the sheet it traces over the physical panel
    preset : str or None           the preset it came from (None: a lens array of the caller's own)
    description : str or None      the preset's description of the device
    views, slant_deg               a slanted preset's view count and lens slant (deg), or None
    mapping_name : str or None     the panel's pixel mapping (the preset's, or the one applied)
    physical_panel : Panel or None a slanted preset's panel, when ``lens_array`` is its view space
    mapping : Mapping or None      applied: render exactly the views it reads, then map them onto
                                   ``mapped_panel``
    sheet : mapping or None        where the traced sheet came from (``--method subpixel``): the
                                   preset's mapping and offset, or a calibration and its ``shift_mm``
    quilt : mapping or None        a Looking Glass preset's quilt (``display.quilt``): ``device``
                                   and the unit's ``calibration`` file (None: the factory one)
    mapping_options : mapping or None  read from a sidecar: the applied mapping's parameters
                                   (``mappings.mapping_parameters``), which rebuild it exactly
                                   (``mappings.mapping_from_record``); None in older sidecars
    viewing_distance_mm : float or None  a lenticular preset's design distance, mm (``presets.toml``):
                                   the default of the render's viewing distance (``RenderRequest.viewing``)
    viewing_distance_source : str or None  where that distance comes from, for the sidecar
    """

    lens_array: LensArray
    preset: str | None = None
    description: str | None = None
    views: int | None = None
    slant_deg: float | None = None
    mapping_name: str | None = None
    physical_panel: Panel | None = None
    mapping: Mapping | None = None
    sheet: MappingABC[str, Any] | None = None
    quilt: MappingABC[str, Any] | None = None
    mapping_options: MappingABC[str, Any] | None = None
    viewing_distance_mm: float | None = None
    viewing_distance_source: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.lens_array, LensArray):
            raise ConfigError(f"lens_array must be a povh3d.LensArray, got {type(self.lens_array).__name__}")
        if self.mapping is not None and self.mapping_name != self.mapping.name:
            object.__setattr__(self, "mapping_name", self.mapping.name)

    @property
    def mapped_panel(self) -> Panel | None:
        """The physical panel the mapping fills (None without a mapping)."""
        if self.mapping is None:
            return None
        return self.physical_panel or self.lens_array.panel

    @property
    def render_array(self) -> LensArray:
        """The array the method renders: the display's, or the view-space array a mapping reads."""
        if self.mapping is None:
            return self.lens_array
        return self.mapping.render_array(self.physical_panel or self.lens_array.panel,  # mapped_panel
                                         self.lens_array.focal)

    @property
    def image_size(self) -> tuple[int, int]:
        """``(W, H)`` of the image written: the mapped panel, or the H3D image."""
        panel = self.mapped_panel or self.lens_array.panel
        return panel.width, panel.height

    @property
    def sheet_shift_mm(self) -> float | None:
        """How far across a calibration puts the traced sheet (``subpixel.placed_sheet``), or None."""
        return None if not self.sheet or "shift_mm" not in self.sheet else float(self.sheet["shift_mm"])

    def as_record(self) -> dict[str, Any]:
        """The sidecar's ``lens_array`` (the array rendered) and ``display`` entries."""
        display: dict[str, Any] = {"preset": self.preset}
        for key, value in (("description", self.description), ("views", self.views),
                           ("slant_deg", self.slant_deg), ("mapping", self.mapping_name)):
            if value is not None:
                display[key] = value
        if self.mapping is not None:  # every parameter, so a replay rebuilds this mapping, not the preset's
            from .mappings import mapping_parameters

            display["mapping_options"] = mapping_parameters(self.mapping)
        elif self.mapping_options is not None:
            display["mapping_options"] = dict(self.mapping_options)
        if self.physical_panel is not None:
            p = self.physical_panel
            display["physical_panel"] = {"size_px": [p.width, p.height], "pixel_pitch_mm": [p.pitch_x, p.pitch_y]}
        if self.sheet is not None:
            display["sheet"] = dict(self.sheet)
        if self.quilt is not None:
            display["quilt"] = dict(self.quilt)
        return {"lens_array": self.render_array.as_record(), "display": display}

    @classmethod
    def from_record(cls, record: MappingABC[str, Any]) -> Display:
        """The display a sidecar describes (``as_record``; a sidecar without a ``display`` entry is a
        lens array alone).  Its ``lens_array`` is the array the image was rendered through.

        A damaged or forged sidecar (a field of the wrong type, a NaN, a zero pitch, zero views) is
        one ``ConfigError`` naming the field, never a crash further on.
        """
        side = record.get("lens_array") if isinstance(record, MappingABC) else None
        if not isinstance(side, MappingABC):
            raise ConfigError(f"the sidecar's lens_array is {_kind(side)}, not a lens array; "
                              f"delete the sidecar and give {param('ppl')} NxxNy")
        try:
            _check_pairs(side, ("lenses", "lens_pitch_mm"), ("views",))
            (lenses_x, lenses_y), (pitch_x, pitch_y) = side["lenses"], side["lens_pitch_mm"]  # pairs: checked
            basis: Any = tuple(map(tuple, side["lattice_mm"])) if "lattice_mm" in side else None  # LensArray checks it
            lens_array = LensArray(side["grid"], lenses_x, lenses_y, pitch_x, pitch_y, side["focal_mm"],
                                   _panel(side["panel"]), side.get("rotation_deg", 0.0),
                                   basis)
        except (KeyError, TypeError, ValueError, IndexError, AttributeError, OverflowError, ZeroDivisionError) as exc:
            raise ConfigError(f"the sidecar's lens array is incomplete or damaged ({type(exc).__name__}: {exc}); "
                              f"delete the sidecar and give {param('ppl')} NxxNy") from None
        if side.get("views") is not None and [int(v) for v in side["views"]] != \
                (list(lens_array.views[::-1]) if lens_array.views else None):
            raise ConfigError(f"the sidecar's lens array has views {side['views']!r}, which its lenses and panel "
                              f"contradict; delete the sidecar and give {param('ppl')} NxxNy")
        d = record.get("display") or {}
        if not isinstance(d, MappingABC):
            raise ConfigError(f"the sidecar's display is {_kind(d)}, not a display; delete the sidecar")
        views, slant = d.get("views"), d.get("slant_deg")
        if views is not None and (isinstance(views, bool) or not isinstance(views, int) or views < 1):
            raise ConfigError(f"the sidecar's display has {views!r} views, not a whole number >= 1; delete the sidecar")
        if slant is not None and not _finite(slant):
            raise ConfigError(f"the sidecar's display slant {slant!r} is not a finite number; delete the sidecar")
        seen = d.get("viewing_distance")   # what the rows were rendered for (render's record)
        distance = seen.get("mm") if isinstance(seen, MappingABC) else None
        if distance is not None and not (_finite(distance) and distance > 0):
            raise ConfigError(f"the sidecar's viewing distance {distance!r} is not a distance in mm; delete the sidecar")
        try:
            return cls(lens_array, d.get("preset"), d.get("description"), views, slant,
                       d.get("mapping"), _panel(d["physical_panel"]) if d.get("physical_panel") else None,
                       sheet=d.get("sheet") if isinstance(d.get("sheet"), MappingABC) else None,
                       quilt=d.get("quilt") if isinstance(d.get("quilt"), MappingABC) else None,
                       mapping_options=_options(d.get("mapping_options")),
                       viewing_distance_mm=None if distance is None else float(distance))
        except (KeyError, TypeError, ValueError, IndexError, AttributeError, OverflowError) as exc:
            raise ConfigError(f"the sidecar's display is damaged ({type(exc).__name__}: {exc}); "
                              "delete the sidecar") from None


def _options(value: Any) -> dict[str, Any] | None:
    if value is None:
        return None
    if not isinstance(value, MappingABC) or not all(isinstance(v, (int, float, str, bool)) for v in value.values()):
        raise ValueError(f"mapping_options is {_kind(value)}, not a table of numbers, names and flags")
    return dict(value)


def _kind(value: Any) -> str:
    return "missing" if value is None else f"a {type(value).__name__} ({str(value)[:40]!r})"


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_pairs(side: MappingABC[str, Any], numbers: tuple[str, ...], counts: tuple[str, ...]) -> None:
    """Each of ``numbers`` two finite numbers; each of ``counts``, when given, two whole numbers >= 1."""
    for key in numbers + counts:
        value = side.get(key)
        if value is None and key in counts:
            continue
        if not (isinstance(value, list) and len(value) == 2 and all(map(_finite, value))):
            raise ValueError(f"{key} is {value!r}, not two finite numbers")
        if key in counts and not all(float(v).is_integer() and v >= 1 for v in value):
            raise ValueError(f"{key} is {value!r}, not two whole numbers >= 1")


def _panel(record: MappingABC[str, Any]) -> Panel:
    (w, h), (sx, sy) = record["size_px"], record["pixel_pitch_mm"]
    if not all(map(_finite, (w, h, sx, sy))) or not (float(w).is_integer() and float(h).is_integer()):
        raise ValueError(f"the panel {record['size_px']!r} px, {record['pixel_pitch_mm']!r} mm is not whole "
                         "pixels and finite pitches")
    return Panel(int(w), int(h), float(sx), float(sy))


def build_display(preset: str | None = "demo", overrides: MappingABC[str, Any] | None = None, *,
                  lens_array: LensArray | None = None, method: str = "multi-ortho", mapping: str | None = None,
                  mapping_options: MappingABC[str, Any] | None = None,
                  calibration: str | Path | None = None, camera_model: str | None = None) -> Display:
    """The display a render is for: the command line's and ``povh3d.render``'s one builder.

    Parameters
    ----------
    preset : str               a display preset (``povh3d.presets.names()``)
    overrides : mapping        preset fields replaced (``geometry.presets.FIELDS``: ``ppl``, ``focal`` ...)
    lens_array : LensArray     a lens array of the caller's own, instead of the preset's
    method : str               the render method (``subpixel`` traces a slanted preset's sheet itself)
    mapping : str              a pixel mapping to apply (``alioscopy``, ``slanted``, ``smart:4`` ...)
    mapping_options : mapping  its options (``per_lens``, ``views``, ``slope``, ``offset``,
                               ``rows_per_view``, ``reverse``, ``blend``)
    calibration : path         a calibration file: the sheet of ``mapping='slanted'`` or of ``method='subpixel'``
                               (a Looking Glass preset: the unit's ``visual.json``)
    camera_model : str         a Looking Glass preset's views: ``perspective`` (the vendor's sheared
                               cameras, the default) or ``orthographic`` (``display.quilt``)
    """
    from .presets import get_preset, lens_array_from_fields, merge_overrides, physical_panel

    options = {k: v for k, v in (mapping_options or {}).items() if v is not None}
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    device_quilt = lens_array is None and not given and not mapping and method != "subpixel" and not options
    if lens_array is None:
        fields = get_preset(preset or "demo")
        if fields.get("sheet_from") == "calibration":  # the 27": the unit's calibration gives the sheet
            from .presets import calibrated_fields

            if calibration is None and device_quilt:  # a quilt needs no sheet: the layout and a cone
                return _device_display(Display(_placeholder_array(), preset, fields.get("description"),
                                               fields.get("views")), _device(preset), None, camera_model or "perspective")
            if calibration is not None:
                fields = calibrated_fields(fields, _device_calibration(preset, calibration))
        fields = merge_overrides(fields, dict(overrides or {}))
        display = Display(lens_array_from_fields(fields), preset or "demo", fields.get("description"),
                          fields.get("views"), fields.get("slant_deg"), fields.get("mapping"),
                          physical_panel(fields), viewing_distance_mm=fields.get("viewing_distance_mm"),
                          viewing_distance_source=fields.get("viewing_distance_source"))
    else:
        if overrides:
            raise ConfigError("a lens array of your own takes no preset overrides; build it with them instead")
        display = Display(lens_array)
    if device_quilt and _device(preset) is not None:  # the device's views at its tile size, for its quilt
        return _device_display(display, _device(preset), calibration, camera_model or "perspective")
    if camera_model is not None:
        raise ConfigError(f"{param('camera_model')} chooses a Looking Glass preset's views; {preset or 'this display'} "
                          f"with these options renders its lens array's own: drop {param('camera_model')}")
    if calibration is not None and not mapping and method != "subpixel":
        raise ConfigError(f"{param('calibration')} gives the sheet of {param('mapping')} slanted or of {param('method')} subpixel; "
                          f"add one of them, or drop {param('calibration')}")
    if method == "subpixel":
        return _subpixel_sheet(display, mapping, options, calibration)
    if mapping:
        built, panel = mapping_for_display(mapping, display, calibration=calibration, **options)
        if calibration is not None and is_visual(read_calibration(calibration)):
            return replace(display, mapping=built, physical_panel=panel)  # the file's screen is the panel
        return replace(display, mapping=built)
    return display


def _device_display(display: Display, device: Any, calibration: str | Path | None, camera_model: str) -> Display:
    """A Looking Glass preset rendered for its quilt (``display.quilt``): the camera bank of
    one lens per tile pixel over the panel, spanning the unit's view cone (its views the
    vendor's perspective cameras, or that bank's oblique orthographic views)."""
    from .quilt import check_camera_model, quilt_array, quilt_views, warn_default_cone

    views = quilt_views(device, calibration)
    spec = {"device": device.name, "calibration": None if calibration is None else str(Path(calibration).resolve()),
            "camera_model": check_camera_model(camera_model)}
    warn_default_cone(device, calibration)
    return replace(display, lens_array=quilt_array(device, views), views=device.views, mapping_name=None, quilt=spec)


def _device(preset: str | None) -> Any:
    """The Looking Glass device a preset names, or None."""
    from .looking_glass import DEVICES

    return DEVICES.get(preset or "")


def _device_calibration(preset: str | None, calibration: str | Path) -> Any:
    from .quilt import device_calibration

    return device_calibration(_device(preset), calibration)


def _placeholder_array() -> LensArray:
    """A lens array ``_device_display`` replaces at once (a Display holds one from the start)."""
    return LensArray("lenticular", 1, 1, 1.0, 1.0, 1.0, Panel(1, 1, 1.0, 1.0))


def _subpixel_sheet(display: Display, mapping: str | None, options: dict[str, Any],
                    calibration: str | Path | None) -> Display:
    """``--method subpixel`` on a display with a slanted mapping (alioscopy-42, philips-20): the
    sheet that mapping describes, traced subpixel by subpixel straight to the panel image; with
    a calibration, the calibrated sheet where the calibration puts it."""
    if mapping:
        raise ConfigError(f"{param('method')} subpixel writes the panel image itself; drop {param('mapping')} (a preset's "
                          "slanted mapping gives the sheet it traces)")
    if not display.mapping_name and calibration is None:
        return display
    if options.get("offset"):
        raise ConfigError(f"{param('method')} subpixel traces the sheet centred on the panel, or where {param('calibration')} puts "
                          f"it; drop {param('offset')} (the sidecar records the mapping offset that addresses the same sheet)")
    from .subpixel import slanted_sheet

    la = display.lens_array
    nominal, panel, record = None, la.panel, {}
    if display.mapping_name:
        built, panel = mapping_for_display(display.mapping_name, display, **options)
        nominal, offset = slanted_sheet(built, panel, la.focal)
        record = {"from_mapping": built.name, "mapping_offset": offset}
    elif la.grid == "lenticular":
        nominal = la
    if calibration is None:
        assert nominal is not None  # a mapping gave it: no mapping and no calibration returned above
        return replace(display, lens_array=nominal, sheet=record)
    from .calibrated_sheet import calibrated_sheet

    sheet, _, record = calibrated_sheet(read_calibration(calibration), panel, la.focal, nominal)
    return replace(display, lens_array=sheet, sheet={**record, "calibration": str(Path(calibration).resolve())})


def mapping_for_display(name: str, display: Display, *, calibration: str | Path | None = None,
                        **options: Any) -> tuple[Mapping, Panel]:
    """The mapping ``name`` for ``display``, and the physical panel it fills.

    Presets with a mapping (alioscopy-42, philips-20) describe the view-space array;
    their physical panel is ``display.physical_panel``.
    """
    from .mappings import build_mapping, options_from_display

    panel = display.physical_panel or display.lens_array.panel
    if calibration is not None and is_visual(data := read_calibration(calibration)):
        if name != "slanted":
            raise ConfigError(f"a Looking Glass calibration gives a slanted sheet, not mapping {name!r}; "
                              f"use {param('mapping')} slanted")
        return _visual_mapping(data, display, **options)
    fields = {k: v for k, v in (("slant_deg", display.slant_deg), ("views", display.views)) if v is not None}
    fields.update(lens_pitch=display.lens_array.pitch_x, pixel_pitch=panel.pitch_x)
    if calibration is not None:
        options["calibration"] = read_calibration(calibration)
    opts = options_from_display(fields, display.lens_array.pitch_x / panel.pitch_x, **options)
    return build_mapping(name, opts), panel


def is_visual(data: Any) -> bool:
    """Whether a calibration file's JSON holds the Looking Glass fields (``pitch``): a unit's
    ``visual.json`` or ``povh3d calibrate --dpi`` output.  Without them it is a pixel file."""
    return isinstance(data, dict) and "pitch" in data


def _visual_mapping(data: dict[str, Any], display: Display, *, views: int | None = None, blend: bool = False,
                    **others: Any) -> tuple[Mapping, Panel]:
    """The slanted mapping of a Looking Glass calibration and the panel it describes: the file's
    ``screenW x screenH`` pixels of ``25.4 / DPI`` mm.  A preset's own panel, or a Looking Glass
    device's calibration, that the file contradicts is refused."""
    from .looking_glass import DEVICES, check_panel, parse_visual
    from .mappings import from_calibration
    from .mappings.looking_glass_shader import slanted_mapping

    from_calibration(data, 1)  # its fields present, and its pixel fields (calibrate --dpi) consistent with them
    cal = parse_visual(data)
    if display.preset in DEVICES:
        DEVICES[display.preset].check(cal)
    if display.physical_panel is not None:
        p = display.physical_panel
        check_panel(cal, (p.width, p.height), p.pitch_x)
    views = views or display.views
    if not views:
        raise ConfigError(f"a Looking Glass calibration needs the view count; give it with {param('views')}")
    unused = sorted(k for k, v in others.items() if v not in (None, False))
    if unused:
        raise ConfigError(f"the calibration gives the sheet; drop --{', --'.join(k.replace('_', '-') for k in unused)}")
    pitch = cal.pixel_pitch_mm
    return slanted_mapping(cal, int(views), blend=bool(blend)), Panel(cal.screen_w, cal.screen_h, pitch, pitch)


def read_calibration(path: str | Path) -> Any:
    """A calibration file's JSON (``map --calibration``, ``render --method subpixel --calibration``)."""
    try:
        return jsontext.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"cannot read the calibration {str(path)!r}: {exc.strerror}") from None
    except ValueError as exc:
        raise InputError(f"the calibration {str(path)!r} is not JSON: {exc}") from None
