"""``render --objects DIR``: the id of the object each pixel's ray first hits, in every view of
every frame.

One more render of the same request, on the mask copy of the scene (``scene.object_ids``):
point-sampled (draft), 16 bits, the same display, method and rays; its views decoded to ids and
written with their names (``app.objects``)."""

from __future__ import annotations

import dataclasses
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

from ..errors import ConfigError, InputError
from ..scene.object_ids import UNRESOLVED, MaskScene, mask_scene
from .objects import ObjectTable, write_masks
from .request import ModelOptions, RenderRequest, VolumeOptions


def check_objects_request(request: RenderRequest) -> MaskScene | None:
    """Refuse, before any work, what the masks cannot be made for; return the mask copy of a scene
    (None for a model or a volume: its parts are known once it is converted)."""
    if request.is_model:
        if request.volume.volume:
            raise ConfigError("a volume drawn as a medium (--volume) has no surfaces to tell apart; render the "
                              "masks of its --labels or --iso surfaces")
    elif request.source.suffix.lower() != ".pov":
        raise ConfigError(f"render --objects takes a POV-Ray scene (.pov), a model or a volume, not "
                          f"{request.source.name!r}")
    if request.display.lens_array.views is None:
        # views pulled from such an image are resampled (bilinear): two ids would blend into a third
        raise ConfigError("render --objects needs whole pixels per lens on a square or lenticular grid in this "
                          "version (hex and fractional-PPL views are resampled); render the masks on such a grid")
    if request.is_model:
        return None
    try:
        text = request.source.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the scene {str(request.source)!r} ({exc})") from None
    return mask_scene(text)


def staged_mask(request: RenderRequest, folder: Path) -> tuple[Path, dict[int, str]]:
    """The mask copy of a model's or a volume's stage written into ``folder``: its include with every
    part its own id (``scene.part_ids``), named after the parts (OBJ objects and groups, glTF nodes,
    3MF objects) or the surfaces (the label table's names, ``label N``, ``iso V``).  The model is
    staged as for the colour pass (from the cache): the same include, the same placement."""
    import warnings

    from ..scene.part_ids import part_ids_include, part_table
    from .render import load_content

    with warnings.catch_warnings():      # the colour pass has said them
        warnings.simplefilter("ignore")
        scene, record = load_content(request)
    stage = scene.path.read_text(encoding="utf-8")
    found = re.search(r'#include\s+"([^"]+)"', stage)
    if found is None or record is None:
        raise RuntimeError(f"the stage {str(scene.path)!r} includes no converted model")   # a bug
    names = [row["name"] for row in record["surfaces"]] if "surfaces" in record else record["parts"]
    table = part_table(names)
    include = (scene.path.parent / found[1]).read_text(encoding="utf-8")
    (folder / "parts.inc").write_text(part_ids_include(include, len(table)), encoding="utf-8")
    path = folder / "stage.pov"
    path.write_text(mask_scene(stage.replace(found[0], '#include "parts.inc"')).text, encoding="utf-8")
    return path, table


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
        if mask is None:
            scene, names = staged_mask(request, work)
        else:
            scene, names = work / request.source.name, mask.names
            scene.write_text(mask.text, encoding="utf-8")
        settings = dataclasses.replace(request.settings, quality="draft", bit_depth=16)
        still = request.frames is None
        masked = dataclasses.replace(request, source=scene, output=work / "mask.png",
                                     views_dir=work / "views" if still else None, depth_maps=None, video=None,
                                     settings=settings, model=ModelOptions(), volume=VolumeOptions(),
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
            masks[n] = decode_ids(views.reshape(ny * nx * ly, lx, -1), len(names)).reshape(ny, nx, ly, lx)
        table = ObjectTable(names, tuple(sorted(masks)), (ny, nx), (ly, lx))
        write_masks(out, table, masks)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    _note_in_sidecars(request, out, table)
    unresolved = sum(int((m == UNRESOLVED).sum()) for m in masks.values()) / sum(m.size for m in masks.values())
    return {"objects": len(names), "frames": len(masks), "unresolved": unresolved, "folder": str(out)}


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
