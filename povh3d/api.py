"""The Python API: render a scene to an H3D PNG, interleave and extract view stacks.

These functions touch files; the geometry and image work they call is pure.
Outputs are written atomically, each image with its JSON sidecar.
"""

from __future__ import annotations

import json
import re
import time
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from .crop import CropSettings
from .errors import ConfigError, InputError, OutputError
from .geometry import LensArray
from .imageio import atomic_path, check_writable, read_png, read_sidecar, write_png, write_sidecar
from .interleave import extract, interleave
from .methods import METHODS, run_method
from .quality_bench import resolve_auto
from .povray import find_povray, povray_version
from .render import Progress, Quality, RenderSettings
from .sandbox import describe as describe_sandbox
from .scene import load_scene
from .calibration.commands import (  # noqa: F401  capture-side processing (thesis ch. 4)
    borders_file, calibrate_file, equalise_file, stitch_files, undistort_file, viewpoints_file)

from .animation import FrameRange, render_animation  # noqa: E402,F401  (animation uses this module)

VIEW_NAME = "v_{l:03d}_{k:03d}.png"
_VIEW_RE = re.compile(r"^v_(\d{3,})_(\d{3,})\.png$")


def _sidecar(kind: str, lens_array: LensArray | None, **extra: Any) -> dict[str, Any]:
    record: dict[str, Any] = {"povh3d_version": __version__, "kind": kind}
    if lens_array is not None:
        record["lens_array"] = lens_array.describe()
    record.update(extra)
    return record


def render(scene_path: str | Path, lens_array: LensArray, output: str | Path, *,
           method: str = "multi-ortho", settings: RenderSettings | None = None,
           views_dir: str | Path | None = None, include_dirs: tuple[str | Path, ...] = (),
           display: dict[str, Any] | None = None, progress: Progress | None = None,
           mapping: Any = None, mapped_panel: tuple[int, int] | None = None,
           crop: CropSettings | None = None, **method_options: Any) -> dict[str, Any]:
    """Render ``scene_path`` through ``lens_array`` into the H3D PNG ``output``.

    With a ``mapping`` (``povh3d.mappings``), ``lens_array`` is the view-space
    array it reads (``mapping.render_array``) and ``output`` is the panel image
    of size ``mapped_panel`` (W, H).  ``method_options`` go to the method
    (``single-stage``: ``lenslet``, ``ior``).  ``crop``: trace only where objects
    can be (multi-ortho; see ``povh3d.crop``).  Returns the sidecar record written
    beside ``output``.
    """
    settings = settings or RenderSettings()
    if method not in METHODS:
        raise ConfigError(f"unknown method {method!r}; choose one of: {', '.join(METHODS)}")
    output = Path(output)
    if output.suffix.lower() != ".png":
        raise ConfigError(f"the output {str(output)!r} must be a .png file")
    scene = load_scene(scene_path, include_dirs)
    check_writable(output)  # fail before rendering, not after
    if views_dir is not None:
        lens_array.require_views()
        Path(views_dir).mkdir(parents=True, exist_ok=True)
        check_writable(Path(views_dir) / ".povh3d-write-test")

    start = time.perf_counter()
    settings, auto = resolve_auto(scene, lens_array, method, settings, **method_options)
    result = run_method(method, scene, lens_array, settings, progress, crop=crop, **method_options)
    render_seconds = time.perf_counter() - start
    h3d = result.h3d
    expected = (lens_array.panel.height, lens_array.panel.width)
    if h3d.shape[:2] != expected:  # a bug, never the user's doing
        raise RuntimeError(f"{method} produced {h3d.shape[:2]}, expected {expected}")

    record = _sidecar(
        "h3d", lens_array, method=method, display=display or {}, scene=str(scene.path),
        scene_sha256=scene.digest,
        quality={**quality_record(settings, result.quality), "bit_depth": settings.bit_depth,
                 "front_clearance_mm": result.back_off},
        output_gamma="sRGB", povray_version=result.stats.povray_version,
        sandbox=describe_sandbox(), scheduler=settings.scheduler,
        timings={"render_seconds": round(render_seconds, 4), **result.stats.as_dict()},
    )
    if auto is not None:
        record["quality"].update(level="auto", auto=auto.as_dict())
    if method == "single-stage":
        record["single_stage"] = single_stage_record(lens_array, result.back_off, **method_options)
    if result.crop is not None:
        record["crop"] = result.crop
    if views_dir is not None:
        write_views(views_dir, extract(h3d[lens_array.bank_region], lens_array.require_views()), lens_array, record)
    if mapping is not None:
        h3d = mapping.apply(h3d, mapped_panel)
        record.update(kind="panel", mapping=mapping.name, size_px=list(mapped_panel))
    write_png(output, h3d)
    write_sidecar(output, record)
    return record


def write_views(views_dir: str | Path, views: np.ndarray, lens_array: LensArray | None,
                source: dict[str, Any] | None = None) -> None:
    """Write a ``(Ny, Nx, Ly, Lx, C)`` view stack as ``v_{l:03d}_{k:03d}.png`` plus ``views.json``."""
    folder = Path(views_dir)
    folder.mkdir(parents=True, exist_ok=True)
    ny, nx = views.shape[:2]
    for l in range(ny):
        for k in range(nx):
            write_png(folder / VIEW_NAME.format(l=l, k=k), views[l, k])
    record = _sidecar("views", lens_array, views=[nx, ny], source=source or {})
    with atomic_path(folder / "views.json") as tmp:
        tmp.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")


def read_views(views_dir: str | Path) -> np.ndarray:
    """Read ``v_{l}_{k}.png`` files into a ``(Ny, Nx, Ly, Lx, C)`` stack; every view must be there."""
    folder = Path(views_dir)
    if not folder.is_dir():
        raise InputError(f"views folder {str(folder)!r} does not exist; check the path")
    found = {}
    for p in folder.iterdir():
        m = _VIEW_RE.match(p.name)
        if m:
            found[(int(m.group(1)), int(m.group(2)))] = p
    if not found:
        raise InputError(f"no view images (v_LLL_KKK.png) in {str(folder)!r}; render with --views-dir first")
    ny = max(l for l, _ in found) + 1
    nx = max(k for _, k in found) + 1
    absent = [(l, k) for l in range(ny) for k in range(nx) if (l, k) not in found]
    if absent:
        l, k = absent[0]
        raise InputError(f"{len(absent)} views missing in {str(folder)!r}, first {VIEW_NAME.format(l=l, k=k)}; "
                         "the stack must be a full Ny x Nx grid")
    images = [read_png(found[(l, k)]) for l in range(ny) for k in range(nx)]
    shapes = {img.shape for img in images}
    if len(shapes) != 1:
        raise InputError(f"the views in {str(folder)!r} differ in size or channels: {sorted(shapes)}")
    dtypes = {img.dtype for img in images}
    if len(dtypes) != 1:
        raise InputError(f"the views in {str(folder)!r} mix 8-bit and 16-bit images")
    return np.stack(images).reshape(ny, nx, *images[0].shape)


def interleave_dir(views_dir: str | Path, output: str | Path) -> dict[str, Any]:
    """Interleave a folder of views into an H3D PNG with its sidecar."""
    views = read_views(views_dir)
    check_writable(output)
    h3d = interleave(views)
    source = read_sidecar(Path(views_dir) / "views.json") or {}
    record = _sidecar("h3d", None, method="interleave", views=[views.shape[1], views.shape[0]],
                      views_dir=str(Path(views_dir).resolve()), size_px=[h3d.shape[1], h3d.shape[0]],
                      output_gamma="sRGB")
    if source.get("lens_array"):
        record["lens_array"] = source["lens_array"]
    write_png(output, h3d)
    write_sidecar(output, record)
    return record


def extract_file(h3d_path: str | Path, ppl: tuple[int, int] | None, views_dir: str | Path) -> dict[str, Any]:
    """Extract the view stack of an H3D PNG into ``views_dir``; ``ppl`` is ``(Ny, Nx)``.

    Without ``ppl`` the lens array comes from the image's sidecar; a hex or
    fractional-PPL array is resampled lens by lens (``elemental.extract_views``)
    and ``views.json`` records the lens centres used.
    """
    h3d = read_png(h3d_path)
    if ppl is None:
        return _extract_resampled(h3d, h3d_path, views_dir)
    try:
        views = extract(h3d, ppl)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    try:
        Path(views_dir).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create {str(views_dir)!r}: {exc.strerror}") from None
    write_views(views_dir, views, None, {"h3d": str(Path(h3d_path).resolve())})
    return {"views": [ppl[1], ppl[0]], "view_size_px": [views.shape[3], views.shape[2]]}


def quality_record(settings: RenderSettings, rendered: Quality) -> dict[str, Any]:
    """The quality asked for and as rendered (a method without sub-views antialiases instead)."""
    level = settings.quality if isinstance(settings.quality, str) else "custom"
    return {"level": level, "setting": rendered.label, "povray_options": list(rendered.options),
            "subviews": rendered.subviews, "footprint_samples": rendered.footprint,
            "max_trace_level": rendered.max_trace_level}


def single_stage_record(lens_array: LensArray, back_off: float, lenslet: str = "conic",
                        ior: float | None = None) -> dict[str, Any]:
    """What the single-stage method built: lenslet optics, focal plane, capture size."""
    from .single_stage import SingleStagePlan, lenslet_for

    return SingleStagePlan.for_clearance(lens_array, lenslet_for(lens_array, lenslet, ior), back_off).describe()


def _extract_resampled(h3d: np.ndarray, h3d_path: str | Path, views_dir: str | Path) -> dict[str, Any]:
    from .elemental import extract_views, view_grid
    from .presets import lens_array_from_record

    record = read_sidecar(h3d_path)
    if not record or "lens_array" not in record:
        raise ConfigError(f"{str(h3d_path)!r} has no sidecar with its lens array; give --ppl NxxNy")
    lens_array = lens_array_from_record(record["lens_array"])
    if h3d.shape[:2] != (lens_array.panel.height, lens_array.panel.width):
        raise InputError(f"{str(h3d_path)!r} is {h3d.shape[1]}x{h3d.shape[0]} but its sidecar describes a "
                         f"{lens_array.panel.width}x{lens_array.panel.height} panel; re-render it")
    ny, nx = lens_array.views or view_grid(lens_array)
    views = extract_views(h3d, lens_array, (ny, nx)) if lens_array.views is None else \
        extract(h3d[lens_array.bank_region], (ny, nx))
    try:
        Path(views_dir).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create {str(views_dir)!r}: {exc.strerror}") from None
    source = {"h3d": str(Path(h3d_path).resolve()), "resampled": lens_array.views is None,
              "lens_centres_mm": lens_array.lens_centres().reshape(-1, 2).tolist()}
    write_views(views_dir, views, lens_array, source)
    return {"views": [nx, ny], "view_size_px": [views.shape[3], views.shape[2]]}


def povray_info() -> dict[str, str]:
    binary = find_povray()
    return {"binary": binary, "version": povray_version(binary)}



def render_model(model: str | Path, lens_array: LensArray, output: str | Path, *, depth: float | None = None,
                 shading: str = "auto", max_triangles: int | str | None = None, **kwargs: Any) -> dict[str, Any]:
    """Render a mesh file (OBJ, STL, PLY, glTF, ...) on the default stage; see ``povh3d.mesh.stage``.

    The model is converted once (cached by content), scaled to the display's
    field and depth budget (``depth`` mm overrides the budget) and centred on
    the screen; ``kwargs`` go to ``render``.  Returns the sidecar record, which
    also describes the model and its placement.
    """
    from .mesh.stage import prepare_stage

    settings = kwargs.get("settings")
    cache_dir = settings.cache_dir if settings is not None else None
    stage, model_record = prepare_stage(model, lens_array, depth=depth, shading=shading,
                                        max_triangles=max_triangles, cache_dir=cache_dir)
    record = render(stage, lens_array, output, **kwargs)
    record["model"] = model_record
    write_sidecar(output, record)
    return record
