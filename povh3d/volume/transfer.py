"""Transfer functions: what colour and how much fog each scalar value of a volume is.

A transfer function is a list of control points ``(value, r, g, b, extinction)``:
``(r, g, b)`` is the colour a thick slab of that value shows, ``extinction``
``sigma`` how much light it stops per mm of the volume (its own mm, before it is
scaled onto the display).  Between control points both the **emission**
``e = sigma * (r, g, b)`` and the extinction are linear in the value; beyond the
first and last points they stay constant.  A ray through the volume then shows

    C = integral e(s) T(s) ds + B T(L),     T(s) = exp(-integral_0^s sigma),

(``B`` the background behind the volume): the emission-absorption model of
direct volume rendering.  A slab of constant value thick enough to be opaque
shows exactly ``(r, g, b)``.

Values are **absolute** (CT: Hounsfield units), **relative** (0 and 1 are the
volume's minimum and its 99.5th percentile: MRI has no absolute scale), or
**labels** (a segmentation: each control point's value is a label, drawn as a
solid block of its colour; labels not listed are clear).  The text format is
in docs/volume-rendering.md.  Pure NumPy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError, InputError, param
from ..image.colour import srgb_to_linear

KINDS = ("absolute", "relative", "labels")
#: The largest label a labels transfer draws: POV-Ray's colour maps hold 256 entries.
MAX_LABEL_ENTRIES = 256
RELATIVE_PERCENTILE = 99.5


@dataclass(frozen=True, eq=False)
class Transfer:
    """A piecewise-linear transfer function.

    Attributes
    ----------
    name : str
    kind : {'absolute', 'relative', 'labels'}
    values : (n,) float             control values, increasing (labels: distinct integers)
    colour : (n, 3) float           colour of an opaque slab, linear RGB, >= 0
    extinction : (n,) float, 1/mm   of the volume's own mm, >= 0
    """

    name: str
    kind: str
    values: np.ndarray
    colour: np.ndarray
    extinction: np.ndarray

    def __post_init__(self) -> None:
        v = np.asarray(self.values, dtype=np.float64)
        if self.kind not in KINDS:
            raise ConfigError(f"transfer {self.name}: kind must be one of {', '.join(KINDS)}, got {self.kind!r}")
        if v.ndim != 1 or len(v) < 1 or (self.kind != "labels" and len(v) < 2):
            raise ConfigError(f"transfer {self.name}: needs at least two control points (one for labels)")
        if np.any(np.diff(v) <= 0):
            raise ConfigError(f"transfer {self.name}: control values must increase")
        if self.kind == "labels" and np.any(v != np.rint(v)):
            raise ConfigError(f"transfer {self.name}: labels are whole numbers")

    @property
    def emission(self) -> np.ndarray:
        """(n, 3) emission per mm at the control points: extinction times colour."""
        return np.asarray(self.colour, dtype=np.float64) * np.asarray(self.extinction, dtype=np.float64)[:, None]

    def window(self, values: np.ndarray) -> tuple[float, float]:
        """Data values ``(lo, hi)`` that relative control values 0 and 1 stand for."""
        flat = np.asarray(values).ravel(order="K")
        sample = flat[::max(1, flat.size // 1_000_000)]  # a percentile of a million voxels is plenty
        lo, hi = float(np.nanmin(flat)), float(np.nanpercentile(sample, RELATIVE_PERCENTILE))
        return (lo, hi) if hi > lo else (lo, lo + 1.0)

    def data_values(self, volume_values: np.ndarray) -> np.ndarray:
        """The control values in the volume's own units."""
        v = np.asarray(self.values, dtype=np.float64)
        if self.kind != "relative":
            return v
        lo, hi = self.window(volume_values)
        return lo + v * (hi - lo)

    def as_record(self) -> dict:
        return {"name": self.name, "kind": self.kind, "points": [
            [float(v), *map(float, c), float(s)] for v, c, s in zip(self.values, self.colour, self.extinction)]}


def _preset(name: str, kind: str, rows: Sequence[Sequence[float]]) -> Transfer:
    a = np.array(rows, dtype=np.float64)
    return Transfer(name, kind, a[:, 0], a[:, 1:4], a[:, 4])


# Extinctions in 1/mm of the patient: ~0.01 lets a 10 cm organ glow through, ~0.5 is opaque at 2 mm.
PRESETS: dict[str, Transfer] = {
    # Bone only: the skeleton, ivory, opaque from about 300 HU.
    "ct-bone": _preset("ct-bone", "absolute", [
        (150, 0.0, 0.0, 0.0, 0.0), (300, 0.9, 0.8, 0.65, 0.15), (700, 1.0, 0.95, 0.85, 0.6),
        (2000, 1.0, 1.0, 1.0, 1.0)]),
    # Soft tissue faint and warm, fat yellow and fainter, bone bright and nearly opaque; air clear.
    "ct-soft": _preset("ct-soft", "absolute", [
        (-600, 0.0, 0.0, 0.0, 0.0), (-100, 0.9, 0.8, 0.4, 0.004), (20, 0.8, 0.3, 0.25, 0.006),
        (80, 0.95, 0.45, 0.35, 0.02), (200, 0.95, 0.9, 0.8, 0.1), (1000, 1.0, 1.0, 0.95, 0.5),
        (3000, 1.0, 1.0, 1.0, 0.5)]),
    # MRI: grey, noise floor clear, bright tissue denser.
    "mri": _preset("mri", "relative", [
        (0.0, 0.0, 0.0, 0.0, 0.0), (0.1, 0.0, 0.0, 0.0, 0.0), (0.3, 0.6, 0.6, 0.65, 0.01),
        (0.7, 0.9, 0.9, 0.9, 0.04), (1.0, 1.0, 1.0, 1.0, 0.08)]),
}
#: Named transfers that depend on the volume: ``labels`` colours every label present.
BUILT_FOR_VOLUME = ("labels",)
AUTO = "auto"
NAMES = (*PRESETS, *BUILT_FOR_VOLUME, AUTO)
#: A non-negative integer volume with at most this many distinct values is taken as a segmentation.
MAX_AUTO_LABELS = 64
#: A minimum at or below this is air in Hounsfield units: a CT.
CT_AIR = -500.0

# Twelve well-separated colours (Paul Tol's "muted" and "bright" schemes), sRGB; used decoded to linear.
_PALETTE_SRGB = np.array([
    [204, 102, 119], [51, 34, 136], [221, 204, 119], [17, 119, 51], [136, 204, 238], [136, 34, 85],
    [68, 170, 153], [153, 153, 51], [170, 68, 153], [238, 102, 119], [34, 136, 51], [204, 187, 68],
]) / 255.0


def label_transfer(labels: list[int], *, extinction: float = 0.05) -> Transfer:
    """A colour per label (a fixed palette, cycled), every label equally dense, 0 clear."""
    labels = sorted(int(v) for v in labels if v != 0)
    if not labels:
        raise ConfigError("the volume has no labels other than 0 (the background): nothing to draw")
    if len(labels) >= MAX_LABEL_ENTRIES:
        raise ConfigError(f"the volume has {len(labels)} labels; direct volume rendering draws at most "
                          f"{MAX_LABEL_ENTRIES - 1}: render surfaces with {param('labels')} instead")
    colour = srgb_to_linear(_PALETTE_SRGB[np.arange(len(labels)) % len(_PALETTE_SRGB)])
    return Transfer("labels", "labels", np.array(labels, dtype=np.float64), colour,
                    np.full(len(labels), float(extinction)))


def auto_transfer(values: np.ndarray, has_label_table: bool = False) -> str:
    """The preset that suits ``values``: ``labels`` for a segmentation (a label table, or few
    non-negative integers), ``ct-soft`` for Hounsfield units (air below -500), else ``mri``."""
    values = np.asarray(values)
    if np.issubdtype(values.dtype, np.integer):
        lo, hi = int(values.min()), int(values.max())
        if has_label_table or (lo >= 0 and hi < 1 << 20
                               and np.count_nonzero(np.bincount(values.ravel(order="K"))) <= MAX_AUTO_LABELS):
            return "labels"
    return "ct-soft" if float(np.nanmin(values)) <= CT_AIR else "mri"


def parse_transfer(text: str, name: str) -> Transfer:
    """A transfer function from its text (docs/volume-rendering.md); errors name the line."""
    kind, rows = "absolute", list[list[float]]()
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        where = f"{name} line {number}"
        words = line.split()
        if words[0] == "kind":
            if len(words) != 2 or words[1] not in KINDS:
                raise InputError(f"{where}: write 'kind absolute', 'kind relative' or 'kind labels'")
            if rows:
                raise InputError(f"{where}: 'kind' must come before the control points")
            kind = words[1]
            continue
        if len(words) != 5:
            raise InputError(f"{where}: expected 5 numbers (value red green blue extinction), got {len(words)} items")
        try:
            numbers = [float(w) for w in words]
        except ValueError:
            bad = next(w for w in words if not _is_number(w))
            raise InputError(f"{where}: {bad!r} is not a number") from None
        if not all(np.isfinite(numbers)):
            raise InputError(f"{where}: numbers must be finite")
        if min(numbers[1:]) < 0:
            raise InputError(f"{where}: colour and extinction must not be negative")
        if rows and numbers[0] <= rows[-1][0]:
            raise InputError(f"{where}: value {words[0]} does not increase on the line before "
                             f"({rows[-1][0]:g}); list control points in increasing order")
        if kind == "labels" and numbers[0] != round(numbers[0]):
            raise InputError(f"{where}: a label is a whole number, got {words[0]}")
        rows.append(numbers)
    least = 1 if kind == "labels" else 2
    if len(rows) < least:
        raise InputError(f"{name}: needs at least {least} control point{'s' if least > 1 else ''} "
                         "(value red green blue extinction)")
    if kind == "labels" and len(rows) >= MAX_LABEL_ENTRIES:
        raise InputError(f"{name}: at most {MAX_LABEL_ENTRIES - 1} labels, got {len(rows)}")
    return _preset(name, kind, rows)


def _is_number(word: str) -> bool:
    try:
        float(word)
    except ValueError:
        return False
    return True


def load_transfer(spec: str | Path, labels: list[int] | None = None) -> Transfer:
    """A preset by name (``labels`` needs the volume's ``labels``) or a transfer file."""
    spec_text = str(spec)
    if spec_text in PRESETS:
        return PRESETS[spec_text]
    if spec_text == AUTO:
        raise ConfigError("the 'auto' transfer is chosen from the volume (auto_transfer)")
    if spec_text == "labels":
        if labels is None:
            raise ConfigError("the 'labels' transfer needs a label volume")
        return label_transfer(labels)
    path = Path(spec_text)
    if not path.is_file():
        raise InputError(f"transfer {spec_text!r} is neither a preset ({', '.join(NAMES)}) nor a file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the transfer file {spec_text!r}: {exc}") from None
    return parse_transfer(text, path.name)
