"""``render --objects DIR``: the id of the object each pixel's ray first hits, in every view of
every frame.

One more render of the same request, on the mask copy of the scene (``scene.object_ids``) or of
a model's or volume's stage (``staged_mask``): point-sampled (draft), 8 bits, the same display,
method and rays; its views decoded to ids and written with their names (``renderer.outputs.objects``).  A
still's panel stays in memory (``_trace_still``); an animation's frames go through ``renderer.render``.
On a hex or fractional-PPL array the panel's pixels are decoded (each its own ray, as in the
colour pass) and the views picked from them, the nearest pixel of each lens, never blended."""

from __future__ import annotations

import dataclasses
import re
import shutil
import tempfile
import warnings
from pathlib import Path
from collections.abc import Mapping

import numpy as np

from ...errors import ConfigError, InputError, Povh3dWarning, param
from ...image.sidecar import Sidecar
from ...jsontext import JSONValue
from ...geometry.lens_array import LensArray
from ...scene.object_ids import UNRESOLVED, MaskScene, mask_scene
from ..outputs.objects import ObjectTable, write_masks
from ..placement.pose import PlacementOptions, recorded_pose
from ..request import ModelOptions, RenderRequest, VolumeOptions


def check_objects_request(request: RenderRequest, folder: str | Path | None = None) -> MaskScene | None:
    """Refuse, before any work, what the masks cannot be made for, and a ``folder`` (``--objects``) that is
    not new, empty or povh3d's masks, or holds what the render reads (``outputs.objects.check_objects_dir``);
    return the mask copy of a scene (None for a model or a volume: its parts are known once it is converted)."""
    if folder is not None:
        from ...scene.scene import load_scene
        from ..outputs.objects import check_objects_dir

        reads = (request.source,) if request.is_model else load_scene(request.source, request.include_dirs).files
        check_objects_dir(folder, (request.source, *reads))
    if request.is_model:
        if request.volume.volume:
            raise ConfigError(f"a volume drawn as a medium ({param('volume')}) has no surfaces to tell apart; render the "
                              f"masks of its {param('labels')} or {param('iso')} surfaces")
    elif request.source.suffix.lower() != ".pov":
        raise ConfigError(f"render {param('objects')} takes a POV-Ray scene (.pov), a model or a volume, not "
                          f"{request.source.name!r}")
    if (request.display.quilt or {}).get("camera_model") == "perspective":
        raise ConfigError("the object masks trace the lens array's rays, not the vendor's perspective cameras; "
                          f"add {param('camera_model')} orthographic for a Looking Glass render with masks")
    if request.method == "subpixel":
        raise ConfigError(f"{param('method')} subpixel traces each colour channel of a pixel along its own ray, so a pixel "
                          f"has no one object id; render the masks with {param('method')} multi-ortho")
    if request.display.mapping is not None and (request.frames is not None or request.render_array.views is None):
        # the image written is the mapped panel: its pixels mix views, and only a still's views are kept whole
        raise ConfigError("the object masks of a mapped display come from the views of a still; render one "
                          f"frame (no {param('frames')}) for them")
    if request.is_model:
        return None
    try:
        text = request.source.read_text(encoding="utf-8").removeprefix("\ufeff")  # a BOM: POV-Ray skips it
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the scene {str(request.source)!r} ({exc})") from None
    return mask_scene(text)


def staged_mask(request: RenderRequest, folder: Path) -> tuple[Path, dict[int, str]]:
    """The mask copy of a model's or a volume's stage written into ``folder``: its include with every
    part its own id (``scene.part_ids``), named after the parts (OBJ objects and groups, glTF nodes,
    3MF objects) or the surfaces (the label table's names, ``label N``, ``iso V``).  The model is
    staged as for the colour pass (from the cache): the same include, the same placement."""
    import warnings

    from ...scene.part_ids import part_ids_include, part_table
    from ..render import load_content

    with warnings.catch_warnings():      # the colour pass has said them
        warnings.simplefilter("ignore")
        scene, record = load_content(request)
    stage = scene.path.read_text(encoding="utf-8")
    found = re.search(r'#include\s+"([^"]+)"', stage)
    if found is None or record is None:
        raise RuntimeError(f"the stage {str(scene.path)!r} includes no converted model")   # a bug
    rows, parts = record.get("surfaces"), record.get("parts")
    names = ([str(row["name"]) for row in rows if isinstance(row, Mapping)] if isinstance(rows, list)
             else [str(p) for p in parts] if isinstance(parts, list) else [])
    table = part_table(names)
    include = (scene.path.parent / found[1]).read_text(encoding="utf-8")
    (folder / "parts.inc").write_text(part_ids_include(include, len(table)), encoding="utf-8")
    path = folder / "stage.pov"
    path.write_text(mask_scene(stage.replace(found[0], '#include "parts.inc"')).text, encoding="utf-8")
    return path, table


def render_objects(request: RenderRequest, folder: str | Path,
                   colour: Mapping[str, JSONValue] | None = None) -> dict[str, JSONValue]:
    """Render the object masks of ``request``'s still or frames into ``folder``; return what was
    written.  ``colour``: the colour pass's record (a still's sidecar, an animation's report), whose method
    the masks trace (the default may have fallen back) and whose placement a still's take as it is (no
    camera or depth run again); None: the mask copy settles its own."""
    from ...hyper.ids import decode_ids
    from ..render import render
    from ...image.io import read_png

    mask = check_objects_request(request)
    out = Path(folder)
    work = Path(tempfile.mkdtemp(prefix=".povh3d-objects-", dir=out.parent if str(out.parent) else "."))
    try:
        if mask is None:
            scene, names = staged_mask(request, work)
        else:
            scene, names = work / request.source.name, mask.names
            scene.write_text(mask.text, encoding="utf-8")
        # 8 bits: the ids' codes are whole 8-bit sRGB codes (scene.object_ids), which Pillow reads fast
        settings = dataclasses.replace(request.settings, quality="draft", bit_depth=8)
        array = request.render_array
        masked = dataclasses.replace(request, source=scene, output=work / "mask.png", views_dir=None,
                                     depth_maps=None, dataset=None, video=None, objects=None, settings=settings,
                                     model=ModelOptions(), volume=VolumeOptions(),
                                     include_dirs=(request.source.resolve().parent, *request.include_dirs),
                                     # a stage is in display mm, as its colour pass knew (renderer.placement.place): no
                                     # camera to look for in the model's include
                                     placement=request.placement if mask else PlacementOptions("native"))
        traced = _colour_pass(request, colour)
        masked = _method_as(masked, traced)
        with warnings.catch_warnings():   # the colour pass has said what its method sees of the scene
            warnings.filterwarnings("ignore", message=_SAID, category=Povh3dWarning)
            if request.frames is None:   # a still: its panel kept in memory, no image, sidecar or views written
                images = {0: _trace_still(_placed_as(masked, traced), settle=traced is None)}
            else:                        # each frame's panel (the lens mesh's rays, point-sampled)
                report = render(masked)
                images = {_frame_number(name): read_png(name) for name in _frame_names(report)}
        masks, panels = {}, {}
        for n, h3d in images.items():
            ids = decode_ids(h3d, len(names))
            masks[n] = mask_views(ids, array)
            if array.views is None:
                panels[n] = ids
        ny, nx, ly, lx = next(iter(masks.values())).shape
        import secrets
        table = ObjectTable(names, tuple(sorted(masks)), (ny, nx), (ly, lx),
                            (array.panel.height, array.panel.width) if panels else None, secrets.token_hex(8))
        write_masks(out, table, masks, panels)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    _note_in_sidecars(request, out, table)
    unresolved = sum(int((m == UNRESOLVED).sum()) for m in masks.values()) / sum(m.size for m in masks.values())
    return {"objects": len(names), "frames": len(masks), "unresolved": unresolved, "folder": str(out)}


#: The warning of a scene that reads image_width rendered with ``ray_state.FALLBACK``: the colour pass's.
_SAID = r".* uses image_width or image_height other than as their ratio"


def _frame_names(report: Mapping[str, JSONValue]) -> list[str]:
    """An animation report's frames (``renderer.animation.render_sequence``)."""
    frames = report.get("frames")
    return [str(name) for name in frames] if isinstance(frames, list) else []


def _frame_number(name: str) -> int:
    """The animation frame whose image is ``name``, as its sidecar says (written by this render)."""
    from ...image.io import read_sidecar_record

    side = read_sidecar_record(name)
    if side is None or side.animation is None:   # a bug: render_sequence writes it
        raise RuntimeError(f"the frame {name!r} has no sidecar with its animation entry")
    return side.animation.frame


def _colour_pass(request: RenderRequest, colour: Mapping[str, JSONValue] | None) -> Sidecar | None:
    """The colour pass's record: a still's sidecar, or an animation's first frame's (its frames share
    one method: ``renderer.render`` settles it once); None: not known."""
    from ...image.io import read_sidecar_record

    if colour is not None and request.frames is not None:
        names = _frame_names(colour)
        return read_sidecar_record(names[0]) if names else None
    return None if colour is None else Sidecar.from_json(colour)


def _method_as(masked: RenderRequest, colour: Sidecar | None) -> RenderRequest:
    """``masked`` traced with the method the colour pass used: the default may have fallen back to
    ``ray_state.FALLBACK`` (the sidecar's ``method_note``), and a scene that reads ``image_width``
    builds other geometry in a mesh-camera run than in each view's own."""
    method = colour.method if colour is not None else None
    if method is None or method == masked.method:
        return masked
    # as ``ray_state.settle_method`` trades it; chosen, so that the mask pass trades nothing again
    return dataclasses.replace(masked, method=method, method_options={}, method_chosen=True)


def _placed_as(masked: RenderRequest, colour: Sidecar | None) -> RenderRequest:
    """``masked`` with the colour pass's pose, front clearance and depth scale as settings (the
    Python API's matrix path of ``renderer.placement.place``): the same rays without evaluating the scene's
    camera or measuring its depth again (a POV-Ray run each)."""
    placement_record = colour.placement.to_json() if colour is not None and colour.placement is not None else {}
    quality = colour.quality if colour is not None else None
    clearance = quality.front_clearance_mm if quality is not None else None
    pose = recorded_pose(placement_record) if placement_record and clearance is not None else None
    if pose is None or clearance is None or masked.is_model:   # native or staged in mm: placed without a POV-Ray run
        return masked
    settings = dataclasses.replace(masked.settings, pose=pose, front_clearance=float(clearance),
                                   depth_scale=_number(placement_record.get("depth_scale", 1.0)))
    return dataclasses.replace(masked, settings=settings)


def _number(value: JSONValue) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):  # a bug: the render writes a number
        raise RuntimeError(f"the colour pass's depth_scale is {value!r}, not a number")
    return float(value)


def _trace_still(masked: RenderRequest, settle: bool = False) -> np.ndarray:
    """The mask copy's panel image, unmapped, traced as ``renderer.render`` traces a still (placed the same
    way, the same method, rays and crop), without its outputs: no PNG, views or sidecar to write and
    read back.  ``settle``: no colour pass to take the method from; the mask copy's own check picks it
    (``ray_state.settle_method``: it reads image_width as the scene does; it has no fog to check)."""
    from ..methods.registry import run_method
    from ...scene.scene import load_scene
    from ..placement.place import place_display
    from ..placement.ray_state import settle_method

    scene = load_scene(masked.source, masked.include_dirs)
    placed, _ = place_display(masked, scene)
    if settle:
        placed, _ = settle_method(placed, scene)
    return run_method(placed.method, scene, placed.render_array, placed.settings, crop=placed.crop,
                      method_options=placed.method_options).h3d


def mask_views(ids: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """``(Ny, Nx, Ly, Lx)`` view masks of a panel's ``(H, W)`` ids: the camera bank's region, or on a
    hex or fractional-PPL array each view pixel the id of its lens's pixel nearest the view's point
    (the pixel ``extract_views`` weighs most: ids are never blended)."""
    from ...image.elemental import nearest_in_lens, view_points

    if lens_array.views is not None:
        # image.interleave.extract's layout, copied by NumPy: 2 bytes a pixel cost less than loading its
        # compiled gather (about 1 s a process)
        (ny, nx), bank = lens_array.views, ids[lens_array.bank_region]
        h, w = bank.shape
        return np.ascontiguousarray(bank.reshape(h // ny, ny, w // nx, nx).transpose(1, 3, 0, 2))
    return nearest_in_lens(ids, lens_array, *view_points(lens_array))


def _note_in_sidecars(request: RenderRequest, folder: Path, table: ObjectTable) -> None:
    """The render's own sidecars name the masks folder and the ids' names (the table's copy)."""
    from ...image.io import read_sidecar_record, write_sidecar
    from ..animation import frame_path

    if request.frames is None:
        images = [request.output]
    else:
        digits = max(4, len(str(request.frames.last)))
        images = [frame_path(request.output, n, digits) for n in request.frames.numbers]
    note = {"folder": str(folder.resolve()), "names": {str(i): n for i, n in sorted(table.names.items())},
            "render_id": table.render_id}
    for image in images:
        record = read_sidecar_record(image)
        if record is not None:
            write_sidecar(image, record.with_(objects=note))
