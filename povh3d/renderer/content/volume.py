"""The stage for ``povh3d render VOLUME``: a volume's surfaces (or its medium) placed on the display.

The volume's physical box is turned into display coordinates by the orientation
preset (and ``--rotate``), centred and scaled like a model (``geometry.fit``'s
``fit_to_display``: fill the panel, or ``--depth``).  Surfaces (``--labels``,
``--iso``) are extracted in LPS mm, turned, decimated to the display's
triangle budget and written as one include in the cache, keyed by the voxel
values and every option that shapes them; the stage scene is the mesh stage's
(``stage.pov.j2``: background, two lights, ``translate shift scale s``).
``--volume`` hands the volume and its world-to-display matrix to
``renderer.content.volume_media`` instead.  A ``.vtk`` file holding a polygon mesh is a
model: it goes to the mesh path (``renderer.content.model``) through a PLY copy in the cache.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import numpy as np

from ... import cache
from ..._version import __version__
from ...cache import content_key
from .stage_text import model_stage_text
from ...jsontext import JSONValue
from ...errors import ConfigError, InputError, param, warn
from ...geometry.fit import depth_warning, fit_to_display, fit_record
from ...geometry.lens_array import LensArray
from ...image.io import atomic_path
from ...volume.grid import Volume
from ...volume.orient import display_box, volume_to_display, world_to_display
from ..request import VolumeOptions
from .model import load_manifest, prepare_stage, store_manifest, write_stage

IDENT = "Povh3d_Volume"
#: Labels are extracted from voxels at most this share of a lens across (``surfaces.voxel_step``):
#: the display resolves a lens, so finer voxels only feed triangles the decimation removes.
LABEL_DETAIL = 1 / 5
#: At most this many distinct integer values make a volume a label map when nothing says what to draw.
MAX_AUTO_LABELS = 255


def volume_digest(volume: Volume) -> str:
    """sha256 of the voxels and their geometry: the cache key's part that is the data."""
    values = volume.values
    # The voxels' bytes in their own memory order (VTK's files are Fortran-ordered): a C-ordered copy
    # of a 32-million-voxel volume costs more than hashing it.  The order is part of the key.
    order = "F" if values.flags.f_contiguous and not values.flags.c_contiguous else "C"
    data = values.T if order == "F" else np.ascontiguousarray(values)
    h = hashlib.sha256()
    h.update(str((values.dtype.str, volume.shape, volume.spacing, volume.origin, order)).encode())
    h.update(np.asarray(volume.direction, dtype=np.float64).tobytes())
    # an ndarray is a buffer; NumPy's stubs declare its __buffer__ for Python 3.12+ only
    h.update(memoryview(data).cast("B"))  # type: ignore[arg-type]
    return h.hexdigest()


def what_to_draw(volume: Volume, options: VolumeOptions) -> tuple[str, list[str]]:
    """``'labels'``, ``'iso'`` or ``'volume'``, and a note when povh3d chose it."""
    if options.volume:
        return "volume", []
    if options.labels is not None:
        return "labels", []
    if options.iso is not None:
        return "iso", []
    values = volume.values
    integral = np.issubdtype(values.dtype, np.integer) or bool(np.all(np.mod(values, 1) == 0))
    labels = volume.labels() if integral else []
    if 0 < len(labels) <= MAX_AUTO_LABELS:
        return "labels", [f"no {param('labels')}, {param('iso')} or {param('volume')}: {volume.name} holds {len(labels)} integer labels, "
                          f"drawing every one ({param('labels')} LIST picks some)"]
    lo, hi = volume.value_range()
    raise ConfigError(f"{volume.name} holds values from {lo:.6g} to {hi:.6g}; say what to draw: {param('iso')} VALUE "
                      f"(a surface at that value), {param('labels')} (a segmentation) or {param('volume')} (a medium)")


def place_volume(volume: Volume, lens_array: LensArray, orientation: str, rotate: Any = None,
                 depth: float | None = None) -> tuple[np.ndarray, Any, np.ndarray]:
    """The volume turned (orientation preset, then ``rotate``) and its physical box fitted to the display:
    the turn (3, 3), the ``Fit`` and the world-to-display matrix (4, 4)."""
    matrix = volume_to_display(orientation, rotate)
    fit = fit_to_display(*display_box(volume.corners(), matrix), lens_array, depth=depth)
    return matrix, fit, world_to_display(matrix, fit.shift, fit.scale)


def prepare_volume_stage(source: str | Path, lens_array: LensArray, options: VolumeOptions | None = None, *,
                         depth: float | None = None, max_triangles: int | str | None = None,
                         cache_dir: Path | None = None) -> tuple[Path, dict[str, JSONValue]]:
    """Read, place, extract (cached) and write the stage scene; returns its path and the sidecar record.

    ``max_triangles``: the surfaces' triangle budget (None or ``'auto'``: the display's, ``auto_budget``).
    """
    from ...volume.read import read_volume
    from ...volume.sources import is_polydata_vtk

    options = options or VolumeOptions()
    if is_polydata_vtk(source):
        if dataclasses.replace(options, rotate=None) != VolumeOptions():
            raise ConfigError(f"{Path(source).name!r} is a polygon mesh, not a volume; the volume options ({param('labels')}, "
                              f"{param('iso')}, {param('volume')}, {param('orientation')} ...) do not apply to it")
        return _mesh_stage(Path(source), lens_array, depth=depth, max_triangles=max_triangles,
                           cache_dir=cache_dir, rotate=options.rotate)
    volume = read_volume(source, spacing=options.spacing, series=options.series, weigh=volume_weigher(source))
    kind, notes = what_to_draw(volume, options)
    for note in notes:
        warn(note)
    matrix, fit, to_display = place_volume(volume, lens_array, options.orientation, options.rotate, depth)
    digest = volume_digest(volume)
    record: dict[str, JSONValue] = {
        "volume": volume.as_record(), "source": str(source), "draw": kind, "orientation": options.orientation,
        "rotate": list(options.rotate) if options.rotate else None, "world_to_display": to_display.tolist(),
        "fit": fit_record(fit, depth_budget_mm=fit.depth),
        "warnings": depth_warning(fit, "volume")}
    root = cache.cache_root(cache_dir)
    if kind == "volume":
        from .volume_media import media_stage

        key = content_key("volume-media", __version__, digest, options.transfer, options.df3_bits,
                          np.round(to_display, 12).tolist())
        folder = cache.cache_folder(cache.entry_path(root, "volumes", key, ""), "volume")
        stage, media = media_stage(volume, to_display, lens_array, transfer=options.transfer,
                                   bits=options.df3_bits, folder=folder)
        record["media"] = media
        return stage, record
    from ...mesh.simplify import auto_budget

    # None or 'auto' (the one word ModelOptions takes)
    budget = auto_budget(lens_array) if max_triangles is None or isinstance(max_triangles, str) else max_triangles
    speck = min(lens_array.pitch_x, lens_array.pitch_y) / fit.scale   # one lens, in the surfaces' mm
    include, manifest = cached_surfaces(volume, digest, kind, options, matrix, budget, root, speck)
    record["surfaces"] = manifest["surfaces"]
    record["triangles"] = manifest["triangles"]
    record["triangle_budget"] = budget
    record["surfaces_from_cache"] = manifest["from_cache"]
    record["seconds"] = manifest["seconds"]
    record["silhouette_error"] = manifest["silhouette_error"]
    record["specks_left_out"] = manifest.get("specks_left_out", 0)
    record["voxel_step"] = manifest.get("voxel_step", [1, 1, 1])
    stage = write_stage(include.parent, model_stage_text(include.name, IDENT, fit, lens_array,
                                                         model=volume.name))
    return stage, record


def cached_surfaces(volume: Volume, digest: str, kind: str, options: VolumeOptions, matrix: np.ndarray,
                    budget: int | None, root: Path, speck: float = 0.0) -> tuple[Path, dict[str, Any]]:
    """The surfaces' include in the cache (``volumes/KEY/``), extracted only when it is not there."""
    import time

    key = content_key("volume-surfaces", __version__, digest, kind, options.labels, options.iso,
                      options.opacity, options.smoothing, np.round(matrix, 12).tolist(), budget, round(speck, 9),
                      LABEL_DETAIL)
    folder = cache.entry_path(root, "volumes", key, "")
    include = folder / "surfaces.inc"
    manifest = load_manifest(folder, key, ("surfaces",))
    if manifest is not None and include.is_file():
        return include, {**manifest, "from_cache": True}
    folder = cache.cache_folder(folder, "volume")
    include = folder / "surfaces.inc"
    start = time.perf_counter()
    from ...volume.surfaces import iso_surfaces, label_surfaces, voxel_step

    smoothing, opacity = options.smoothing, list(options.opacity) if options.opacity else None
    step = (1, 1, 1)
    if kind == "labels":
        # a str is 'all', the one word VolumeOptions takes
        labels = None if options.labels is None or isinstance(options.labels, str) else list(options.labels)
        step = voxel_step(volume.spacing, LABEL_DETAIL * speck)
        surfaces = label_surfaces(volume, labels, smoothing=smoothing, opacity=opacity, step=step)
    else:
        assert options.iso is not None  # kind 'iso': what_to_draw found it
        surfaces = iso_surfaces(volume, list(options.iso), smoothing=smoothing, opacity=opacity)
    extracted = time.perf_counter() - start
    from ...volume.include import surfaces_include

    text, rows, stats = surfaces_include(surfaces, matrix, budget, ident=IDENT, source=volume.name, speck=speck)
    with atomic_path(include) as tmp:
        tmp.write_text(text, encoding="utf-8")
    manifest = {"surfaces": rows, "triangles": sum(r["triangles"] for r in rows),
                "seconds": {"extract": round(extracted, 4), "decimate": stats["decimate_seconds"],
                            "write": stats["write_seconds"]}, "silhouette_error": stats["silhouette_error"],
                "specks_left_out": stats["specks_left_out"], "voxel_step": list(step)}
    store_manifest(folder, key, manifest)
    return include, {**manifest, "from_cache": False}


def _mesh_stage(source: Path, lens_array: LensArray, *, depth: float | None, max_triangles: Any,
                cache_dir: Path | None, rotate: Any) -> tuple[Path, dict[str, JSONValue]]:
    """A polygon-mesh ``.vtk``: triangulated into a PLY in the cache, then staged as any model."""
    import trimesh

    from ...volume.read import read_vtk_mesh

    root = cache.cache_root(cache_dir)
    key = content_key("vtk-mesh", __version__, hashlib.sha256(source.read_bytes()).hexdigest())
    ply = cache.entry_path(root, "volumes", key, "") / f"{source.stem}.ply"
    if not ply.is_file():
        points, faces = read_vtk_mesh(source)
        if not len(faces):
            raise InputError(f"{str(source)!r} holds no polygons; check the file")
        ply = cache.cache_folder(ply.parent, "volume") / ply.name
        with atomic_path(ply) as tmp:
            # cast: a PLY export is bytes (export's type covers every format)
            tmp.write_bytes(cast(bytes, trimesh.Trimesh(points, faces, process=False).export(file_type="ply")))
    stage, record = prepare_stage(ply, lens_array, depth=depth, max_triangles=max_triangles, cache_dir=cache_dir,
                                  rotate=rotate)
    record["model"] = str(source)
    return stage, record


#: Bytes of memory a volume's reading and drawing take per voxel, beyond its own samples: measured on
#: 192^3 voxels drawn as an iso surface (int16: 12 a voxel in all, float64: 20, peak resident less the
#: imports), so the voxel's own bytes and 12 more.
VOLUME_BYTES_PER_VOXEL = 12


def volume_weigher(source: str | Path) -> Callable[[int, int], None]:
    """What ``read_volume`` tells a volume's size to before a voxel is read: a refusal of a reading
    estimated over the run's memory budget (``--max-memory``, else what the machine has free)."""
    from ..budget import check_memory

    def weigh(voxels: int, itemsize: int) -> None:
        check_memory(f"reading the volume {Path(source).name} ({voxels:,} voxels)",
                     voxels * (itemsize + VOLUME_BYTES_PER_VOXEL),
                     f"crop or downsample it before rendering, or raise {param('max_memory')}")
    return weigh
