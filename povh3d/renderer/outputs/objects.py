"""Object masks on disk: ``DIR/objects.json`` (the ids' names, the frames, the views) and per
frame ``DIR/f_NNNN/v_LLL_KKK.png``, 16-bit grey, each pixel the id of the object its ray
first hits (0: nothing).  A hex or fractional-PPL render, whose views are resampled, also has
``DIR/f_NNNN/h3d.png``: the id of every panel pixel's own ray (``panel_size_px`` in the table)."""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...jsontext import JSONValue
from ...errors import InputError, OutputError, param, plain
from ..._version import __version__
from ...image.io import read_png, read_sidecar, write_png
from .views import VIEW_NAME, check_replaced_dir, replaced_whole

MANIFEST = "objects.json"
FRAME_DIR = "f_{n:04d}"
PANEL_NAME = "h3d.png"


@dataclass(frozen=True)
class ObjectTable:
    """The ids of a render's objects and their names; views ``(Ny, Nx)``, view size ``(Ly, Lx)``;
    ``panel`` ``(H, W)`` when every frame also has its panel mask (hex, fractional PPL)."""

    names: dict[int, str]
    frames: tuple[int, ...]
    views: tuple[int, int]
    view_size: tuple[int, int]
    panel: tuple[int, int] | None = None
    render_id: str = ""   # the render's, also in its sidecars ("objects"): masks of another render are refused

    def __post_init__(self) -> None:
        if any(i < 1 or i > 65535 for i in self.names):
            raise ValueError(f"object ids run 1..65535 (0 is nothing), got {sorted(self.names)}")
        seen: dict[str, int] = {}
        for ident, name in self.names.items():
            if name in seen:
                raise ValueError(f"objects {seen[name]} and {ident} are both named {name!r}; names must differ")
            seen[name] = ident
        if not self.frames:
            raise ValueError("frames: at least one")

    def as_record(self) -> dict[str, JSONValue]:
        record: dict[str, JSONValue] = {"kind": "objects", "objects": {str(i): n for i, n in sorted(self.names.items())},
                  "frames": list(self.frames), "views": [self.views[1], self.views[0]],
                  "view_size_px": [self.view_size[1], self.view_size[0]]}
        if self.panel is not None:
            record["panel_size_px"] = [self.panel[1], self.panel[0]]
        if self.render_id:
            record["render_id"] = self.render_id
        return record

    @classmethod
    def from_record(cls, record: Mapping[str, Any]) -> ObjectTable:
        try:
            names = {int(i): str(n) for i, n in record["objects"].items()}
            (nx, ny), (w, h) = record["views"], record["view_size_px"]
            panel = record.get("panel_size_px")
            return cls(names, tuple(int(n) for n in record["frames"]), (int(ny), int(nx)), (int(h), int(w)),
                       None if panel is None else (int(panel[1]), int(panel[0])), str(record.get("render_id", "")))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise InputError(f"the object table is incomplete or damaged ({exc}); render {param('objects')} again") from None


def check_objects_dir(folder: str | Path, inputs: tuple[Path, ...] = ()) -> Path:
    """Before any work: ``--objects`` new, empty or a masks folder povh3d wrote (it is replaced whole),
    holding none of ``inputs`` (the scene and the files it reads)."""
    from ...image.io import check_output_folder

    check_output_folder(folder, inputs, what=f"{param('objects')} folder")
    return check_replaced_dir(folder, MANIFEST, lambda record: record.get("kind") == "objects", param("objects"))


def write_masks(folder: str | Path, table: ObjectTable, masks: dict[int, np.ndarray],
                panels: dict[int, np.ndarray] | None = None) -> None:
    """Write ``{frame: (Ny, Nx, Ly, Lx) ids}``, with ``table.panel`` also ``{frame: (H, W) ids}``, and
    the table, into a folder that replaces ``folder`` whole (``views.replaced_whole``): the masks of
    an older render never stay beside the new table."""
    folder = Path(folder)
    try:
        with replaced_whole(folder, "objects") as tmp:
            for n in table.frames:
                frame_dir = tmp / FRAME_DIR.format(n=n)
                frame_dir.mkdir()
                ids = masks[n]
                for l in range(ids.shape[0]):
                    for k in range(ids.shape[1]):
                        write_png(frame_dir / VIEW_NAME.format(l=l, k=k), ids[l, k].astype(np.uint16))
                if table.panel is not None and panels is not None:  # given together
                    write_png(frame_dir / PANEL_NAME, panels[n].astype(np.uint16))
            record = {"povh3d_version": __version__, **table.as_record()}
            (tmp / MANIFEST).write_text(json.dumps(plain(record), indent=2) + "\n", encoding="utf-8")
    except OSError as exc:
        raise OutputError(f"cannot write the object masks into {str(folder)!r}: {exc.strerror or exc}; the previous "
                          "masks, if any, are unchanged") from None


def read_table(folder: str | Path) -> ObjectTable:
    folder = Path(folder)
    record = read_sidecar(folder / MANIFEST) if (folder / MANIFEST).is_file() else None
    if not record:
        raise InputError(f"{str(folder)!r} holds no object masks ({MANIFEST}); render with {param('objects')} DIR first")
    return ObjectTable.from_record(record)


def read_mask(folder: str | Path, table: ObjectTable, frame: int, view: tuple[int, int] | None) -> np.ndarray:
    """The ``(Ly, Lx)`` id mask of view ``(l, k)`` of ``frame`` (None: the ``(H, W)`` panel mask of a
    table that has them); an unknown id is an ``InputError``."""
    if view is None:
        path, size = Path(folder) / FRAME_DIR.format(n=frame) / PANEL_NAME, table.panel
    else:
        path, size = Path(folder) / FRAME_DIR.format(n=frame) / VIEW_NAME.format(l=view[0], k=view[1]), table.view_size
    if not path.is_file() or size is None:
        raise InputError(f"the object mask {str(path)!r} is missing; render {param('objects')} again")
    mask = read_png(path)
    if mask.shape[2] != 1 or mask.shape[:2] != size:
        raise InputError(f"{str(path)!r} is not a {size[1]}x{size[0]} grey id mask; "
                         f"render {param('objects')} again")
    ids = mask[..., 0].astype(np.int64)
    unknown = sorted(set(np.unique(ids).tolist()) - set(table.names) - {0})
    if unknown:
        raise InputError(f"{str(path)!r} holds object id {unknown[0]} that {MANIFEST} does not name; "
                         f"render {param('objects')} again")
    return ids
