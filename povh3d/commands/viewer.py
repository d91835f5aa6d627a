"""``povh3d viewer``: a render's views written as one self-contained HTML page.

A render is a views folder (``v_LLL_KKK.png`` with ``views.json``), an H3D image
with its sidecar (the views are pulled from it through its lens array), or an
animation's frames (``OUT_nnnn.png``, named by any frame or by ``OUT.png``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import InputError, param
from ..image.io import atomic_path, check_output, read_png, read_sidecar_record, with_sidecar
from ..image.sidecar import Sidecar
from ..renderer.outputs.views import h3d_views, read_views

_FRAME_RE = re.compile(r"^(?P<stem>.+)_(?P<n>\d{4,})$")


@dataclass(frozen=True)
class RenderViews:
    """The views of a render: one ``(Ny, Nx, Ly, Lx, C)`` stack per frame."""

    frames: tuple[np.ndarray, ...]
    numbers: tuple[int, ...]            # the animation frame numbers (0 for a still)
    grid: str
    images: tuple[Path, ...]            # the H3D images (empty for a views folder)
    records: tuple[Sidecar, ...]  # their sidecars
    pixel_aspect: float = 1.0           # a view pixel's width over height on the display (view_pixel_aspect)


def view_pixel_aspect(lens_array: object) -> float:
    """Width over height of a view's pixel on the display, from a sidecar's lens array: each view
    pixel is one lens, ``pixel_distance_3d_mm`` (the lens pitches) apart; 1 when it is not known."""
    side: Any = lens_array if isinstance(lens_array, Mapping) else {}
    pitch: Any = side.get("pixel_distance_3d_mm") or side.get("lens_pitch_mm")
    try:
        aspect = float(pitch[0]) / float(pitch[1])
    except (TypeError, ValueError, IndexError, ZeroDivisionError):
        return 1.0
    return aspect if 1e-3 <= aspect <= 1e3 else 1.0


def frame_files(render: str | Path) -> list[tuple[int, Path]]:
    """The H3D images a render names: one still, or every frame of its animation, in order."""
    path = Path(render)
    if path.is_file():
        record = read_sidecar_record(path)
        match = _FRAME_RE.match(path.stem)
        if record is None or record.animation is None or not match:
            return [(0, path)]
        stem = match["stem"]
    else:
        stem = path.stem
    pattern = re.compile(rf"^{re.escape(stem)}_(\d{{4,}}){re.escape(path.suffix or '.png')}$")
    folder = path.parent
    found = sorted((int(m[1]), p) for p in (folder.iterdir() if folder.is_dir() else ())
                   if (m := pattern.match(p.name)))
    if not found:
        raise InputError(f"{str(path)!r} is neither an H3D image, a views folder nor an animation's "
                         f"frames ({stem}_NNNN.png); check the path")
    return found


def read_render_views(render: str | Path) -> RenderViews:
    """Read the views of a render (see the module docstring for what a render is)."""
    path = Path(render)
    if path.is_dir():
        manifest = read_sidecar_record(path / "views.json")
        lens_array = manifest.lens_array if manifest is not None else None
        grid = lens_array.grid if lens_array is not None else "square"
        return RenderViews((read_views(path),), (0,), grid, (), (),
                           view_pixel_aspect(lens_array.to_json() if lens_array is not None else None))
    frames, numbers, images, records, grids = [], [], [], [], set()
    for n, image_path in frame_files(path):
        record = read_sidecar_record(image_path)
        if record is None or record.lens_array is None:
            raise InputError(f"{str(image_path)!r} has no sidecar with its lens array; give its views folder "
                             f"(render {param('views_dir')}) instead")
        views, grid = h3d_views(read_png(image_path), record, image_path)
        frames.append(views)
        numbers.append(n)
        images.append(image_path)
        records.append(record)
        grids.add(grid)
    shapes = {f.shape for f in frames}
    if len(shapes) != 1 or len(grids) != 1:
        raise InputError(f"the frames of {str(path)!r} differ in lens array or size; render the animation again")
    return RenderViews(tuple(frames), tuple(numbers), grids.pop(), tuple(images), tuple(records),
                       view_pixel_aspect(records[0].get("lens_array")))


def write_viewer(render: str | Path, output: str | Path, *, fps: float = 12.0, cdp: str | None = None,
                 title: str | None = None, objects: str | Path | None = None,
                 reads: tuple[str | Path, ...] = ()) -> dict[str, Any]:
    """Write the viewer page of ``render`` to ``output`` (atomically); ``cdp`` is a 3DCDP header's text,
    ``objects`` the object masks folder that gives every view its own boxes; ``reads``: other files the
    command read (the header's), which ``output`` must not be."""
    from ..hyper.page import ViewerContent, viewer_html

    output = Path(output)
    if output.suffix.lower() not in (".html", ".htm"):
        raise InputError(f"the viewer is an HTML page: name it .html, got {str(output)!r}")
    check_output(output, (*with_sidecar(render), *reads), what="viewer page", sidecar=False)
    rendered = read_render_views(render)
    if cdp is not None:
        _check_header(cdp, rendered)
    view_boxes = _view_boxes(objects, rendered) if objects is not None else None
    content = ViewerContent(rendered.frames, grid=rendered.grid, fps=fps, cdp=cdp, numbers=rendered.numbers,
                            view_boxes=view_boxes, title=title or f"povh3d: {Path(render).name}",
                            pixel_aspect=rendered.pixel_aspect)
    text = viewer_html(content)
    with atomic_path(output) as tmp:
        tmp.write_text(text, encoding="utf-8")
    ny, nx = content.views
    return {"output": str(output), "frames": len(rendered.frames), "views": [nx, ny],
            "view_size_px": [content.view_size[1], content.view_size[0]], "bytes": len(text.encode())}


def _check_header(cdp: str, rendered: RenderViews) -> None:
    """A header made for another render (views, view size, frames) is refused, not drawn wrongly."""
    from ..hyper.cdp import from_xml

    header = from_xml(cdp.encode("utf-8"))
    ny, nx, ly, lx = rendered.frames[0].shape[:4]
    frames = set(rendered.numbers)
    stray = sorted({b.frame for s in header.scenes for a in s.annotations for b in a.boxes} - frames)
    if header.views != (nx, ny) or header.view_size != (lx, ly) or stray:
        raise InputError(f"the 3DCDP header describes {header.views[0]}x{header.views[1]} views of "
                         f"{header.view_size[0]}x{header.view_size[1]}"
                         + (f" and frame {stray[0]}" if stray else "")
                         + f" but the render has {nx}x{ny} of {lx}x{ly}, frames {min(frames)}..{max(frames)}; "
                         "annotate this render")


def _view_boxes(objects: str | Path, rendered: RenderViews) -> tuple[Any, ...]:
    """Per frame, view row and column, the boxes of the objects the masks show there."""
    from ..hyper.boxes import mask_boxes
    from ..renderer.outputs.objects import read_mask, read_table

    table = read_table(objects)
    ny, nx, ly, lx = rendered.frames[0].shape[:4]
    if table.frames != rendered.numbers or table.views != (ny, nx) or table.view_size != (ly, lx):
        raise InputError(f"the object masks in {str(objects)!r} are of another render (frames, views or size "
                         f"differ); render {param('objects')} with the same options")
    return tuple([[mask_boxes(read_mask(objects, table, n, (l, k))) for k in range(nx)] for l in range(ny)]
                 for n in rendered.numbers)
