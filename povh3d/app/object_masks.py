"""``render --objects DIR``: the id of the object each pixel's ray first hits, in every view of
every frame.

One more render of the same request, on the mask copy of the scene (``scene.object_ids``):
point-sampled (draft), 16 bits, the same display, method and rays; its views decoded to ids and
written with their names (``app.objects``)."""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
from pathlib import Path
from typing import Any

from ..errors import ConfigError, InputError
from ..scene.object_ids import UNRESOLVED, mask_scene
from .objects import ObjectTable, write_masks
from .request import RenderRequest


def check_objects_request(request: RenderRequest) -> Any:
    """Refuse, before any work, what the masks cannot be made for; return the mask copy."""
    if request.source.suffix.lower() != ".pov":
        raise ConfigError("render --objects takes a POV-Ray scene (.pov) in this version; models and volumes "
                          "are not yet split into objects")
    if request.display.lens_array.views is None:
        # views pulled from such an image are resampled (bilinear): two ids would blend into a third
        raise ConfigError("render --objects needs whole pixels per lens on a square or lenticular grid in this "
                          "version (hex and fractional-PPL views are resampled); render the masks on such a grid")
    try:
        text = request.source.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the scene {str(request.source)!r} ({exc})") from None
    return mask_scene(text)


def render_objects(request: RenderRequest, folder: str | Path) -> dict[str, Any]:
    """Render the object masks of ``request``'s still into ``folder``; return what was written."""
    from ..hyper.ids import decode_ids
    from .render import render
    from ..image.io import read_png, read_sidecar
    from .views import h3d_views, read_views

    mask = check_objects_request(request)
    out = Path(folder)
    work = Path(tempfile.mkdtemp(prefix=".povh3d-objects-", dir=out.parent if str(out.parent) else "."))
    try:
        scene = work / request.source.name
        scene.write_text(mask.text, encoding="utf-8")
        settings = dataclasses.replace(request.settings, quality="draft", bit_depth=16)
        still = request.frames is None
        masked = dataclasses.replace(request, source=scene, output=work / "mask.png",
                                     views_dir=work / "views" if still else None, depth_maps=None, video=None,
                                     settings=settings,
                                     include_dirs=(request.source.resolve().parent, *request.include_dirs))
        report = render(masked)
        if still:
            stacks = {0: read_views(work / "views")}
        else:   # an animation's views: pulled from each frame's image as 'povh3d extract' does
            stacks = {}
            for name in report["frames"]:
                record = read_sidecar(name)
                stacks[int(record["animation"]["frame"])] = h3d_views(read_png(name), record, name)[0]
        masks = {}
        for n, views in stacks.items():
            ny, nx, ly, lx = views.shape[:4]
            masks[n] = decode_ids(views.reshape(ny * nx * ly, lx, -1), len(mask.names)).reshape(ny, nx, ly, lx)
        table = ObjectTable(mask.names, tuple(sorted(masks)), (ny, nx), (ly, lx))
        write_masks(out, table, masks)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    _note_in_sidecars(request, out, table)
    unresolved = sum(int((m == UNRESOLVED).sum()) for m in masks.values()) / sum(m.size for m in masks.values())
    return {"objects": len(mask.names), "frames": len(masks), "unresolved": unresolved, "folder": str(out)}


def _note_in_sidecars(request: RenderRequest, folder: Path, table: ObjectTable) -> None:
    """The render's own sidecars name the masks folder and the ids' names (the table's copy)."""
    from ..image.io import read_sidecar, write_sidecar
    from .animation import frame_path

    if request.frames is None:
        images = [request.output]
    else:
        digits = max(4, len(str(request.frames.last)))
        images = [frame_path(request.output, n, digits) for n in request.frames.numbers]
    note = {"folder": str(folder.resolve()), "names": {str(i): n for i, n in sorted(table.names.items())}}
    for image in images:
        record = read_sidecar(image)
        if record is not None:
            write_sidecar(image, {**record, "objects": note})
