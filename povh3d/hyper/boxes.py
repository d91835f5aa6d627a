"""Object boxes from id masks, and the thesis's metadata synchronisation: per-frame boxes
merged into one scene with one annotation per object and per stretch of frames."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .cdp import Annotation, BoundingBox, Scene

Box = tuple[int, int, int, int]      # x_min, y_min, x_max, y_max: pixels, inclusive


@dataclass(frozen=True)
class Link:
    """What a user gives an object: its URL and description."""

    url: str = ""
    description: str = ""


def mask_boxes(mask: np.ndarray) -> dict[int, Box]:
    """The box of every object id in an ``(H, W)`` integer mask (0 is the background).

    Returns ``{id: (x_min, y_min, x_max, y_max)}``, columns as x and rows as y, inclusive.
    """
    mask = np.asarray(mask)
    if mask.ndim != 2 or not np.issubdtype(mask.dtype, np.integer):
        raise ValueError(f"mask: an (H, W) integer array, got {mask.shape} {mask.dtype}")
    boxes = {}
    ids = np.unique(mask)
    for ident in ids[ids != 0]:
        rows = np.flatnonzero((mask == ident).any(axis=1))
        cols = np.flatnonzero((mask == ident).any(axis=0))
        boxes[int(ident)] = (int(cols[0]), int(rows[0]), int(cols[-1]), int(rows[-1]))
    return boxes


def stretches(frames: Sequence[int], present: Sequence[int]) -> list[tuple[int, int]]:
    """The runs ``(first, last)`` of ``present`` that are consecutive in the render's ``frames``."""
    where = {n: i for i, n in enumerate(frames)}
    runs: list[tuple[int, int]] = []
    previous = None
    for n in sorted(present, key=where.__getitem__):
        if previous is not None and where[n] == where[previous] + 1:
            runs[-1] = (runs[-1][0], n)
        else:
            runs.append((n, n))
        previous = n
    return runs


def merge_frames(frames: Sequence[int], per_frame: Mapping[int, Mapping[int, Mapping[str, Box]]],
                 names: Mapping[int, str], links: Mapping[str, Link] | None = None) -> Scene:
    """One scene of the render's ``frames``: an annotation for each object and stretch of frames.

    Parameters
    ----------
    frames : the render's frame numbers, in order
    per_frame : ``{frame: {object id: {space: box}}}``, space ``"view"`` or ``"h3d"``
    names : ``{object id: name}``
    links : ``{name: Link}``; an object without one gets an empty link
    """
    links = links or {}
    found: dict[int, list[int]] = {}
    for n in frames:
        for ident in per_frame.get(n, {}):
            found.setdefault(ident, []).append(n)
    runs = sorted((run, ident) for ident, present in found.items() for run in stretches(frames, present))
    annotations = []
    for number, ((first, last), ident) in enumerate(runs, start=1):
        link = links.get(names[ident], Link())
        boxes, box_id = [], 0
        for n in frames[frames.index(first):frames.index(last) + 1]:
            for space in ("view", "h3d"):
                box = per_frame[n][ident].get(space)
                if box is not None:
                    box_id += 1
                    boxes.append(BoundingBox(box_id, n, space, box, url=link.url))
        annotations.append(Annotation(number, names[ident], ident, first, last, link.url, link.description,
                                      tuple(boxes)))
    return Scene(1, frames[0], frames[-1], annotations=tuple(annotations))
