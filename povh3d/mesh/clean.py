"""Make a part safe to write: drop what POV-Ray cannot take, count what was dropped.

Pure NumPy.  POV-Ray would refuse a non-finite number and silently skip a
degenerate triangle; both are dropped here and counted so the user is told.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..extras import installed
from .load import Part

# A triangle whose doubled area is below this fraction of the squared size of
# the model is a line or a point: POV-Ray, which stores vertices as 32-bit
# floats, would drop it anyway.
_DEGENERATE_AREA = 1e-14


@dataclass(frozen=True)
class CleanReport:
    """What cleaning did to one part (or, summed, to a model)."""

    nonfinite_faces: int = 0
    degenerate_faces: int = 0
    unused_vertices: int = 0
    merged_vertices: int = 0
    notes: tuple[str, ...] = ()

    def __add__(self, other: CleanReport) -> CleanReport:
        return CleanReport(*(getattr(self, f.name) + getattr(other, f.name)
                             for f in dataclasses.fields(self)))


def merge_equal_vertices(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Share vertices with bit-identical coordinates (STL stores every corner separately).

    Returns the unique vertices, in order of first use, and the re-indexed faces.
    A sort of the rows (``np.unique``) up to ``MERGE_SMALL`` corners; past that, where
    numba is installed (``povh3d[mesh]``), a hash table in compiled code
    (``kernels.first_of_equal_rows``): 1.6 s instead of 6.5 s at 3 million corners,
    more than its 0.4 s import and load.  Both give the same groups.
    """
    v = np.ascontiguousarray(vertices, dtype=np.float64) + 0.0  # -0.0 -> 0.0, so equal points hash equal
    if len(v) > MERGE_SMALL and installed("numba"):
        from .kernels import first_of_equal_rows

        first, inverse = first_of_equal_rows(v.view(np.uint64))
    else:
        first, inverse = first_of_equal_rows_sorted(v.view(np.uint64))
    # groups are numbered in order of first appearance: the file's vertex order (stable, readable diffs)
    return v[first], inverse[faces]


#: Corners merged by a sort; past this the compiled hash table, when numba is there, is faster import included.
MERGE_SMALL = 1_000_000


def first_of_equal_rows_sorted(bits: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``kernels.first_of_equal_rows`` by a sort: for ``(n, k)`` uint64 rows, ``first`` (the row of
    each distinct value, in order of first appearance) and ``inverse`` (the group of each row)."""
    rows = np.ascontiguousarray(bits).view(f"V{8 * bits.shape[1]}").reshape(-1)
    _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)  # first: lowest row
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return first[order], rank[inverse.reshape(-1)]


def degenerate_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(m,)`` bool: faces with a repeated index or (numerically) zero area."""
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    doubled_area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    return repeated | (doubled_area <= _DEGENERATE_AREA * size * size)


def clean_part(part: Part, *, merge: bool = False) -> tuple[Part, CleanReport]:
    """Drop faces on non-finite vertices and degenerate faces, then unused vertices.

    Parameters
    ----------
    part : Part
    merge : bool
        Share bit-identical vertices first (triangle soups such as STL); only
        done when the part has no per-vertex attributes that could differ.
    """
    notes: list[str] = []
    vertices, faces = part.vertices, part.faces
    finite = np.isfinite(vertices).all(axis=1)
    bad = ~finite[faces].all(axis=1) if len(faces) else np.zeros(0, dtype=bool)
    nonfinite = int(bad.sum())
    faces = faces[~bad]
    vertices = np.where(finite[:, None], vertices, 0.0)  # unused after the drop; keeps the maths quiet

    normals, uv, colours, texture = part.normals, part.uv, part.vertex_colors, part.texture
    if normals is not None and not np.isfinite(normals).all():
        normals = None
        notes.append(f"part {part.name!r}: the file's normals hold non-finite numbers; computed them instead")
    if uv is not None and not np.isfinite(uv).all():
        uv, texture = None, None
        notes.append(f"part {part.name!r}: texture coordinates hold non-finite numbers; using the base colour")

    merged = 0
    if merge and normals is None and uv is None and colours is None and len(faces):
        before = int(np.count_nonzero(np.bincount(faces.ravel(), minlength=len(vertices))))
        vertices, faces = merge_equal_vertices(vertices, faces)
        merged = before - len(vertices)

    degenerate = degenerate_faces(vertices, faces) if len(faces) else np.zeros(0, dtype=bool)
    keep = ~degenerate
    face_colors = part.face_colors
    if face_colors is not None:
        face_colors = face_colors[~bad][keep]
    faces = faces[keep]

    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    unused = int((~used).sum()) if not merged else 0
    remap = np.cumsum(used) - 1
    pick = lambda a: None if a is None else a[used]  # noqa: E731
    cleaned = dataclasses.replace(
        part, vertices=vertices[used], faces=remap[faces].astype(np.int64), normals=pick(normals),
        uv=pick(uv), vertex_colors=pick(colours), face_colors=face_colors,
        texture=texture if uv is not None else None)
    return cleaned, CleanReport(nonfinite, int(degenerate.sum()), unused, merged, tuple(notes))


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals, ``(n, 3)`` float64, along ``(b-a) x (c-a)``.

    A vertex whose neighbours' normals cancel (a fin, a needle) takes the
    normal of one of its faces, so POV-Ray never gets a zero normal.
    """
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    face_n = np.cross(b - a, c - a)  # length = twice the area: the weight
    n = len(vertices)
    summed = np.column_stack([sum(np.bincount(faces[:, k], weights=face_n[:, axis], minlength=n)
                                  for k in range(3)) for axis in range(3)])
    length = np.linalg.norm(summed, axis=1)
    fallback = np.zeros_like(summed)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit_faces = face_n / np.linalg.norm(face_n, axis=1, keepdims=True)
        for k in range(3):
            fallback[faces[:, k]] = unit_faces
        weak = ~(length > 1e-300)
        summed[weak] = fallback[weak]
        length[weak] = 1.0
        return summed / length[:, None]
