"""Display pixel mappings: the registry ``MAPPINGS`` and how a name becomes a mapping.

``MAPPINGS`` maps each name to an entry that builds the mapping from the display
(its pixels per lens, its slant) and the N of ``smart:N``.  Tests loop over it,
so a new entry is tested by the existing tests.
"""

from __future__ import annotations

import math
from fractions import Fraction
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, cast  # cast: parse_name gives every mapping with an n_range its N

from ...errors import ConfigError, param
from .base import Mapping
from .sampling import Sampling, Source
from .slanted import Slanted, from_calibration, looking_glass
from .unslanted import Distributed, DistributedSmart, Triangular, smart

__all__ = ["MAPPINGS", "Mapping", "MappingOptions", "Sampling", "Source", "Slanted", "build_mapping",
           "from_calibration", "looking_glass", "mapping_from_record", "mapping_parameters", "options_from_display",
           "parse_name", "slope_from_degrees"]


@dataclass(frozen=True)
class MappingOptions:
    """What a mapping may need from the display and the command line.

    ppl : int or None          whole pixels per lens of an unslanted sheet (smart, triangular, ...)
    per_lens : float or None   slanted: subpixels X under one lens horizontally
    views : int or None        slanted: N
    slope : float or None      slanted: 3 tan a (subpixels per row)
    offset : float             slanted: k_off
    rows_per_view : int or None  slanted: panel rows per view row (default 3/slope when whole, else 1)
    reverse, blend : bool      slanted: reversed views, blended fractional views
    calibration : dict or None  Looking Glass fields (pitch, slope, center, invView, DPI, screenW, screenH)
    """

    ppl: int | None = None
    per_lens: float | None = None
    views: int | None = None
    slope: float | None = None
    offset: float = 0.0
    rows_per_view: int | None = None
    reverse: bool = False
    blend: bool = False
    calibration: dict[str, Any] | None = field(default=None, hash=False, compare=False)


@dataclass(frozen=True)
class Entry:
    build: Callable[[int | None, MappingOptions], Mapping]
    n_range: tuple[int, int] | None
    summary: str
    example: MappingOptions  # small options the registry tests use


def _need_ppl(name: str, opts: MappingOptions) -> int:
    if opts.ppl is None:
        raise ConfigError(f"mapping {name!r} needs whole pixels per lens; give them with {param('ppl')}")
    return opts.ppl


def _slanted(_: int | None, o: MappingOptions) -> Mapping:
    if o.calibration is not None:
        if o.views is None:
            raise ConfigError(f"a Looking Glass calibration needs the view count; give it with {param('views')}")
        return from_calibration(o.calibration, o.views, blend=o.blend)
    missing = [flag for flag, v in ((param("per_lens"), o.per_lens), (param("views"), o.views),
                                    (param("slope"), o.slope)) if v is None]
    if missing:
        raise ConfigError(f"mapping 'slanted' needs {', '.join(missing)} (or {param('calibration')} FILE.json)")
    rows = o.rows_per_view
    if rows is None:
        rows = round(3 / o.slope) if o.slope and abs(3 / o.slope - round(3 / o.slope)) < 1e-9 and \
            round(3 / o.slope) > 0 else 1
    assert o.per_lens is not None and o.views is not None and o.slope is not None  # none missing
    return Slanted("slanted", o.per_lens, o.views, o.slope, o.offset, rows, o.reverse, o.blend)


MAPPINGS: dict[str, Entry] = {
    "alioscopy": Entry(lambda n, o: Slanted("alioscopy", 8.0, 8, 1.0, o.offset, 3, o.reverse, o.blend), None,
                       "Alioscopy 8 views, slant atan(1/3) = 18.43 deg (thesis 4.6.2, Eq. 4.3)",
                       MappingOptions()),
    "philips": Entry(lambda n, o: Slanted("philips", 4.5, 9, 0.5, o.offset, 6, o.reverse, o.blend), None,
                     "Philips 9 views, slant atan(1/6) = 9.46 deg (thesis 4.6.1, Fig. 4.26)",
                     MappingOptions()),
    "slanted": Entry(_slanted, None,
                     "any slanted lenticular (van Berkel); or a Looking Glass calibration",
                     MappingOptions(per_lens=5.5, views=11, slope=0.75)),
    "triangular": Entry(lambda n, o: Triangular(_need_ppl("triangular", o)), None,
                        "R, G, B of a view pixel over 3 rows in a triangle, no slant (thesis 5.2.2)",
                        MappingOptions(ppl=10)),
    "distributed": Entry(lambda n, o: Distributed(_need_ppl("distributed", o)), None,
                         "R, G, B micro-images from 3 lenses a third as wide (thesis 5.2.3)",
                         MappingOptions(ppl=4)),
    "smart": Entry(lambda n, o: smart(cast(int, n), _need_ppl("smart", o)), (2, 7),
                   "N x PPL views over N rows, 3D pixel distance 1/N (thesis 5.2.4, Fig. 5.17)",
                   MappingOptions(ppl=5)),
    "distributed-smart": Entry(lambda n, o: DistributedSmart(cast(int, n), _need_ppl("distributed-smart", o),
                                                             f"distributed-smart:{n}"), (2, 7),
                               "smart:N then distributed (thesis 5.2.5)", MappingOptions(ppl=6)),
}


def parse_name(name: str) -> tuple[str, int | None]:
    """``'smart:3'`` -> ``('smart', 3)``; a ConfigError listing the names otherwise."""
    base, _, arg = str(name).partition(":")
    listing = ", ".join(f"{k}:N" if e.n_range else k for k, e in MAPPINGS.items())
    if base not in MAPPINGS:
        raise ConfigError(f"unknown mapping {name!r}; choose one of: {listing}")
    entry = MAPPINGS[base]
    if entry.n_range is None:
        if arg:
            raise ConfigError(f"mapping {base!r} takes no :N, got {name!r}")
        return base, None
    lo, hi = entry.n_range
    if not arg:
        raise ConfigError(f"mapping {base!r} needs its dimension N, e.g. {base}:{lo} (N = {lo}..{hi})")
    try:
        n = int(arg)
    except ValueError:
        n = None
    if n is None or not lo <= n <= hi:
        raise ConfigError(f"mapping {base!r} takes N from {lo} to {hi}, got {arg!r}")
    return base, n


def build_mapping(name: str, options: MappingOptions | None = None) -> Mapping:
    base, n = parse_name(name)
    return MAPPINGS[base].build(n, options or MappingOptions())


def slope_from_degrees(deg: float) -> float:
    """``3 tan a``, snapped to a small fraction when the angle is a rounded one.

    Data sheets quote rounded degrees (18.43 for atan(1/3), 9.46 for atan(1/6));
    over a thousand rows the rounding would drift a tenth of a subpixel.
    """
    tan = math.tan(math.radians(deg))
    frac = Fraction(tan).limit_denominator(12)
    if frac and abs(float(frac) - tan) <= 1e-3 * abs(tan):
        tan = float(frac)
    return 3 * tan


def options_from_display(fields: dict[str, Any], ppl_x: float | None, **given: Any) -> MappingOptions:
    """Options from display fields (a preset's slant and views) and the lens array's PPL."""
    opts: dict[str, Any] = {k: v for k, v in given.items() if v is not None}
    if "ppl" not in opts and ppl_x is not None and abs(ppl_x - round(ppl_x)) < 1e-6:
        opts["ppl"] = int(round(ppl_x))
    if fields.get("slant_deg") is not None and "slope" not in opts:
        opts["slope"] = slope_from_degrees(float(fields["slant_deg"]))
    if fields.get("views") and "views" not in opts:
        opts["views"] = int(fields["views"])
    if fields.get("lens_pitch") and fields.get("pixel_pitch") and "per_lens" not in opts:
        sx = fields["pixel_pitch"][0] if isinstance(fields["pixel_pitch"], (list, tuple)) else fields["pixel_pitch"]
        opts["per_lens"] = round(float(fields["lens_pitch"]) / (float(sx) / 3), 9)
    return MappingOptions(**opts)


# The mapping classes a sidecar may name (``mapping_parameters``'s ``kind``).
_KINDS: dict[str, type[Mapping]] = {cls.__name__: cls for cls in (Slanted, Triangular, Distributed, DistributedSmart)}


def mapping_parameters(mapping: Mapping) -> dict[str, Any]:
    """Every parameter of ``mapping`` (its class as ``kind``, then its dataclass fields): what a
    sidecar records so that ``mapping_from_record`` rebuilds the same mapping, options and all."""
    from dataclasses import fields

    # every mapping class is a frozen dataclass (base.Mapping's rule); the base class itself is not
    return {"kind": type(mapping).__name__, **{f.name: getattr(mapping, f.name) for f in fields(cast(Any, mapping))}}


def mapping_from_record(name: str, parameters: dict[str, Any]) -> Mapping:
    """The mapping ``mapping_parameters`` recorded (a sidecar's ``display.mapping_options``); a
    ConfigError naming the fault when the record is not one."""
    from dataclasses import fields

    params = dict(parameters)
    cls = _KINDS.get(str(params.pop("kind", "")))
    if cls is None:
        raise ConfigError(f"the sidecar's mapping options name no mapping class povh3d knows "
                          f"({parameters.get('kind')!r}); render the image again")
    known = {f.name for f in fields(cast(Any, cls))}   # a dataclass, as every mapping class
    if set(params) - known or params.get("name") != name:
        raise ConfigError(f"the sidecar's mapping options do not describe mapping {name!r} "
                          f"({', '.join(sorted(set(params) - known)) or 'another name'}); render the image again")
    try:
        return cls(**params)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"the sidecar's mapping options are damaged ({exc}); render the image again") from None
