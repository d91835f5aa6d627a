"""``convert-mesh``: a model file to a POV-Ray include (and its textures), all or nothing.

Load (``load.py``), clean (``clean.py``), optionally simplify (``simplify.py``),
place (unit, ``--fit-depth``, ``--center``), format (``write.py``), then write:
everything is built in memory first, every file goes through a temporary name,
and a failure removes what was already written, so nothing half-done is left.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from dataclasses import dataclass, field
from collections.abc import Callable
from typing import Any, NamedTuple
from pathlib import Path

import numpy as np

from ...errors import ConfigError, InputError, param, warn
from ...image.io import atomic_path, write_png
from ...mesh.clean import CleanReport, clean_part, vertex_normals
from ...mesh.identifiers import check_identifier, identifier_from_path
from ...mesh.load import LoadedModel, Part, load_model
from ...mesh.write import include_text, mesh2_text

SHADING = ("auto", "smooth", "flat")


@dataclass
class ConversionResult:
    """What ``convert_mesh`` wrote and noticed (for the CLI and the stage).

    ``warnings`` were each issued once (``errors.warn``) when the include was written;
    the list keeps them for a record (the stage's manifest, the render's sidecar)."""

    ident: str
    include: Path
    textures: list[Path]
    bounds: tuple[list[float], list[float]]
    parts: int
    triangles: int
    vertices: int
    smooth: bool
    files_read: list[Path]
    clean: CleanReport
    warnings: list[str] = field(default_factory=list)
    simplification: dict | None = None
    seconds: float = 0.0
    up: str = "y"                 # the model's up axis taken (``mesh.orient``)
    up_reason: str = ""
    scale: float = 1.0            # applied to the model's mm (``normalize``: 1 / its largest extent)
    part_names: list[str] = field(default_factory=list)   # of the include's mesh2 blocks, in order

    def summary(self) -> str:
        return (f"{self.parts} part{'s' if self.parts != 1 else ''}, {self.triangles} triangles, "
                f"{self.vertices} vertices, {'smooth' if self.smooth else 'flat'} shading")


def _positive(name: str, value: float | None) -> float | None:
    if value is not None and not (np.isfinite(value) and value > 0):
        raise ConfigError(f"{name} must be a positive number of mm, got {value!r}")
    return value


def place(parts: list[Part], *, fit_depth: float | None, center: bool,
          normalize: bool = False) -> tuple[list[Part], float]:
    """Scale uniformly so the model is ``fit_depth`` mm deep (``normalize``: its largest extent 1),
    then centre its box on the origin; in double precision, before any number reaches POV-Ray.
    Returns the parts and the scale applied."""
    lo, hi = model_bounds(parts)
    scale = 1.0
    if normalize:
        extent = float(np.max(hi - lo))
        if not (np.isfinite(extent) and extent > 0):
            raise ConfigError("the model is a single point; it cannot be scaled to the display")
        scale = 1.0 / extent
    elif fit_depth is not None:
        depth = hi[2] - lo[2]
        if not depth > 0:
            raise ConfigError(f"{param('fit_depth')} cannot scale a model that is flat in z (zero depth); leave it out")
        scale = fit_depth / depth
    shift = -(lo + hi) / 2 * scale if center else np.zeros(3)
    if scale == 1.0 and not shift.any():
        return parts, scale
    return [dataclasses.replace(p, vertices=p.vertices * scale + shift) for p in parts], scale


def model_bounds(parts: list[Part]) -> tuple[np.ndarray, np.ndarray]:
    """``(min, max)``, each ``(3,)`` float64 mm, over every part's vertices."""
    lo = np.min([p.vertices.min(axis=0) for p in parts], axis=0)
    hi = np.max([p.vertices.max(axis=0) for p in parts], axis=0)
    return lo, hi


def _warnings(report: CleanReport, parts: list[Part], missing: list[str], notes: list[str]) -> list[str]:
    out = list(notes) + list(report.notes)
    if report.nonfinite_faces:
        out.append(f"dropped {report.nonfinite_faces} faces with non-finite (NaN or infinite) vertices")
    if report.degenerate_faces:
        out.append(f"dropped {report.degenerate_faces} degenerate faces (zero area)")
    textures_missing = {p.texture_missing for p in parts if p.texture_missing}
    for name in textures_missing:
        out.append(f"texture {name!r} named by the model is missing; rendering with the base colour")
    for name in missing:
        if name not in textures_missing:
            out.append(f"{name!r} named by the model is missing")
    return out


class TurnedModel(NamedTuple):
    """A model read, cleaned and turned: what ``turned_parts`` gives."""

    loaded: LoadedModel          # as read (files, missing textures, the reader's warnings)
    parts: list[Part]            # cleaned, without empty parts, turned
    clean: CleanReport           # what cleaning did
    up: str                      # the up axis taken
    up_reason: str               # and why


#: Bytes of memory reading a model takes, per byte of its file, estimated before it is read.  Measured
#: on a 1.3-million-triangle sphere (trimesh and povh3d's reader, peak resident less the imports): OBJ
#: 7.4, GLB 4.7, STL 3.6, PLY 1.0; the reader's cleaning and the writing come on top.  A compressed
#: file (3MF, a Draco GLB) can expand past it: the reader itself then meets POV-Ray's limit of its own.
MODEL_BYTES_PER_FILE_BYTE = 12


def check_model_memory(model: Path) -> None:
    """Refuse, before it is read, a model whose estimated reading is over the run's memory budget
    (``--max-memory``, else what the machine has free)."""
    from ..budget import check_memory

    try:
        size = os.path.getsize(model)
    except OSError:
        return   # the reader says what is wrong with the file
    check_memory(f"reading {model.name} ({size / 2**20:.3g} MB)", MODEL_BYTES_PER_FILE_BYTE * size,
                 f"simplify the model before converting it, or raise {param('max_memory')}")


def turned_parts(model: Path, *, unit: str | None = None, up: str | None = None, rotate: Any = None,
                 step: Callable[[int, int], None] = lambda done, total: None) -> TurnedModel:
    """The model read, cleaned and turned up (``--up``, else the format's or detected), then by ``rotate``."""
    check_model_memory(model)
    loaded = load_model(model, unit=unit)
    step(1, 4)
    parts: list[Part] = []
    report = CleanReport()
    for raw in loaded.parts:
        part, r = clean_part(raw, merge=loaded.format.soup)
        report = report + r
        if len(part.faces):
            parts.append(part)
    if not parts:
        dropped = report.nonfinite_faces + report.degenerate_faces
        why = f" (all {dropped} were dropped as non-finite or degenerate)" if dropped else ""
        raise InputError(f"{str(model)!r} contains no triangles{why}; check the export")

    step(2, 4)
    from ...mesh.orient import detect_up, reorient

    if up is None:
        up, up_reason = detect_up(model.suffix, *model_bounds(parts))
    else:
        up_reason = param("up")
    return TurnedModel(loaded, reorient(parts, up, rotate), report, up, up_reason)


def convert_mesh(model: str | Path, output: str | Path | None = None, *, name: str | None = None,
                 unit: str | None = None, shading: str = "auto", fit_depth: float | None = None,
                 center: bool = False, max_triangles: int | None = None, up: str | None = None,
                 rotate: tuple[float, float, float] | None = None, normalize: bool = False,
                 progress: Callable[[int, int], None] | None = None) -> ConversionResult:
    """Convert ``model`` into the include ``output`` (default: beside it, ``.inc``).

    Parameters
    ----------
    model : path            any format in ``FORMATS``
    output : path or None
    name : str or None      the identifier to declare (default: from the file name)
    unit : {'mm', 'cm', 'm', 'in'} or None   the model's unit (default: the file's, else the format's)
    shading : {'auto', 'smooth', 'flat'}     auto: flat for STL (a facet format), smooth otherwise
    fit_depth : float or None   scale the model to this depth (z extent), mm
    center : bool           centre the model's bounding box on the origin
    max_triangles : int or None   simplify to at most this many triangles
    up : {'x', 'y', 'z', '-x', '-y', '-z'} or None   the model's up axis (None: the format's, or detected)
    rotate : (3,) degrees or None   then turn it as POV-Ray's ``rotate`` would
    normalize : bool        scale the model so its largest extent is 1 (the stage scales it to the display)
    progress : callable(done, total), optional   called after each of the 4 steps (read, clean, shade, write)

    Raises
    ------
    InputError, ConfigError, OutputError
        With nothing written.
    """
    start = time.perf_counter()
    model = Path(model)
    ident = check_identifier(name) if name is not None else identifier_from_path(model)
    if shading not in SHADING:
        raise ConfigError(f"shading must be one of {', '.join(SHADING)}, got {shading!r}")
    _positive(param("fit_depth"), fit_depth)
    if max_triangles is not None and max_triangles < 4:
        raise ConfigError(f"{param('max_triangles')} must be at least 4, got {max_triangles}")
    output = Path(output) if output is not None else model.with_suffix(".inc")
    if output.resolve() == model.resolve():
        raise ConfigError(f"the output {str(output)!r} would overwrite the model; choose another name")

    step = progress or (lambda done, total: None)
    step(0, 4)
    loaded, parts, report, up, up_reason = turned_parts(model, unit=unit, up=up, rotate=rotate, step=step)
    simplification = None
    if max_triangles is not None and sum(p.triangles for p in parts) > max_triangles:
        from ...mesh.simplify import simplify_parts

        parts, simplification = simplify_parts(parts, max_triangles)
    parts, scale = place(parts, fit_depth=fit_depth, center=center, normalize=normalize)

    smooth = shading == "smooth" or (shading == "auto" and not loaded.format.soup)
    blocks, textures = [], []
    for i, part in enumerate(parts):
        normals = None
        if smooth:
            normals = part.normals if part.normals is not None else vertex_normals(part.vertices, part.faces)
        texture_file = None
        if part.texture is not None and part.uv is not None:
            texture_file = f"{ident}_{i}.png"
            textures.append((output.parent / texture_file, part.texture))
        blocks.append(mesh2_text(part, smooth=smooth, normals=normals, texture_file=texture_file, ident=ident))
    lo, hi = model_bounds(parts)
    result = ConversionResult(
        ident=ident, include=output, textures=[p for p, _ in textures], bounds=(lo.tolist(), hi.tolist()),
        parts=len(parts), triangles=sum(p.triangles for p in parts),
        vertices=sum(len(p.vertices) for p in parts), smooth=smooth, files_read=loaded.files, clean=report,
        warnings=_warnings(report, loaded.parts, loaded.missing, loaded.warnings), simplification=simplification,
        up=up, up_reason=up_reason, scale=scale, part_names=[p.name for p in parts])
    step(3, 4)
    text = include_text(blocks, ident, (lo, hi), source=model.name, summary=result.summary())
    _write_all(output, text, textures)
    for message in result.warnings:  # said through the one channel once written; kept for the records
        warn(message)
    step(4, 4)
    result.seconds = time.perf_counter() - start
    return result


def _write_all(include: Path, text: str, textures: list[tuple[Path, np.ndarray]]) -> None:
    """Textures, then the include; on any failure remove the textures already written."""
    written: list[Path] = []
    try:
        for path, image in textures:
            write_png(path, image)
            written.append(path)
        with atomic_path(include) as tmp:
            with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(text)
    except BaseException:
        for path in written:
            with contextlib.suppress(OSError):
                os.unlink(path)
        raise
