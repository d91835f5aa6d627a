"""``povh3d annotate``: the 3DCDP header of a render from its object masks and a links file."""

from __future__ import annotations

from .. import jsontext
import tomllib
import uuid
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, param
from ..image.io import atomic_path, check_output, read_sidecar_record, with_sidecar
from ..renderer.outputs.objects import ObjectTable, read_mask, read_table
from .viewer import frame_files

_LINK_KEYS = {"url", "description"}


def read_links(path: str | Path, names: set[str]) -> dict[str, Any]:
    """``{object name: Link}`` from a TOML (``[name] url = .. description = ..``) or JSON file; a name
    that is not one of the render's objects, or another key, is an ``InputError``."""
    from ..hyper.boxes import Link
    from ..hyper.cdp import check_url

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
        raw = jsontext.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except FileNotFoundError:
        raise InputError(f"links file {str(path)!r} does not exist; check the path") from None
    except (ValueError, UnicodeDecodeError) as exc:  # JSONDecodeError and TOMLDecodeError are ValueErrors
        raise InputError(f"links file {str(path)!r} cannot be read ({exc}); it maps object names to "
                         "url and description") from None
    links = {}
    for name, entry in raw.items():
        if name not in names:
            raise InputError(f"links file {str(path)!r} names object {name!r}, which the render does not hold "
                             f"(its objects: {', '.join(sorted(names)) or 'none'})")
        if not isinstance(entry, dict) or set(entry) - _LINK_KEYS or \
                not all(isinstance(v, str) for v in entry.values()):
            raise InputError(f"links file {str(path)!r}: object {name!r} takes only url and description (text)")
        try:
            check_url(entry.get("url"))
        except ValueError as exc:
            raise InputError(f"links file {str(path)!r}: object {name!r}: {exc}; give an http(s):// or mailto: "
                             "address") from None
        links[name] = Link(entry.get("url", ""), entry.get("description", ""))
    return links


def _render_frames(render: Path) -> tuple[list[int], dict[str, Any]]:
    """The render's frame numbers and the sidecar of its first image (a views folder: frame 0)."""
    if render.is_dir():
        numbers, side = [0], read_sidecar_record(render / "views.json")
    else:
        files = frame_files(render)
        numbers, side = [n for n, _ in files], read_sidecar_record(files[0][1])
    return numbers, (side.to_json() if side is not None else {})


def _check_against(table: ObjectTable, frames: list[int], record: dict[str, Any], masks: Path) -> None:
    la = record.get("lens_array") or {}
    note = record.get("objects") if isinstance(record.get("objects"), dict) else {}
    names = {str(i): n for i, n in sorted(table.names.items())}
    if note and (note.get("render_id", "") != table.render_id or note.get("names") != names):
        # the same lens array and frames, another render: its ids name another scene's objects
        raise InputError(f"the object masks in {str(masks)!r} are of another render than the image (its "
                         f"objects: {', '.join(sorted(note.get('names', {}).values())) or 'none'}); give the "
                         f"masks folder it was rendered with ({note.get('folder', '?')}), or render {param('objects')} again")
    if list(table.frames) != frames:
        raise InputError(f"the object masks in {str(masks)!r} are of frames {table.frames[0]}..{table.frames[-1]} "
                         f"({len(table.frames)}) but the render has {frames[0]}..{frames[-1]} ({len(frames)}); "
                         f"render {param('objects')} with the same frames")
    views = la.get("views") or record.get("views")
    size = la.get("view_size_px") or record.get("view_size_px")
    if views and list(views) != [table.views[1], table.views[0]] or \
            size and list(size) != [table.view_size[1], table.view_size[0]]:
        # either may be missing from the sidecar (was a TypeError here)
        has_views = f"{views[0]}x{views[1]}" if views else "unknown"
        has_size = f"{size[0]}x{size[1]}" if size else "unknown"
        raise InputError(f"the object masks in {str(masks)!r} are {table.views[1]}x{table.views[0]} views of "
                         f"{table.view_size[1]}x{table.view_size[0]} but the render has {has_views} "
                         f"of {has_size}; render {param('objects')} with the same lens array")


def _h3d_offset(record: dict[str, Any]) -> tuple[int, int] | None:
    """Where the view bank sits in the H3D image ``(row, col)``, or None when the views do not
    tile it (hex, fractional PPL): those take their H3D boxes from the panel masks."""
    from ..display.display import Display

    if "lens_array" not in record:
        return None
    la = Display.from_record(record).lens_array
    if la.views is None:
        return None
    rows, cols = la.bank_region
    return rows.start or 0, cols.start or 0


def frame_boxes(masks: Path, table: ObjectTable, frame: int, centre: tuple[int, int],
                h3d_offset: tuple[int, int] | None) -> dict[int, dict[str, tuple[int, int, int, int]]]:
    """``{id: {"view": box, "h3d": box}}`` of one frame."""
    from ..hyper.boxes import mask_boxes
    from ..image.interleave import interleave

    out: dict[int, dict[str, Any]] = {}
    for ident, box in mask_boxes(read_mask(masks, table, frame, centre)).items():
        out.setdefault(ident, {})["view"] = box
    if h3d_offset is None and table.panel is not None:    # hex, fractional PPL: the panel's own mask
        for ident, box in mask_boxes(read_mask(masks, table, frame, None)).items():
            out.setdefault(ident, {})["h3d"] = box
    elif h3d_offset is not None:
        ny, nx = table.views
        stack = np.stack([[read_mask(masks, table, frame, (l, k)) for k in range(nx)] for l in range(ny)])
        dy, dx = h3d_offset
        for ident, (x0, y0, x1, y1) in mask_boxes(interleave(stack[..., None])[..., 0]).items():
            out.setdefault(ident, {})["h3d"] = (x0 + dx, y0 + dy, x1 + dx, y1 + dy)
    return out


def build_header(render: str | Path, masks: str | Path, links: str | Path | None = None) -> Any:
    """The ``CdpHeader`` of ``render`` from its object masks (checked against the render)."""
    from ..hyper.boxes import merge_frames
    from ..hyper.cdp import CdpHeader

    render, masks = Path(render), Path(masks)
    table = read_table(masks)
    frames, record = _render_frames(render)
    _check_against(table, frames, record, masks)
    link_table = read_links(links, set(table.names.values())) if links else {}
    ny, nx = table.views
    centre = ((ny - 1) // 2, (nx - 1) // 2)
    offset = _h3d_offset(record)
    per_frame = {n: frame_boxes(masks, table, n, centre, offset) for n in frames}
    scene = merge_frames(frames, per_frame, table.names, link_table)
    size = (record.get("lens_array") or {}).get("panel", {}).get("size_px")
    digest = record.get("image_sha256") or render.name
    return CdpHeader(str(uuid.uuid5(uuid.NAMESPACE_URL, f"povh3d:{digest}")), render.stem, render.name,
                     (nx, ny), centre, (table.view_size[1], table.view_size[0]),
                     tuple(size) if size and (offset is not None or table.panel) else None, "povh3d render",
                     (scene,))


def annotate(render: str | Path, masks: str | Path, output: str | Path, *,
             links: str | Path | None = None) -> dict[str, Any]:
    """Write the 3DCDP header of ``render`` to ``output`` (atomically, after every check)."""
    from ..hyper.cdp import to_xml

    output = Path(output)
    if output.suffix.lower() != ".xml":
        raise InputError(f"the 3DCDP header is XML: name it .xml, got {str(output)!r}")
    check_output(output, (*with_sidecar(render), *([links] if links is not None else [])), what="3DCDP header",
                 sidecar=False)
    header = build_header(render, masks, links)
    data = to_xml(header)
    with atomic_path(output) as tmp:
        tmp.write_bytes(data)
    scene = header.scenes[0]
    return {"output": str(output), "objects": len({a.object_id for a in scene.annotations}),
            "annotations": len(scene.annotations), "frames": [scene.start, scene.end]}


def read_header(path: str | Path) -> Any:
    """A 3DCDP header file read through the schema."""
    from ..hyper.cdp import MAX_HEADER_BYTES, from_xml

    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_HEADER_BYTES:   # refused before it is read
            raise InputError(f"3DCDP header {str(path)!r} is {size / 2**20:.3g} MB, over the {MAX_HEADER_BYTES >> 20} MB "
                             "a header may take; write it again with 'povh3d annotate'")
        data = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"3DCDP header {str(path)!r} does not exist; write it with 'povh3d annotate'") from None
    return from_xml(data, repr(str(path)))


def read_cdp_text(path: str | Path) -> str:
    """The header's text, after it has been read through the schema (the page parses it again)."""
    read_header(path)
    return Path(path).read_text(encoding="utf-8")
