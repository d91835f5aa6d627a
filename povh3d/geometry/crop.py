"""Which lenses of each view can see an object, and the crop that skips the rest.

Pure: a LensArray and a bounding box (or a measured hit mask) in, index masks
out.  The one-pass ``multi-ortho`` method tiles the views side by side
(``tiled[l*Ly + i, k*Lx + j] = view[l, k][i, j]``).  A crop keeps some whole
columns and rows of that tiled image (``CropPlan``); the mesh camera traces only
those, and pasting the result into a canvas of the background colour gives the
uncropped render.  Views are cropped by column and row ranges, not by their own
rectangles, so the kept pixels form one rectangular image with no gaps.

Why the pixels are identical, not just close:

- A kept pixel gets the same ray: both meshes are written in lens pitches,
  where every corner is exact in POV-Ray's single-precision vertices
  (``cameras.bank_front_clearance``), so the cropped quads lie exactly on the
  uncropped ones and the rays agree to double rounding (in mm, corners were
  rounded differently: 1-23 of 2-8 million pixels changed).
- A ray that meets no object shows the constant background (no fog, media,
  sky_sphere: ``features.background_is_constant``), so removed pixels are the
  fill colour.
- Removing columns makes pixels that were apart neighbours.  POV-Ray's adaptive
  antialiasing compares a pixel with its neighbours and supersamples within
  half a pixel, so every cut has ``margin`` (>= 2) lens columns on each side
  that no sample can see an object from: the pixels at a cut are background
  with background neighbours, in either render.  The margin is applied along
  the tiled image, across view borders, so where a view reaches the panel edge
  its neighbour in the tiled image (the next view's first lens) is kept too.
- POV-Ray 3.7 compares neighbours only within its render blocks (32 x 32
  pixels), so with antialiasing every removed run is a whole number of blocks
  and every kept pixel keeps its place in its block (``plan_crop(block=...)``).
- POV-Ray's antialiasing jitter (on unless ``-J``) depends on the pixel's place
  in the image: a jittered render cannot be cropped without changing pixels,
  and ``crop_render`` does not crop it (``layout_independent``).

The fill colour is taken from the render itself: the pixels at the cuts, which
must all be one colour (``fill_colour``); anything else means the bounding box
did not hold every object, and the crop is refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, param
from .lens_array import LensArray

#: Lens columns/rows of background kept around whatever a view can see.
DEFAULT_MARGIN = 2
#: POV-Ray 3.7's default render block size (``+BS``), pixels.
POVRAY_BLOCK = 32


def layout_independent(options: tuple[str, ...]) -> tuple[bool, int | None]:
    """Whether a render with these POV-Ray switches can be cropped without changing pixels.

    Returns
    -------
    ok : bool          False for antialiasing with jitter (POV-Ray's default)
    block : int|None   the block size removed runs must keep to, None without antialiasing
    """
    antialias, jitter, block = False, True, POVRAY_BLOCK
    for opt in options:
        o = opt.strip()
        if o[1:2].upper() == "A" and o[2:3].upper() not in ("M", "G"):
            antialias = o[0] == "+"
        elif o[1:2].upper() == "J":
            jitter = o[0] == "+"
        elif o[1:3].upper() == "BS" and o[3:].isdigit():
            block = int(o[3:])
    if not antialias:
        return True, None
    return (not jitter), block


@dataclass(frozen=True)
class CropPlan:
    """The columns and rows of the tiled image that are traced.

    Attributes
    ----------
    keep_cols : (Nx*Lx,) bool    tiled-image columns traced (column ``k*Lx + j``)
    keep_rows : (Ny*Ly,) bool    tiled-image rows traced (row ``l*Ly + i``)
    lenses : (int, int)          ``(Lx, Ly)`` of the array
    """

    keep_cols: np.ndarray
    keep_rows: np.ndarray
    lenses: tuple[int, int]

    def __post_init__(self) -> None:
        for name, n in (("keep_cols", self.lenses[0]), ("keep_rows", self.lenses[1])):
            keep = np.asarray(getattr(self, name), dtype=bool).reshape(-1)
            if len(keep) % n:
                raise ValueError(f"CropPlan.{name} has {len(keep)} entries, not a whole number of views of {n}")
            keep.setflags(write=False)
            object.__setattr__(self, name, keep)

    @property
    def size(self) -> tuple[int, int]:
        """``(width, height)`` of the cropped tiled image, pixels."""
        return int(self.keep_cols.sum()), int(self.keep_rows.sum())

    @property
    def full_size(self) -> tuple[int, int]:
        """``(width, height)`` of the uncropped tiled image, pixels."""
        return len(self.keep_cols), len(self.keep_rows)

    @property
    def is_full(self) -> bool:
        """True when nothing is cropped."""
        return bool(self.keep_cols.all() and self.keep_rows.all())

    @property
    def fraction(self) -> float:
        """Fraction of the tiled image's pixels that are traced."""
        return float(self.keep_cols.mean() * self.keep_rows.mean())

    def col_segments(self) -> np.ndarray:
        """(n, 4) int: ``(view k, first lens, stop lens, cropped-image column)`` of each kept run."""
        return _segments(self.keep_cols, self.lenses[0])

    def row_segments(self) -> np.ndarray:
        """(n, 4) int: ``(view l, first lens row, stop, cropped-image row)`` of each kept run."""
        return _segments(self.keep_rows, self.lenses[1])

    def as_record(self) -> dict:
        return {"traced_fraction": round(self.fraction, 6), "size_px": list(self.size),
                "full_size_px": list(self.full_size)}


def _runs(keep: np.ndarray) -> np.ndarray:
    """(n, 2) ``[start, stop)`` of the runs of True in a 1D bool array."""
    edges = np.diff(np.concatenate([[0], keep.astype(np.int8), [0]]))
    return np.stack([np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)], axis=1)


def _segments(keep: np.ndarray, per_view: int) -> np.ndarray:
    """Kept runs split at view borders: each segment is one quad of one view."""
    offset = np.concatenate([[0], np.cumsum(keep)])   # cropped-image index of each tiled index
    rows = []
    for a, b in _runs(keep):
        borders = list(range((a // per_view + 1) * per_view, b, per_view))
        for s0, s1 in zip([a, *borders], [*borders, b]):
            rows.append((s0 // per_view, s0 % per_view, s0 % per_view + (s1 - s0), offset[s0]))
    return np.array(rows, dtype=np.int64).reshape(-1, 4)


# -- what each view can see ----------------------------------------------------------

def bbox_hits(lens_array: LensArray, bbox: np.ndarray | tuple,
              angular: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Lens columns and rows of each view whose pixel footprint can meet ``bbox``.

    The ray of view ``(l, k)`` through lens ``(j, i)`` is ``c + z (u_k/f, v_l/f)``
    at depth ``z``.  It can meet the box only if ``cx`` lies in
    ``[xmin - max(z u/f), xmax - min(z u/f)]`` over ``z`` in ``[zmin, zmax]`` (the
    projection of the box along the view direction, whose x-extent depends on
    ``u_k`` only and y-extent on ``v_l`` only), widened by half a lens pitch for
    the antialiasing samples of a pixel, which span one lens pitch in a view.
    ``angular``: the pixel's whole footprint (``povh3d.footprint``), whose
    directions also span the pixel's angular width, ``u +- s/2``.

    Parameters
    ----------
    lens_array : LensArray      with whole pixels per lens
    bbox : (2, 3) float, mm     ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``; may be infinite
    angular : bool              widen for footprint samples across the pixel's angle

    Returns
    -------
    col_hits : (Nx, Lx) bool    lens column j may show an object in view column k
    row_hits : (Ny, Ly) bool    lens row i may show an object in view row l
    """
    box = check_bbox(bbox)
    lens_array.require_views()
    u, v = lens_array.view_offsets()
    centres = lens_array.lens_centres()
    cx, cy = centres[0, :, 0], centres[:, 0, 1]
    z = box[:, 2]
    f = lens_array.focal
    wx, wy = (lens_array.panel.pitch_x / 2, lens_array.panel.pitch_y / 2) if angular else (0.0, 0.0)
    col = _reach(cx, (u - wx) / f, (u + wx) / f, box[:, 0], z, lens_array.pitch_x / 2)
    row = _reach(cy, (v - wy) / f, (v + wy) / f, box[:, 1], z, lens_array.pitch_y / 2)
    return col, row


def _reach(c: np.ndarray, slope_lo: np.ndarray, slope_hi: np.ndarray, extent: np.ndarray, z: np.ndarray,
           half: float) -> np.ndarray:
    """(views, lenses) bool: ``c`` within ``extent - z*slope`` (z over the box, slope over
    ``[slope_lo, slope_hi]``) +- ``half``."""
    slopes = np.stack([slope_lo, slope_hi], axis=1)[:, :, None]             # (views, 2, 1)
    # z * slope with an infinite z and a zero slope is 0, not NaN: that view never drifts.
    shift = np.where(slopes == 0, 0.0, z[None, None, :] * slopes).reshape(len(slopes), -1)
    lo = extent[0] - shift.max(axis=1) - half
    hi = extent[1] - shift.min(axis=1) + half
    return (c[None, :] >= lo[:, None]) & (c[None, :] <= hi[:, None])


def check_bbox(bbox: np.ndarray | tuple | list[float]) -> np.ndarray:
    """``bbox`` as a (2, 3) float array, or a ConfigError naming what is wrong."""
    try:
        box = np.asarray(bbox, dtype=np.float64).reshape(2, 3)
    except (TypeError, ValueError):
        raise ConfigError(f"{param('bbox')} takes 6 numbers xmin,ymin,zmin,xmax,ymax,zmax in mm, got {bbox!r}") from None
    if np.isnan(box).any() or np.any(box[0] > box[1]):
        raise ConfigError(f"{param('bbox')} needs xmin <= xmax, ymin <= ymax, zmin <= zmax (mm), got {box.reshape(-1).tolist()}")
    if np.isposinf(box[0]).any() or np.isneginf(box[1]).any():   # a box at infinity holds nothing
        raise ConfigError(f"{param('bbox')} holds nothing: a min of inf or a max of -inf, got {box.reshape(-1).tolist()}; "
                          "give -inf for a min and inf for a max that is unbounded")
    return box


def mask_hits(mask: np.ndarray, views: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Lens columns and rows of each view where a tiled hit mask is set.

    Parameters
    ----------
    mask : (Ny*Ly, Nx*Lx) bool   the tiled image, True where a ray met an object
    views : (Ny, Nx)

    Returns
    -------
    col_hits : (Nx, Lx) bool, row_hits : (Ny, Ly) bool
        Unions over the other view axis, so the crop stays a grid of tiles.
    """
    ny, nx = views
    h, w = mask.shape
    if h % ny or w % nx:
        raise ValueError(f"mask of shape {mask.shape} does not tile into {ny}x{nx} views")
    m = np.asarray(mask, dtype=bool).reshape(ny, h // ny, nx, w // nx)
    return np.asarray(m.any(axis=(0, 1))), np.asarray(m.any(axis=(2, 3)))


# -- the plan -------------------------------------------------------------------------

def plan_crop(col_hits: np.ndarray, row_hits: np.ndarray, margin: int = DEFAULT_MARGIN,
              block: int | None = None) -> CropPlan:
    """The crop that traces every hit lens plus ``margin`` lenses of background around it.

    Parameters
    ----------
    col_hits : (Nx, Lx) bool, row_hits : (Ny, Ly) bool
        From ``bbox_hits`` or ``mask_hits``.
    margin : int
        Background lenses kept beside the hits; at least 2 (see the module note).
    block : int or None
        POV-Ray's render block size when antialiasing: its adaptive test compares
        a pixel only with neighbours in the same block, so every removed run is
        shortened to a whole number of blocks and every kept pixel keeps its place
        in its block.  None when each pixel is one ray (``-A``).
    """
    if margin < 2:
        raise ValueError(f"margin must be at least 2 lenses, got {margin}")
    col_hits, row_hits = np.asarray(col_hits, bool), np.asarray(row_hits, bool)
    lenses = (col_hits.shape[1], row_hits.shape[1])
    cols, rows = col_hits.reshape(-1), row_hits.reshape(-1)
    if not (cols.any() and rows.any()):
        # Nothing to see anywhere: trace one corner (3 x 3 lenses) of background, for its colour.
        cols, rows = np.zeros_like(cols), np.zeros_like(rows)
        cols[0] = rows[0] = True
    # Dilating the tiled columns (not each view's) keeps a view's neighbour in the
    # tiled image wherever the view reaches the panel edge.
    return CropPlan(_keep(cols, margin, block), _keep(rows, margin, block), lenses)


def _keep(hits: np.ndarray, margin: int, block: int | None) -> np.ndarray:
    """Hits widened by ``margin`` each side; removed runs cut to whole ``block``s."""
    n = len(hits)
    count = np.concatenate([[0], np.cumsum(hits)])            # hits before each index
    index = np.arange(n)
    keep = count[np.minimum(index + margin + 1, n)] > count[np.maximum(index - margin, 0)]
    if block:
        for a, b in _runs(~keep):
            keep[a:b - (b - a) // block * block] = True  # give back the left end of the run
    return keep


# -- back to the full tiled image --------------------------------------------------------

def cut_mask(plan: CropPlan) -> tuple[np.ndarray, np.ndarray]:
    """Columns and rows of the cropped image that sit beside a cut.

    Returns
    -------
    cols : (W',) bool, rows : (H',) bool
        True where the kept column/row has a removed one as its neighbour in the
        uncropped image: these are margin pixels, background by construction.
    """
    return _beside_cut(plan.keep_cols), _beside_cut(plan.keep_rows)


def _beside_cut(keep: np.ndarray) -> np.ndarray:
    removed = ~keep
    left = np.concatenate([[False], removed[:-1]])
    right = np.concatenate([removed[1:], [False]])
    return (left | right)[keep]


def fill_colour(cropped: np.ndarray, plan: CropPlan) -> np.ndarray | None:
    """The background colour read at the cuts, or None when they disagree.

    Parameters
    ----------
    cropped : (H', W', C) array   the cropped tiled render (extra row/column removed)

    Returns
    -------
    (C,) array of the image dtype, or None: no cut (nothing to fill) also gives None.
    """
    cols, rows = cut_mask(plan)
    pixels = np.concatenate([cropped[:, cols].reshape(-1, cropped.shape[-1]),
                             cropped[rows, :].reshape(-1, cropped.shape[-1])])
    if len(pixels) == 0:
        return None
    colour = pixels[0]
    return colour if np.all(pixels == colour) else None


def paste(cropped: np.ndarray, plan: CropPlan, fill: np.ndarray) -> np.ndarray:
    """The uncropped tiled image: ``fill`` everywhere, ``cropped`` at the kept rows and columns.

    Parameters
    ----------
    cropped : (H', W', C) array
    fill : (C,) array

    Returns
    -------
    (Ny*Ly, Nx*Lx, C) array of ``cropped``'s dtype
    """
    w, h = plan.size
    if cropped.shape[:2] != (h, w):
        raise ValueError(f"cropped image is {cropped.shape[:2]}, the plan keeps {(h, w)}")
    fw, fh = plan.full_size
    canvas = np.empty((fh, fw) + cropped.shape[2:], cropped.dtype)
    canvas[...] = fill
    canvas[np.ix_(plan.keep_rows, plan.keep_cols)] = cropped
    return canvas


# -- what the user asked for ----------------------------------------------------------------

CROP_MODES = ("auto", "off", "measure")


@dataclass(frozen=True)
class CropSettings:
    """Whether and how to crop the one-pass view bank.

    Attributes
    ----------
    mode : {'auto', 'off', 'measure'}
        ``auto`` crops to ``bbox`` when one is given; ``measure`` finds what each
        view can see with a coverage pre-pass at the same rays (exact, but it
        costs about as much as tracing a simple scene, so it pays only for
        expensive scenes); ``off`` traces everything.  Either way only where the
        background is one colour and the render does not jitter.
    bbox : (2, 3) float or None, mm   every object lies inside (the user's word)
    margin : int                      background lenses kept beside what a view sees
    """

    mode: str = "auto"
    bbox: tuple[tuple[float, float, float], tuple[float, float, float]] | None = None
    margin: int = DEFAULT_MARGIN

    def __post_init__(self) -> None:
        if self.mode not in CROP_MODES:
            raise ConfigError(f"{param('crop')} must be one of {', '.join(CROP_MODES)}, got {self.mode!r}")
        if self.bbox is not None:
            box = check_bbox(self.bbox)
            object.__setattr__(self, "bbox", tuple(tuple(float(x) for x in row) for row in box))
        if isinstance(self.margin, bool) or not isinstance(self.margin, int) or self.margin < 2:
            raise ConfigError(f"the crop margin must be a whole number of lenses >= 2, got {self.margin!r}")


def parse_bbox(text: str) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """``'xmin,ymin,zmin,xmax,ymax,zmax'`` (mm; ``inf`` allowed) -> ((xmin, ymin, zmin), (xmax, ymax, zmax))."""
    parts = [p for p in text.replace(" ", ",").split(",") if p]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != 6:
        raise ConfigError(f"{param('bbox')} takes 6 numbers xmin,ymin,zmin,xmax,ymax,zmax in mm, got {text!r}")
    box = check_bbox(values)
    (x0, y0, z0), (x1, y1, z1) = box.tolist()
    return (x0, y0, z0), (x1, y1, z1)
