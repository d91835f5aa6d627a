"""The default stage for ``povh3d render MODEL``: the model converted (cached) and placed where the
display shows it sharply.

The fit and the depth budget are ``geometry/fit.py``'s, the stage scene's
text ``renderer/content/stage_text.py``'s; this module converts the model into the cache
(``povh3d.cache``: ``meshes/ab/KEY/``, its manifest an entry of the one cache) and
writes the stage file beside it (``write_stage``, which ``renderer/content/volume.py`` uses too).
"""

from __future__ import annotations

from ... import jsontext
import hashlib
import json
from pathlib import Path

import numpy as np

from ... import cache
from ..._version import __version__
from ...cache import content_key
from .stage_text import model_stage_text
from ...errors import warn
from ...geometry.fit import depth_warning, fit_to_display, fit_record
from ...geometry.lens_array import LensArray
from ...image.io import atomic_path


def write_stage(folder: Path, text: str) -> Path:
    """The stage scene ``text`` as ``folder/stage-<hash>.pov``, written once (atomically) and reused."""
    stage = folder / f"stage-{hashlib.sha256(text.encode()).hexdigest()[:16]}.pov"
    if not stage.is_file():
        with atomic_path(stage) as tmp:
            tmp.write_text(text, encoding="utf-8")
    return stage


def load_manifest(folder: Path, key: str, required: tuple[str, ...]) -> dict | None:
    """The manifest entry of a converted model or volume in ``folder``; None on a miss (a damaged one:
    warned, removed)."""
    def parse(body: bytes) -> dict:
        manifest = jsontext.loads(body)
        if not isinstance(manifest, dict) or not set(required) <= manifest.keys():
            raise ValueError("not a manifest")
        return manifest

    try:
        return cache.load(folder / "manifest.entry", key, parse, again="converting again")
    except OSError:
        return None


def store_manifest(folder: Path, key: str, manifest: dict) -> None:
    """Keep ``manifest`` as the entry of ``folder`` (written last: it makes the folder a hit)."""
    from ...errors import OutputError

    try:
        cache.store(folder / "manifest.entry", key, json.dumps(manifest, indent=2).encode("utf-8"))
    except (OSError, OutputError):
        pass   # the next run converts again


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
    from ...mesh.identifiers import identifier_from_path

    model = Path(model)
    if not model.is_file():
        from ...errors import InputError

        raise InputError(f"model file {str(model)!r} does not exist; check the path")
    # "part-names": manifests before the part names (object masks) are converted again
    key = content_key("mesh", __version__, _sha256(model), shading, max_triangles, up, rotate, unit, "normalized",
                      "part-names")
    folder = cache.entry_path(cache.cache_root(cache_dir), "meshes", key, "")
    manifest = load_manifest(folder, key, ("include", "files", "part_names"))
    if manifest is not None and isinstance(manifest["files"], dict) and (folder / manifest["include"]).is_file():
        if all(Path(p).is_file() and _sha256(Path(p)) == h for p, h in manifest["files"].items()):
            manifest["from_cache"] = True
            return folder / manifest["include"], manifest
    folder = cache.cache_folder(folder, "mesh")
    ident = identifier_from_path(model)
    result = convert_mesh(model, folder / f"{ident}.inc", shading=shading, max_triangles=max_triangles,
                          up=up, rotate=rotate, unit=unit, center=True, normalize=True)
    manifest = {"include": result.include.name, "ident": result.ident, "bounds": result.bounds,
                "triangles": result.triangles, "parts": result.parts, "part_names": result.part_names,
                "warnings": result.warnings,
                "simplification": result.simplification, "model": str(model.resolve()),
                "up": result.up, "up_reason": result.up_reason, "mm_per_unit_size": 1.0 / result.scale,
                "files": {str(p): _sha256(p) for p in result.files_read if p.is_file()}}
    store_manifest(folder, key, manifest)
    manifest["from_cache"] = False
    return result.include, manifest


def prepare_stage(model: str | Path, lens_array: LensArray, *, depth: float | None = None,
                  shading: str = "auto", max_triangles: int | str | None = None,
                  cache_dir: Path | None = None, up: str | None = None,
                  rotate: tuple[float, float, float] | None = None, unit: str | None = None) -> tuple[Path, dict]:
    """Convert (cached) and write the stage scene beside the include; returns its path and a record.

    ``max_triangles`` may be ``'auto'``: the budget from the display's 3D resolution.
    """
    from ...mesh.simplify import auto_budget

    if isinstance(max_triangles, str):  # 'auto', the one word ModelOptions takes
        max_triangles = auto_budget(lens_array)
    include, manifest = cached_include(model, shading=shading, max_triangles=max_triangles, cache_dir=cache_dir,
                                       up=up, rotate=rotate, unit=unit)
    lo, hi = (np.asarray(b, dtype=np.float64) for b in manifest["bounds"])
    fit = fit_to_display(lo, hi, lens_array, depth=depth)
    stage = write_stage(include.parent, model_stage_text(include.name, manifest["ident"], fit, lens_array,
                                                         model=Path(model).name))
    # The conversion's warnings were said when it ran; a converted model from the cache says them again.
    said = [] if manifest["from_cache"] else list(manifest["warnings"])
    warnings = list(manifest["warnings"]) + depth_warning(fit, "model")
    for message in warnings[len(said):]:
        warn(message)
    record = {"model": str(Path(model)), "include": str(include), "triangles": manifest["triangles"],
              "parts": manifest["part_names"],
              "conversion_from_cache": manifest["from_cache"], "warnings": warnings,
              "up": manifest.get("up"), "up_reason": manifest.get("up_reason"),
              "simplification": manifest["simplification"],
              "fit": fit_record(fit, depth_budget_mm=fit.depth)}
    return stage, record
