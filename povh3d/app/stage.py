"""The default stage for ``povh3d render MODEL``: the model placed where the display shows it sharply.

Depth budget (the depth range the lens array shows sharply).  The thesis gives
no depth-of-field formula, so this is the standard one for integral imaging
with the panel a focal length behind the lenses (the conventions' set-up, the
"depth-priority" mode): a pixel of pitch ``s`` under a lens of pitch ``p`` and
focal length ``f`` sends a beam ``p`` wide (the whole aperture) that spreads
by the pixel's angle ``s / f``.  At distance ``z`` from the screen the beam,
hence the reconstructed point, is ``p + |z| s / f`` wide; it stays within one
more lens pitch (the display's 3D pixel) while ``|z| <= p f / s = N f``, with
``N = p / s`` pixels per lens.  So the sharp range is ``-N f <= z <= N f``,
``2 N f`` deep, straddling the screen (Hoshino et al., JOSA A 15, 1998: the
resolution limit ``f / (|z| s)`` of integral photography meets the lens
Nyquist limit ``1 / p`` there).  Lenticular sheets use the horizontal ``N``;
square arrays the smaller of the two.

Functions here are pure apart from ``prepare_stage`` and ``cached_include``,
which write into the povh3d cache.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._version import __version__
from ..engine.cache import content_key, default_cache_dir
from ..errors import ConfigError, warn
from ..geometry.lens_array import LensArray
from ..errors import OutputError
from ..image.io import atomic_path, check_writable
from ..povray.templates import render_template

FILL = 0.9  # of the display's width and height: a margin so the model is not cut at the edge


def depth_budget_mm(lens_array: LensArray) -> float:
    """``2 N f``: the depth (mm) the array shows sharply, half in front of the screen, half behind."""
    n = lens_array.ppl_x if lens_array.unidirectional or lens_array.grid == "hex" \
        else min(lens_array.ppl_x, lens_array.ppl_y)
    return 2.0 * n * lens_array.focal


@dataclass(frozen=True)
class Placement:
    """``object { M translate shift scale scale }``: the model centred on the origin, then scaled.

    Attributes
    ----------
    shift : (3,) float, mm          minus the model's box centre
    scale : float                   uniform
    size : (3,) float, mm           the placed model's box size
    limit : {'width', 'height', 'depth'}   which of the display's limits sets the scale
    depth : float, mm               the depth budget used
    """

    shift: tuple[float, float, float]
    scale: float
    size: tuple[float, float, float]
    limit: str
    depth: float


def fit_to_display(lo: np.ndarray, hi: np.ndarray, lens_array: LensArray, *,
                   depth: float | None = None, fill: float = FILL) -> Placement:
    """Scale the box ``lo..hi`` (mm) uniformly to fill the display's panel.

    The model keeps its proportions: the scale is the largest that fits
    ``fill`` of the panel's width and height (and, with ``depth``, that depth
    in mm), and the box is centred on the origin, so the model straddles the
    screen ``z = 0``.  Without ``depth`` a deep model may reach past the depth
    budget: ``Placement.depth`` is the budget, ``size[2]`` what the model takes.
    """
    if depth is not None and not (np.isfinite(depth) and depth > 0):
        raise ConfigError(f"--depth must be a positive number of mm, got {depth!r}")
    budget = depth if depth is not None else depth_budget_mm(lens_array)
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    size = hi - lo
    width, height = lens_array.panel.size_mm
    limits = {"width": fill * width, "height": fill * height, "depth": depth if depth is not None else np.inf}
    scales = {k: limits[k] / s for k, s in zip(limits, size) if s > 0}
    if not scales:
        raise ConfigError("the model is a single point; it cannot be scaled to the display")
    limit = min(scales, key=scales.get)
    scale = scales[limit]
    return Placement(tuple((-(lo + hi) / 2).tolist()), float(scale), tuple((size * scale).tolist()), limit, float(budget))


def stage_text(include: str, ident: str, placement: Placement, lens_array: LensArray, *, model: str) -> str:
    """The stage scene (no camera): background, two lights, the placed model."""
    width, height = lens_array.panel.size_mm
    reach = max(width, height)
    return render_template(
        "stage.pov.j2", version=__version__, model=model, include=include, ident=ident,
        shift=placement.shift, scale=placement.scale, size=placement.size, limit=placement.limit,
        depth=placement.depth,
        key_light=(-0.6 * reach, 0.9 * reach, -1.5 * reach), fill_light=(0.9 * reach, 0.2 * reach, -1.0 * reach))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def cached_include(model: str | Path, *, shading: str = "auto", max_triangles: int | None = None,
                   cache_dir: Path | None = None, up: str | None = None,
                   rotate: tuple[float, float, float] | None = None, unit: str | None = None) -> tuple[Path, dict]:
    """The model converted into the cache (``meshes/KEY/``), converting only when needed.

    The model is turned (``up``, ``rotate``), centred and scaled to a largest
    extent of 1 in Python, in double precision, so a model in any unit (a
    planet in metres) reaches POV-Ray as numbers near 1.  The key is the model's content and the options; a manifest lists every file
    the conversion read (MTL, textures, buffers) with its hash, and the entry is
    used only while they all still match.  Returns the include and the manifest.
    """
    from .convert_mesh import convert_mesh
    from ..mesh.identifiers import identifier_from_path

    model = Path(model)
    if not model.is_file():
        from ..errors import InputError

        raise InputError(f"model file {str(model)!r} does not exist; check the path")
    key = content_key("mesh", __version__, _sha256(model), shading, max_triangles, up, rotate, unit, "normalized")
    folder = (cache_dir or default_cache_dir()) / "meshes" / key[:2] / key
    manifest_path = folder / "manifest.json"
    try:  # a damaged manifest is a cache miss, converted again
        manifest = json.loads(manifest_path.read_text(encoding="utf-8")) if manifest_path.is_file() else None
    except (OSError, ValueError):
        manifest = None
    if isinstance(manifest, dict) and isinstance(manifest.get("files", {}), dict) and "include" in manifest:
        deps = manifest.get("files", {})
        if all(Path(p).is_file() and _sha256(Path(p)) == h for p, h in deps.items()):
            manifest["from_cache"] = True
            return folder / manifest["include"], manifest
    try:
        folder.mkdir(parents=True, exist_ok=True)
        check_writable(folder / "manifest.json")
    except (OSError, OutputError) as exc:  # an unusable cache: convert into a folder of this run
        import tempfile

        from ..system import owned_prefix

        warn(f"the mesh cache {str(folder.parent.parent)!r} cannot be used ({exc}); converting without it")
        folder = Path(tempfile.mkdtemp(prefix=owned_prefix("povh3d-")))  # swept after this run ends
        manifest_path = folder / "manifest.json"
    ident = identifier_from_path(model)
    result = convert_mesh(model, folder / f"{ident}.inc", shading=shading, max_triangles=max_triangles,
                          up=up, rotate=rotate, unit=unit, center=True, normalize=True)
    manifest = {"include": result.include.name, "ident": result.ident, "bounds": result.bounds,
                "triangles": result.triangles, "parts": result.parts, "warnings": result.warnings,
                "simplification": result.simplification, "model": str(model.resolve()),
                "up": result.up, "up_reason": result.up_reason, "mm_per_unit_size": 1.0 / result.scale,
                "files": {str(p): _sha256(p) for p in result.files_read if p.is_file()}}
    with atomic_path(manifest_path) as tmp:
        tmp.write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    manifest["from_cache"] = False
    return result.include, manifest


def prepare_stage(model: str | Path, lens_array: LensArray, *, depth: float | None = None,
                  shading: str = "auto", max_triangles: int | str | None = None,
                  cache_dir: Path | None = None, up: str | None = None,
                  rotate: tuple[float, float, float] | None = None, unit: str | None = None) -> tuple[Path, dict]:
    """Convert (cached) and write the stage scene beside the include; returns its path and a record.

    ``max_triangles`` may be ``'auto'``: the budget from the display's 3D resolution.
    """
    from ..mesh.simplify import auto_budget

    if max_triangles == "auto":
        max_triangles = auto_budget(lens_array)
    include, manifest = cached_include(model, shading=shading, max_triangles=max_triangles, cache_dir=cache_dir,
                                       up=up, rotate=rotate, unit=unit)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in manifest["bounds"])
    placement = fit_to_display(lo, hi, lens_array, depth=depth)
    text = stage_text(include.name, manifest["ident"], placement, lens_array, model=Path(model).name)
    stage = include.parent / f"stage-{hashlib.sha256(text.encode()).hexdigest()[:16]}.pov"
    if not stage.is_file():
        with atomic_path(stage) as tmp:
            tmp.write_text(text, encoding="utf-8")
    # The conversion's warnings were said when it ran; a converted model from the cache says them again.
    said = [] if manifest["from_cache"] else list(manifest["warnings"])
    warnings = list(manifest["warnings"])
    if placement.size[2] > placement.depth * (1 + 1e-9):
        warnings.append(f"the model is {placement.size[2]:.3g} mm deep at this size, beyond the depth budget "
                        f"of {placement.depth:.3g} mm (2 N f): its front and back look blurred; "
                        f"--depth {placement.depth:.3g} fits it")
    for message in warnings[len(said):]:
        warn(message)
    record = {"model": str(Path(model)), "include": str(include), "triangles": manifest["triangles"],
              "conversion_from_cache": manifest["from_cache"], "warnings": warnings,
              "up": manifest.get("up"), "up_reason": manifest.get("up_reason"),
              "simplification": manifest["simplification"],
              "placement": {"scale": placement.scale, "size_mm": list(placement.size), "limit": placement.limit,
                            "depth_budget_mm": placement.depth}}
    return stage, record
