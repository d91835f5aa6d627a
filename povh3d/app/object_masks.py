"""``render --objects DIR``: the id of the object each pixel's ray first hits, in every view.

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
    if request.frames is not None:
        raise ConfigError("render --objects makes the masks of a still in this version; drop --frames")
    try:
        text = request.source.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the scene {str(request.source)!r} ({exc})") from None
    return mask_scene(text)


def render_objects(request: RenderRequest, folder: str | Path) -> dict[str, Any]:
    """Render the object masks of ``request``'s still into ``folder``; return what was written."""
    from ..hyper.ids import decode_ids
    from .render import render
    from .views import read_views

    mask = check_objects_request(request)
    out = Path(folder)
    work = Path(tempfile.mkdtemp(prefix=".povh3d-objects-", dir=out.parent if str(out.parent) else "."))
    try:
        scene = work / request.source.name
        scene.write_text(mask.text, encoding="utf-8")
        settings = dataclasses.replace(request.settings, quality="draft", bit_depth=16)
        masked = dataclasses.replace(request, source=scene, output=work / "mask.png", views_dir=work / "views",
                                     depth_maps=None, video=None, settings=settings,
                                     include_dirs=(request.source.resolve().parent, *request.include_dirs))
        render(masked)
        views = read_views(work / "views")
        ny, nx, ly, lx = views.shape[:4]
        ids = decode_ids(views.reshape(ny * nx * ly, lx, -1), len(mask.names)).reshape(ny, nx, ly, lx)
        write_masks(out, ObjectTable(mask.names, (0,), (ny, nx), (ly, lx)), {0: ids})
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {"objects": len(mask.names), "unresolved": float((ids == UNRESOLVED).mean()), "folder": str(out)}
