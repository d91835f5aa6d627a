"""A volume's surfaces as one POV-Ray include: turned into display coordinates, decimated, ``mesh2``.

Each surface becomes a ``Part`` (mesh/) in display mm (``matrix @
world``, no scale: the stage scales), then goes the way of every model:
cleaned, decimated together to the triangle budget (``mesh.simplify``, which
shares it in proportion to their counts), smooth-shaded, written by
``mesh.write``.  A surface's opacity is its colour's alpha, which the writer
turns into POV-Ray's ``transmit``.  Pure: text in memory, nothing written.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from ..mesh.clean import clean_part, vertex_normals
from ..mesh.load import Part
from ..mesh.write import include_text, mesh2_text
from .surfaces import Surface
from ..errors import param

#: Pixels across the window of the decimation's silhouette error (a segmentation's thousands of
#: small triangles make the rasterising the cost; a display resolves fewer lenses than this).
SILHOUETTE_WIDTH = 256


def surface_part(surface: Surface, matrix: np.ndarray) -> Part:
    """``surface`` in display mm: ``matrix`` (3, 3) applied; a mirroring matrix (LPS is
    right-handed, display coordinates left-handed) reverses the winding so normals stay outward."""
    m = np.asarray(matrix, dtype=np.float64)
    faces = surface.faces[:, [0, 2, 1]] if np.linalg.det(m) < 0 else surface.faces
    rgba = np.array([*(round(255 * c) for c in surface.colour), round(255 * surface.opacity)], dtype=np.uint8)
    return Part(surface.name, surface.vertices @ m.T + 0.0, np.asarray(faces, dtype=np.int64), base_color=rgba)


def vertex_pieces(faces: np.ndarray, count: int) -> tuple[int, np.ndarray]:
    """The connected pieces of a mesh's ``count`` vertices through the edges of ``faces`` (m, 3):
    how many, and each vertex's piece (0..pieces-1, in order of each piece's lowest vertex).

    Each round hooks the root of every edge's ends to the smaller of the two, then follows the
    roots to their ends; it stops when no edge joins two roots.  A segmentation's surfaces need
    2-6 rounds (the frog's 25 take 0.04 s): a tenth of importing SciPy's sparse graphs for it."""
    a = np.concatenate([faces[:, 0], faces[:, 1]])
    b = np.concatenate([faces[:, 1], faces[:, 2]])
    root = np.arange(count)
    while True:
        ra, rb = root[a], root[b]
        lower = np.minimum(ra, rb)
        hooked = root.copy()
        np.minimum.at(hooked, ra, lower)
        np.minimum.at(hooked, rb, lower)
        while True:   # every vertex straight to its root: hooked[x] <= x, so the chains end
            deeper = hooked[hooked]
            if np.array_equal(deeper, hooked):
                break
            hooked = deeper
        if np.array_equal(hooked, root):
            break
        root = hooked
    roots, piece = np.unique(root, return_inverse=True)
    return len(roots), piece.reshape(-1)


def drop_specks(part: Part, size: float) -> tuple[Part, int]:
    """``part`` without its connected pieces whose box diagonal is under ``size`` (the largest piece
    always stays), and how many pieces went.

    A segmentation's surfaces hold many pieces a few voxels across (the frog's label 13
    alone has 292): smaller than one lens they are not resolved on the display, yet each
    closed piece keeps at least four triangles through any decimation, so together
    they can hold more triangles than the display's whole budget."""
    f, n = part.faces, len(part.vertices)
    count, piece = vertex_pieces(f, n)
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    np.minimum.at(lo, piece, part.vertices)
    np.maximum.at(hi, piece, part.vertices)
    diagonal = np.linalg.norm(hi - lo, axis=1)
    keep = diagonal >= size
    keep[np.argmax(diagonal)] = True
    used = np.zeros(count, dtype=bool)
    used[piece[f[:, 0]]] = True
    dropped = int(np.sum(used & ~keep))
    if not dropped:
        return part, 0
    faces = keep[piece[f[:, 0]]]
    colours = None if part.face_colors is None else part.face_colors[faces]
    return clean_part(dataclasses.replace(part, faces=f[faces], face_colors=colours))[0], dropped


def surfaces_include(surfaces: list[Surface], matrix: np.ndarray, budget: int | None, *, ident: str,
                     source: str, speck: float = 0.0) -> tuple[str, list[dict[str, Any]], dict[str, Any]]:
    """The include text, one record row per surface, and the decimation's seconds and silhouette error
    (``mesh.simplify``; None when nothing was decimated) and the writing's seconds.

    Over ``budget``, pieces smaller than ``speck`` (one lens, in the surfaces' units) are
    left out first (``drop_specks``), then the rest is decimated."""
    from ..errors import warn

    parts, kept = [], []
    for surface in surfaces:
        part = clean_part(surface_part(surface, matrix))[0]
        if part.triangles:
            parts.append(part)
            kept.append(surface)
        else:
            warn(f"{surface.name} of {source} has no surface; left out")
    if not parts:
        from ..errors import InputError

        raise InputError(f"no surface to draw in {source}; check {param('labels')} or {param('iso')}")
    before = [p.triangles for p in parts]
    start = time.perf_counter()
    silhouette, specks = None, 0
    if budget is not None and sum(before) > budget and speck > 0:
        trimmed, dropped = zip(*(drop_specks(p, speck) for p in parts))
        parts, specks = list(trimmed), sum(dropped)
    if budget is not None and sum(p.triangles for p in parts) > budget:
        from ..mesh.simplify import simplify_parts

        # The frog's 25 surfaces (185,000 triangles to 4,800) give the same error to three digits on
        # 256 and 512 pixels (0.5719, 0.5717 at a tenth of the budget), at 2.5x less time.
        parts, report = simplify_parts(parts, budget, width=SILHOUETTE_WIDTH)
        silhouette = report["silhouette_error"]
    decimated = time.perf_counter() - start
    start = time.perf_counter()
    blocks = [mesh2_text(p, smooth=True, normals=vertex_normals(p.vertices, p.faces), texture_file=None, ident=ident)
              for p in parts]
    lo = np.min([p.vertices.min(axis=0) for p in parts], axis=0)
    hi = np.max([p.vertices.max(axis=0) for p in parts], axis=0)
    total = sum(p.triangles for p in parts)
    text = include_text(blocks, ident, (lo, hi), source=source,
                        summary=f"{len(parts)} surfaces, {total} triangles (from {sum(before)})")
    rows = [{"name": s.name, "label": s.label, "iso": s.iso, "triangles_extracted": n, "triangles": p.triangles,
             "colour": [round(c, 4) for c in s.colour], "opacity": s.opacity}
            for s, p, n in zip(kept, parts, before)]
    stats = {"decimate_seconds": round(decimated, 4), "write_seconds": round(time.perf_counter() - start, 4),
             "silhouette_error": silhouette, "specks_left_out": specks}
    return text, rows, stats
