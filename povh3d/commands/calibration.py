"""File-level calibration commands: read images and grids, write results with sidecars.

What the CLI calls; the image work itself is pure (the other modules here).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, param
from ..image.io import atomic_path, check_output, check_output_folder, read_png, with_sidecar
from ..image.sidecar import Sidecar
from ..renderer.records import base_record, png_output, write_image
from ..calibration.borders import correct_borders
from ..calibration.distortion import undistort_image
from ..calibration.equalise import equalise
from ..calibration.gridfile import Grid, read_grid, write_grid
from ..calibration.lattice import calibrate
from ..calibration.lenticular import calibrate_lenticular
from ..calibration.stitch import stitch
from ..calibration.viewpoints import viewpoints


def _record(kind: str, grid_path: str | Path | None, **extra: object) -> Sidecar:
    grid = {} if grid_path is None else {"grid": str(Path(grid_path).resolve())}
    return base_record(kind, None, **grid, **extra)


def _json_path(path: str | Path) -> None:
    if Path(path).suffix.lower() != ".json":
        raise ConfigError(f"the grid file {str(path)!r} must end in .json")


def calibrate_file(white: str | Path, output: str | Path, *, lattice: str | None = None,
                   distortion: bool = True) -> Grid:
    _json_path(output)
    check_output(output, with_sidecar(white), what="grid file", sidecar=False)
    image = read_png(white)
    t = time.perf_counter()
    grid = calibrate(image, lattice=lattice, distortion=distortion, name=repr(str(white)))
    grid.extra["seconds"] = round(time.perf_counter() - t, 3)
    grid.extra["white_image"] = str(Path(white).resolve())
    write_grid(output, grid)
    return grid


def calibrate_lenticular_file(white: str | Path, output: str | Path, *, dpi: float | None = None,
                              distortion: bool = True) -> dict[str, Any]:
    """Pitch, slant and phase of a lenticular sheet -> a calibration JSON (with the Looking
    Glass fields when ``dpi`` is given, which ``map --calibration`` reads)."""
    _json_path(output)
    if dpi is not None and not (np.isfinite(dpi) and dpi > 0):
        raise ConfigError(f"{param('dpi')} must be a positive number of pixels per inch, got {dpi!r}")
    check_output(output, with_sidecar(white), what="grid file", sidecar=False)
    image = read_png(white)
    t = time.perf_counter()
    fit = calibrate_lenticular(image, distortion=distortion, name=repr(str(white)))
    record = {**fit.as_record(), **_looking_glass_fields(fit, dpi), "seconds": round(time.perf_counter() - t, 3),
              "white_image": str(Path(white).resolve())}
    with atomic_path(output) as tmp:
        tmp.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    return record


def _looking_glass_fields(fit: Any, dpi: float | None) -> dict[str, Any]:
    """The sheet's Looking Glass fields written the vendor's way, every number ``{"value": x}``
    (``display.looking_glass.visual_fields``); none without ``dpi`` or for an unslanted sheet.
    A white image measures no view cone, so none is written (a reader would take a default)."""
    if dpi is None or fit.slant_deg == 0:
        return {}
    from ..display.looking_glass import parse_visual, visual_fields

    fields = visual_fields(parse_visual(fit.looking_glass(dpi)))
    for unmeasured in ("viewCone", "serial", "verticalAngle", "flipSubp", "fringe"):
        fields.pop(unmeasured, None)
    return fields


def _load(image_path: str | Path, grid_path: str | Path) -> tuple[np.ndarray, Grid]:
    image = read_png(image_path)
    grid = read_grid(grid_path)
    grid.check_image(image.shape, repr(str(image_path)))
    return image, grid


def undistort_file(image_path, grid_path, output) -> dict[str, Any]:
    output = png_output(output, inputs=(*with_sidecar(image_path), grid_path))
    image, grid = _load(image_path, grid_path)
    record = _record("undistorted", grid_path, source=str(Path(image_path).resolve()),
                     distortion=grid.distortion.as_record(), output_gamma="sRGB")
    write_image(output, undistort_image(image, grid.distortion), record)
    return record.to_json()


def borders_file(image_path, grid_path, output, *, threshold: float = 0.5, fill: str = "black") -> dict[str, Any]:
    output = png_output(output, inputs=(*with_sidecar(image_path), grid_path))
    image, grid = _load(image_path, grid_path)
    out, border = correct_borders(image, grid, threshold=threshold, fill=fill)
    record = _record("border-corrected", grid_path, source=str(Path(image_path).resolve()), threshold=threshold,
                     fill=fill, border_fraction=round(float(border.mean()), 6), output_gamma="sRGB")
    write_image(output, out, record)
    return record.to_json()


def equalise_file(image_path, grid_path, output, *, size: int | None = None) -> dict[str, Any]:
    output = png_output(output, inputs=(*with_sidecar(image_path), grid_path))
    image, grid = _load(image_path, grid_path)
    out, used = equalise(image, grid, size)
    record = _record("equalised", grid_path, source=str(Path(image_path).resolve()), ppl=[used, used],
                     lenses=[grid.table[1], grid.table[0]], output_gamma="sRGB")
    write_image(output, out, record)
    return record.to_json()


def viewpoints_file(image_path, grid_path, views_dir, *, ppl: int) -> dict[str, Any]:
    from ..renderer.outputs.views import write_views

    from ..renderer.outputs.views import check_views_dir

    check_output_folder(views_dir, (*with_sidecar(image_path), grid_path), what="views folder")
    check_views_dir(views_dir)
    image, grid = _load(image_path, grid_path)
    views = viewpoints(image, grid, ppl)
    write_views(views_dir, views, None, _record("capture", grid_path, source=str(Path(image_path).resolve())))
    return {"views": [ppl, ppl], "view_size_px": [views.shape[3], views.shape[2]]}


def stitch_files(a_path, b_path, grid_path, output) -> dict[str, Any]:
    output = png_output(output, inputs=(*with_sidecar(a_path), *with_sidecar(b_path), grid_path))
    a, grid = _load(a_path, grid_path)
    b = read_png(b_path)
    grid.check_image(b.shape, repr(str(b_path)))
    out, shift, mode = stitch(a, b, grid)
    record = _record("stitched", grid_path, sources=[str(Path(a_path).resolve()), str(Path(b_path).resolve())],
                     shift_lenses={"rows": shift.di, "cols": shift.dj}, mismatch=round(shift.mismatch, 6),
                     mode=mode, size_px=[out.shape[1], out.shape[0]], output_gamma="sRGB")
    write_image(output, out, record)
    return record.to_json()
