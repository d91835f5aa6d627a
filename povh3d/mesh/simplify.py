"""Quadric decimation of parts that carry more detail than the display can show.

``fast_simplification`` (the Fast-Quadric-Mesh-Simplification library that
trimesh's own ``simplify_quadric_decimation`` wraps) does the work; its
collapse record maps every old vertex to a new one, which carries vertex
colours and UVs across.  The cost is reported as the silhouette error: one
minus the intersection over union of the front silhouettes before and after.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..geometry.lens_array import LensArray
from .load import Part
from .raster import Window, iou, silhouette

#: Triangles per 3D pixel (lens) for ``--max-triangles auto``: two make a quad
#: per lens on the visible side, as many again on the hidden side.
TRIANGLES_PER_LENS = 4


def auto_budget(lens_array: LensArray) -> int:
    """The triangle budget ``auto`` means for a display: ``4 x`` its 3D resolution (lenses)."""
    lx, ly = lens_array.resolution_3d
    return TRIANGLES_PER_LENS * lx * ly


def _carry(values: np.ndarray | None, mapping: np.ndarray, count: int) -> np.ndarray | None:
    """Per-vertex values after decimation: each new vertex takes one of the old vertices merged into it."""
    if values is None:
        return None
    out = np.zeros((count, *values.shape[1:]), dtype=values.dtype)
    valid = (mapping >= 0) & (mapping < count)
    out[mapping[valid]] = values[valid]
    return out


def simplify_part(part: Part, target: int) -> Part:
    """``part`` decimated to about ``target`` triangles (unchanged when it has fewer)."""
    from ..extras import require

    fast_simplification = require("fast_simplification", "mesh", "decimating a mesh (a triangle budget)")

    if part.triangles <= target:
        return part
    colours = part.vertex_colors
    if colours is None and part.face_colors is not None:
        # Face colours do not survive collapses; give each vertex the colour of one of its faces.
        colours = np.zeros((len(part.vertices), 4), dtype=np.uint8)
        for k in range(3):
            colours[part.faces[:, k]] = part.face_colors
    if colours is None and part.uv is None:
        # Nothing to carry across (a volume's surfaces): the library's own result, without replaying
        # its collapses for a vertex map (a tenth of the decimation's time on a segmentation).
        points, faces = fast_simplification.simplify(part.vertices, part.faces, target_count=max(1, target))
        mapping = np.zeros(0, dtype=np.int64)
    else:
        points, faces, collapses = fast_simplification.simplify(
            part.vertices, part.faces, target_count=max(1, target), return_collapses=True)
        points, faces, mapping = fast_simplification.replay_simplification(part.vertices, part.faces, collapses)
    n = len(points)
    out = dataclasses.replace(
        part, vertices=np.asarray(points, dtype=np.float64), faces=np.asarray(faces, dtype=np.int64),
        normals=None, uv=_carry(part.uv, mapping, n), vertex_colors=_carry(colours, mapping, n),
        face_colors=None, texture=part.texture if part.uv is not None else None)
    # One pass can stop well short of the target (on a segmentation's surfaces: 5,258 triangles
    # for a target of 2,149); a pass from where it stopped goes on.  Each pass must shrink it.
    if out.triangles > 1.1 * target and out.triangles < 0.9 * part.triangles:
        return simplify_part(out, target)
    return out


def silhouette_error(before: list[Part], after: list[Part], width: int = 512) -> float:
    """``1 - IoU`` of the front (``-z``) silhouettes of two versions of a model."""
    lo = np.min([p.vertices.min(axis=0) for p in before], axis=0)
    hi = np.max([p.vertices.max(axis=0) for p in before], axis=0)
    window = Window.around(lo, hi, width)
    masks = []
    for parts in (before, after):
        mask = np.zeros((window.height, window.width), dtype=bool)
        for p in parts:
            mask |= silhouette(p.vertices, p.faces, window)
        masks.append(mask)
    return 1.0 - iou(*masks)


def simplify_parts(parts: list[Part], budget: int, *, width: int = 512) -> tuple[list[Part], dict]:
    """Share ``budget`` triangles among ``parts`` in proportion to their counts, decimate, measure
    (the silhouette error on a window ``width`` pixels across)."""
    total = sum(p.triangles for p in parts)
    targets = [max(4, math.floor(budget * p.triangles / total)) for p in parts]
    out = [simplify_part(p, t) for p, t in zip(parts, targets)]
    from .clean import clean_part

    out = [clean_part(p)[0] for p in out]  # decimation can leave slivers and unused vertices
    after = sum(p.triangles for p in out)
    return out, {"budget": budget, "triangles_before": total, "triangles_after": after,
                 "silhouette_error": silhouette_error(parts, out, width)}
