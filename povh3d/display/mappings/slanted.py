"""Slanted-lenticular mappings: van Berkel's subpixel formula and its special cases.

A subpixel in column ``k = 3x + c`` (c = 0, 1, 2 for R, G, B) and row ``l`` (from
the top) sits at phase ``k + k_off - slope * l`` across the lens sheet, where
``slope = 3 tan a`` is how many subpixels the lens edge moves right per row and
``X`` subpixels span one lens horizontally.  Its lens (counted along the slant)
is ``floor(phase / X)`` and its view

    view = floor(((k + k_off - 3 l tan a) mod X) * N / X)

``alioscopy`` (X = N = 8, tan a = 1/3, thesis Eq. 4.3) and ``philips``
(X = 4.5, N = 9, tan a = 1/6, Fig. 4.26) are instances.  ``smart:N`` (Fig. 5.17)
is the same lattice with whole pixels instead of subpixels: one pixel per N
rows of slant, N x PPL views.

Which view *pixel* a subpixel shows (view row and lens column):
- the three subpixels of one view pixel lie on one line of constant phase
  (Eq. 4.3: ``R^{r,c} + G^{r+1,c+1} + B^{r+2,c+2}``), so a subpixel's view row is
  that of the pixel's red subpixel, ``floor((l - c * rows_per_view/3) / rows_per_view)``,
  when ``rows_per_view = 3 / slope`` (alioscopy 3, philips 6); otherwise its own row;
- its lens column is the slanted lens's index plus the whole-lens shift of the
  slant at the middle of that view row (the thesis's "de-slanting" of the views),
  so view column ``j`` is the lens whose centre is nearest on the panel.
With these rules both thesis mappings are permutations of the view subpixels,
up to partial lenses at the left and right edges and the top and bottom rows
(those repeat the nearest view pixel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np

from ...errors import ConfigError, param
from .base import EPS, Mapping, centred_margin
from .sampling import Sampling, Source, flat_index

UNITS = ("subpixel", "pixel")


def _denominator(*values: float) -> int | None:
    """A small D making every value times D whole (exact integer phases), else None."""
    d = 1
    for v in values:
        f = Fraction(v).limit_denominator(1000)
        if abs(float(f) - v) > 1e-12:
            return None
        d = d * f.denominator // math.gcd(d, f.denominator)
    return d if d <= 100_000 else None


@dataclass(frozen=True)
class Slanted(Mapping):
    """General slanted-lenticular mapping.

    Parameters
    ----------
    name : str
    per_lens : float        X, units (subpixels or pixels) under one lens horizontally
    views : int             N
    slope : float           3 tan a: units the lens moves right per row down (negative: left)
    offset : float          k_off, units
    rows_per_view : int     panel rows per view-image row
    reverse : bool          view N-1-v instead of v (Looking Glass ``invView``)
    blend : bool            mix the two nearest fractional views (linear light)
    unit : {'subpixel', 'pixel'}
    """

    name: str = "slanted"
    per_lens: float = 8.0
    views: int = 8
    slope: float = 1.0
    offset: float = 0.0
    rows_per_view: int = 1
    reverse: bool = False
    blend: bool = False
    unit: str = "subpixel"

    def __post_init__(self) -> None:
        if not (isinstance(self.per_lens, (int, float)) and math.isfinite(self.per_lens) and self.per_lens > 0):
            raise ConfigError(f"subpixels per lens X must be a positive number, got {self.per_lens!r}")
        if isinstance(self.views, bool) or not isinstance(self.views, int) or self.views < 1:
            raise ConfigError(f"the view count N must be a whole number of at least 1, got {self.views!r}")
        if not math.isfinite(self.slope) or not math.isfinite(self.offset):
            raise ConfigError("the slant and offset must be finite numbers")
        if isinstance(self.rows_per_view, bool) or not isinstance(self.rows_per_view, int) or self.rows_per_view < 1:
            raise ConfigError(f"rows per view row must be a whole number of at least 1, got {self.rows_per_view!r}")
        if self.unit not in UNITS:
            raise ConfigError(f"unit must be one of {UNITS}, got {self.unit!r}")

    # -- geometry ---------------------------------------------------------------------------
    def _units(self, width: int) -> int:
        return 3 * width if self.unit == "subpixel" else width

    def _lenses(self, width: int) -> tuple[int, int]:
        """Lens count and first unit of the lens region (pixel lattices are centred, black margins)."""
        units = self._units(width)
        if self.unit == "pixel" and float(self.per_lens).is_integer():
            return centred_margin(units, int(self.per_lens))
        count = math.floor(units / self.per_lens + EPS)
        if count < 1:
            raise ConfigError(f"a lens of {self.per_lens:g} {self.unit}s does not fit a panel {width} pixels wide")
        return count, 0

    def source(self, panel: tuple[int, int]) -> Source:
        w, h = panel
        if h < self.rows_per_view:
            raise ConfigError(f"mapping {self.name!r} needs at least {self.rows_per_view} panel rows, got {h}")
        return Source(max(1, h // self.rows_per_view), self._lenses(w)[0], self.views)

    def view_pitch(self, pitch: tuple[float, float]) -> tuple[float, float, float]:
        unit_mm = pitch[0] / 3 if self.unit == "subpixel" else pitch[0]
        lens = self.per_lens * unit_mm
        return lens, lens / self.views, self.rows_per_view * pitch[1]

    def resolution_3d(self, panel: tuple[int, int]) -> tuple[int, int]:
        w, h = panel
        if self.unit == "subpixel":
            # Eq. 4.1 / 4.4: subpixels per row over views, rows over 3 (one view
            # pixel spreads over 3 rows' worth of subpixels).
            return (math.floor(3 * w / self.views + EPS), h // 3)
        # Table 5.9: lenses (the panel width over PPL, unrounded) times N, rows over N.
        n = self.views / self.per_lens
        return (math.floor(w / self.per_lens * n + EPS), h // self.rows_per_view)

    # -- the index map ------------------------------------------------------------------------
    def phases(self, panel: tuple[int, int], rows: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Slanted lens index, view and fractional view of every unit (of panel ``rows``, default all).

        Returns
        -------
        lens : (H, U) int64      lens counted along the slant (lens 0 starts at unit ``origin``)
        view : (H, U) int64      0 .. N-1 (before ``reverse``)
        frac : (H, U) float64    ``(phase mod X) * N / X``, the fractional view
        """
        w, h = panel
        _, origin = self._lenses(w)
        u = np.arange(self._units(w), dtype=np.int64)[None, :] - origin
        l = (np.arange(h, dtype=np.int64) if rows is None else np.asarray(rows, np.int64))[:, None]
        d = _denominator(self.per_lens, self.slope, self.offset)
        n = self.views
        if d is not None:  # exact integer phases: no subpixel falls into the wrong view
            per = round(self.per_lens * d)
            p = u * d + round(self.offset * d) - round(self.slope * d) * l
            lens = p // per
            rem = p - lens * per
            return lens, (rem * n) // per, rem * n / per
        p = u + self.offset - self.slope * l
        lens = np.floor(p / self.per_lens + EPS).astype(np.int64)
        frac = np.clip((p - lens * self.per_lens) * n / self.per_lens, 0, n - EPS)
        return lens, np.minimum(np.floor(frac + EPS).astype(np.int64), n - 1), frac

    # Rows per block of the index map: a block's int64 temporaries stay in cache (4K: 24 x 11520 x 8 B
    # = 2 MB), where whole-panel temporaries of 200 MB made building alioscopy's map take seconds.
    BLOCK_ROWS = 24

    def _sample(self, panel: tuple[int, int]) -> Sampling:
        w, h = panel
        parts = [self._sample_rows(panel, np.arange(r, min(h, r + self.BLOCK_ROWS)))
                 for r in range(0, h, self.BLOCK_ROWS)]
        index = np.concatenate([p.index for p in parts])
        black = None if parts[0].black is None else np.concatenate([p.black for p in parts])
        if not self.blend:
            return Sampling(index, black)
        return Sampling(index, black, np.concatenate([p.index2 for p in parts]),
                        np.concatenate([p.weight for p in parts]))

    def _sample_rows(self, panel: tuple[int, int], rows: np.ndarray) -> Sampling:
        """The index map of panel ``rows`` only (``_sample`` stacks blocks of them)."""
        w, _ = panel
        h = rows.size
        src = self.source(panel)
        count, origin = self._lenses(w)
        lens, view, frac = self.phases(panel, rows)
        b = self.rows_per_view
        l = rows.astype(np.int64)[:, None]
        units = self._units(w)
        if self.unit == "subpixel":
            c = (np.arange(units, dtype=np.int64) % 3)[None, :]
            grouped = b % 3 == 0 and abs(self.slope * (b // 3) - 1) < 1e-9
            anchor = l - c * (b // 3) if grouped else l + 0 * c
        else:
            anchor = l + 0 * lens[:1]
        i = np.clip(anchor // b, 0, src.rows - 1)
        # The slant moves the lens right by slope*l units: the view column is the
        # lens whose centre is nearest, taken at the middle row of the view row.
        mid = i * b + (b - 1) / 2
        shift = np.floor((self.slope * mid - self.offset) / self.per_lens + 0.5).astype(np.int64)
        j = np.clip(lens + shift, 0, count - 1)

        def to_index(v: np.ndarray) -> np.ndarray:
            v = (self.views - 1 - v) if self.reverse else v
            if self.unit == "subpixel":
                return flat_index(src, i, j, v, c).reshape(h, w, 3)
            pix = flat_index(src, i, j, v, np.zeros_like(v))
            return pix[..., None] + np.arange(3)

        black = None
        if self.unit == "pixel":
            u = np.arange(units)[None, :] - origin
            outside = (u < 0) | (u >= count * self.per_lens)
            if outside.any():
                black = np.broadcast_to(outside[..., None], (h, w, 3)).copy()
        if not self.blend:
            return Sampling(to_index(np.broadcast_to(view, j.shape)), black)
        f = np.broadcast_to(frac, j.shape) - 0.5  # view centres sit at half-integers
        v0 = np.floor(f).astype(np.int64)
        weight = (f - v0).astype(np.float32)
        i0 = to_index(np.clip(v0, 0, self.views - 1))
        i1 = to_index(np.clip(v0 + 1, 0, self.views - 1))
        wmap = weight.reshape(h, w, 3) if self.unit == "subpixel" else np.repeat(weight[..., None], 3, axis=2)
        return Sampling(i0, black, i1, wmap)


def looking_glass(calibration: dict[str, Any], views: int, *, blend: bool = False) -> Slanted:
    """The slanted mapping of a Looking Glass calibration (``visual.json`` fields).

    Fields: ``pitch`` (lenticules per inch), ``slope``, ``center``, ``invView``,
    ``DPI``, ``screenW``, ``screenH`` (numbers, or ``{"value": number}``).  Their
    shader computes, for subpixel ``c`` of the pixel at ``uv`` (y up),
    ``a = (uv.x + c/(3 W) + uv.y * tilt) * pitch' - center`` with
    ``pitch' = pitch * W / DPI * cos(atan(1/slope))`` lenticules across the
    screen and ``tilt = H / (W * slope)``; the view is ``fract(a)`` (``1 - fract(a)``
    with ``invView``).  In van Berkel's terms that is ``X = 3 W / pitch'``,
    ``3 tan a = 3 / slope`` and ``k_off = 1.5 + 3 (H - 0.5) / slope - center * X``.
    """
    def get(key: str) -> float:
        if key not in calibration:
            raise ConfigError(f"the Looking Glass calibration lacks {key!r}; it needs pitch, slope, center, "
                              "invView, DPI, screenW and screenH")
        value = calibration[key]
        value = value.get("value") if isinstance(value, dict) else value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"calibration field {key!r} must be a number, got {value!r}")
        return float(value)

    inv = calibration.get("invView", 0)
    inv = inv.get("value") if isinstance(inv, dict) else inv
    pitch, slope, center, dpi = get("pitch"), get("slope"), get("center"), get("DPI")
    width, height = get("screenW"), get("screenH")
    if pitch <= 0 or dpi <= 0 or slope == 0 or width < 1 or height < 1:
        raise ConfigError("calibration pitch, DPI, screenW and screenH must be positive and slope non-zero")
    _check_sheet_fields(calibration, pitch, slope, dpi, width, height)
    lenses_across = pitch * width / dpi * math.cos(math.atan(1.0 / slope))
    per_lens = 3 * width / lenses_across
    offset = 1.5 + 3 * (height - 0.5) / slope - center * per_lens
    return Slanted("slanted", per_lens, int(views), 3.0 / slope, offset % per_lens, 1,
                   bool(inv), blend)


def _check_sheet_fields(calibration: dict[str, Any], pitch: float, slope: float, dpi: float,
                        width: float, height: float) -> None:
    """A ``povh3d calibrate --lattice lenticular`` file also holds the sheet in pixels; they must agree."""
    checks = []
    if "pitch_px" in calibration:
        checks.append(("pitch_px", calibration["pitch_px"], dpi / pitch, "DPI / pitch"))
    if "slant_deg" in calibration:
        checks.append(("slant_deg", calibration["slant_deg"], math.degrees(math.atan(1.0 / slope)), "atan(1 / slope)"))
    if "image_size" in calibration:
        size = calibration["image_size"]
        if not (isinstance(size, list) and len(size) == 2 and size == [width, height]):
            raise ConfigError(f"the calibration contradicts itself: image_size {size!r} but screenW x screenH "
                              f"{width:g} x {height:g}; calibrate again")
    for key, value, derived, how in checks:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"calibration field {key!r} must be a number, got {value!r}")
        if not math.isclose(value, derived, rel_tol=1e-6, abs_tol=1e-9):
            raise ConfigError(f"the calibration contradicts itself: {key} is {value!r} but {how} gives "
                              f"{derived!r}; calibrate again")
    if "phase_px" in calibration:  # and the centre (an older calibrate put it half a pixel left)
        phase = calibration["phase_px"]
        if isinstance(phase, bool) or not isinstance(phase, (int, float)) or not math.isfinite(phase):
            raise ConfigError(f"calibration field 'phase_px' must be a number, got {phase!r}")
        centre = calibration["center"]
        centre = centre["value"] if isinstance(centre, dict) else centre  # a number: get("center") checked it
        t = math.atan(1.0 / slope)
        derived = (phase + math.cos(t) * (width + 1) / 2 + math.sin(t) * height / 2) * pitch / dpi - 0.5
        if abs((derived - centre + 0.5) % 1.0 - 0.5) > 1e-6:
            raise ConfigError(f"the calibration contradicts itself: center is {centre!r} but phase_px gives "
                              f"{derived % 1.0!r}; calibrate again")


def from_calibration(calibration: dict[str, Any], views: int, *, blend: bool = False) -> Slanted:
    """The slanted mapping of a calibration file: Looking Glass fields (``looking_glass``), or a
    ``povh3d calibrate --lattice lenticular`` file without them (its sheet in image pixels).

    The pixel file's sheet (``calibration.lenticular``: ``pitch_px`` across the lenticules,
    ``slant_deg`` counter-clockwise, ``phase_px`` from the image centre to the nearest axis) is
    turned into the Looking Glass fields it would carry with ``--dpi`` (any DPI: it cancels), so
    that both files of one sheet give one mapping.
    """
    if not isinstance(calibration, dict):
        raise ConfigError("a calibration is a JSON object (Looking Glass visual.json or 'povh3d calibrate' output)")
    kind = calibration.get("kind")
    if kind == "povh3d-lens-grid":
        raise ConfigError(f"the calibration is a {calibration.get('lattice', 'lens')} lens grid, not a lenticular "
                          f"sheet; calibrate the sheet with 'povh3d calibrate {param('lattice')} lenticular'")
    if "pitch" in calibration or kind != "lenticular":
        return looking_glass(calibration, views, blend=blend)
    pitch, slant, phase = (_number(calibration, key) for key in ("pitch_px", "slant_deg", "phase_px"))
    size = calibration.get("image_size")
    if not (isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) and v >= 1 for v in size)):
        raise ConfigError(f"the calibration's image_size must be [W, H] pixels, got {size!r}; calibrate again")
    if pitch <= 0 or not -45 < slant < 45 or slant == 0:
        raise ConfigError(f"the calibration's sheet (pitch {pitch:g} px, slant {slant:g} deg) is no slanted "
                          "lenticular sheet: the pitch must be positive and the slant within (-45, 45), not 0")
    w, h = size
    t = math.radians(slant)
    centre = (phase + math.cos(t) * (w + 1) / 2 + math.sin(t) * h / 2) / pitch - 0.5  # LenticularFit.looking_glass
    fields = {"pitch": 25.4 / pitch, "slope": 1.0 / math.tan(t), "center": centre % 1.0, "invView": 0,
              "DPI": 25.4, "screenW": w, "screenH": h}
    return looking_glass(fields, views, blend=blend)


def _number(calibration: dict[str, Any], key: str) -> float:
    value = calibration.get(key)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"the lenticular calibration needs a number {key!r}, got {value!r}; calibrate again")
    return float(value)
