"""View stacks on disk: ``views/v_{l:03d}_{k:03d}.png`` (row l, column k of the
camera bank) with ``views.json``; interleaving a views folder into an H3D image and
extracting one from it."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, OutputError
from ..geometry.axes import to_edge
from ..geometry.lens_array import LensArray
from ..image.elemental import extract_views, view_grid
from ..image.interleave import extract, interleave
from ..image.io import atomic_path, check_writable, read_png, read_sidecar, write_png
from .display_setup import Display
from .records import base_record, png_output, write_image

VIEW_NAME = "v_{l:03d}_{k:03d}.png"
_VIEW_RE = re.compile(r"^v_(\d{3,})_(\d{3,})\.png$")


def check_views_dir(views_dir: str | Path) -> Path:
    """Create the views folder if needed and check it can be written (before any work)."""
    folder = Path(views_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create {str(folder)!r}: {exc.strerror}") from None
    check_writable(folder / ".povh3d-write-test")
    return folder


def write_views(views_dir: str | Path, views: np.ndarray, lens_array: LensArray | None,
                source: dict[str, Any] | None = None) -> None:
    """Write a ``(Ny, Nx, Ly, Lx, C)`` view stack as ``v_{l:03d}_{k:03d}.png`` plus ``views.json``.

    A views folder holds one render: ``views.json`` (the manifest) is removed
    first and written last, and the views of an earlier render that this one
    does not overwrite (another PPL) are removed, so an interrupted write leaves
    a folder without a manifest, never a manifest over mixed views.
    """
    folder = check_views_dir(views_dir)
    ny, nx = views.shape[:2]
    manifest = folder / "views.json"
    try:
        manifest.unlink(missing_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot replace {str(manifest)!r}: {exc.strerror}") from None
    for l in range(ny):
        for k in range(nx):
            write_png(folder / VIEW_NAME.format(l=l, k=k), views[l, k])
    for (l, k), path in _view_files(folder).items():
        if l >= ny or k >= nx:
            path.unlink(missing_ok=True)
    record = base_record("views", lens_array, views=[nx, ny], view_size_px=[views.shape[3], views.shape[2]],
                         source=source or {})
    with atomic_path(manifest) as tmp:
        tmp.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")


def _view_files(folder: Path) -> dict[tuple[int, int], Path]:
    found = {}
    for p in folder.iterdir():
        m = _VIEW_RE.match(p.name)
        if m:
            found[(int(m.group(1)), int(m.group(2)))] = p
    return found


def read_views(views_dir: str | Path) -> np.ndarray:
    """Read ``v_{l}_{k}.png`` files into a ``(Ny, Nx, Ly, Lx, C)`` stack; every view must be there."""
    folder = Path(views_dir)
    if not folder.is_dir():
        raise InputError(f"views folder {str(folder)!r} does not exist; check the path")
    found = _view_files(folder)
    if not found:
        raise InputError(f"no view images (v_LLL_KKK.png) in {str(folder)!r}; render with --views-dir first")
    ny = max(l for l, _ in found) + 1
    nx = max(k for _, k in found) + 1
    absent = [(l, k) for l in range(ny) for k in range(nx) if (l, k) not in found]
    if absent:
        l, k = absent[0]
        raise InputError(f"{len(absent)} views missing in {str(folder)!r}, first {VIEW_NAME.format(l=l, k=k)}; "
                         "the stack must be a full Ny x Nx grid")
    manifest = read_sidecar(folder / "views.json") or {}
    grid = manifest.get("views")
    if grid is not None and list(grid) != [nx, ny]:
        raise InputError(f"{str(folder)!r} holds {nx}x{ny} views but its views.json describes {grid[0]}x{grid[1]}: "
                         "views of two renders are mixed; render again into an empty folder")
    images = [read_png(found[(l, k)]) for l in range(ny) for k in range(nx)]
    shapes = {img.shape for img in images}
    if len(shapes) != 1:
        raise InputError(f"the views in {str(folder)!r} differ in size or channels: {sorted(shapes)}")
    size = manifest.get("view_size_px")
    if size is not None and images and list(size) != to_edge(images[0].shape[:2]):
        raise InputError(f"the views in {str(folder)!r} are {images[0].shape[1]}x{images[0].shape[0]} but views.json "
                         f"describes {size[0]}x{size[1]}; render again into an empty folder")
    dtypes = {img.dtype for img in images}
    if len(dtypes) != 1:
        raise InputError(f"the views in {str(folder)!r} mix 8-bit and 16-bit images")
    return np.stack(images).reshape(ny, nx, *images[0].shape)


def interleave_dir(views_dir: str | Path, output: str | Path) -> dict[str, Any]:
    """Interleave a folder of views into an H3D PNG with its sidecar."""
    views = read_views(views_dir)
    output = png_output(output)
    h3d = interleave(views)
    source = read_sidecar(Path(views_dir) / "views.json") or {}
    record = base_record("h3d", None, method="interleave", views=to_edge(views.shape[:2]),
                      views_dir=str(Path(views_dir).resolve()), size_px=to_edge(h3d.shape[:2]),
                      output_gamma="sRGB")
    if source.get("lens_array"):
        record["lens_array"] = source["lens_array"]
    write_image(output, h3d, record)
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
    write_views(views_dir, views, None, {"h3d": str(Path(h3d_path).resolve())})
    return {"views": to_edge(ppl), "view_size_px": to_edge(views.shape[2:4])}


def sidecar_array(h3d: np.ndarray, h3d_path: str | Path, record: dict[str, Any] | None = None) -> LensArray:
    """The lens array of an H3D image's sidecar (``record``, else read), checked against the image's size."""
    record = read_sidecar(h3d_path) if record is None else record
    if not record or "lens_array" not in record:
        raise ConfigError(f"{str(h3d_path)!r} has no sidecar with its lens array; give --ppl NxxNy")
    lens_array = Display.from_record(record).lens_array
    if h3d.shape[:2] != (lens_array.panel.height, lens_array.panel.width):
        raise InputError(f"{str(h3d_path)!r} is {h3d.shape[1]}x{h3d.shape[0]} but its sidecar describes a "
                         f"{lens_array.panel.width}x{lens_array.panel.height} panel; re-render it")
    return lens_array


def sidecar_bank(h3d: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """``(Ny, Nx, Ly, Lx, C)`` views of an image of ``lens_array``: the camera bank's region
    (an array narrower than its panel, e.g. 341 lenses of 6 px on 2048 px), or each lens
    resampled at the view offsets on a hex or fractional-PPL array."""
    if lens_array.views is None:
        return extract_views(h3d, lens_array, view_grid(lens_array))
    return extract(h3d[lens_array.bank_region], lens_array.views)


def h3d_views(h3d: np.ndarray, record: dict[str, Any], h3d_path: str | Path) -> tuple[np.ndarray, str]:
    """The ``(Ny, Nx, Ly, Lx, C)`` views of an H3D image through its sidecar's lens array, and its grid."""
    lens_array = sidecar_array(h3d, h3d_path, record)
    return sidecar_bank(h3d, lens_array), lens_array.grid


def _extract_resampled(h3d: np.ndarray, h3d_path: str | Path, views_dir: str | Path) -> dict[str, Any]:
    lens_array = sidecar_array(h3d, h3d_path)
    views = sidecar_bank(h3d, lens_array)
    ny, nx = views.shape[:2]
    source = {"h3d": str(Path(h3d_path).resolve()), "resampled": lens_array.views is None,
              "lens_centres_mm": lens_array.lens_centres().reshape(-1, 2).tolist()}
    write_views(views_dir, views, lens_array, source)
    return {"views": [nx, ny], "view_size_px": [views.shape[3], views.shape[2]]}
