"""Surfaces of a volume: one per label of a segmentation, or one per iso value.

Labels go through VTK's SurfaceNets (``pyvista.ImageData.contour_labels``):
discrete marching over the label map that puts every boundary face once,
tagged with the two labels it separates, then constrained smoothing that
keeps each face between its voxels.  A label's surface is every face that
touches it, turned so its normal points out of the label: closed wherever the
label does not touch itself only along a voxel edge.  Iso surfaces go
through VTK's flying edges (marching cubes); their faces point towards lower
values, out of the region above the iso value (bone, skin in CT).

Extraction runs in the volume's index frame scaled by the spacing; the
vertices are then moved to LPS world mm (origin, direction), so surfaces
follow the volume's orientation.  Faces wind so that ``(b - a) x (c - a)``
points outward in LPS (a right-handed frame).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, param
from .grid import Volume

#: SurfaceNets smoothing iterations for labels when none are asked for (PyVista's default).
LABEL_SMOOTHING = 16
#: A label with fewer faces than this from the sampled voxels is extracted from its own voxels
#: (a closed surface round one voxel has 6 quads, 12 triangles).
MIN_SAMPLED_FACES = 48
#: Up to this many labels a crop compares the voxels with each (two passes each); more go through a table.
FEW_LABELS = 8


@dataclass(frozen=True, eq=False)
class Surface:
    """One extracted surface in LPS world mm.

    Attributes
    ----------
    name : str                      the tissue's name, ``label N`` or ``iso V``
    vertices : (n, 3) float64, mm   LPS world
    faces : (m, 3) int64            outward winding in LPS
    colour : (3,) float in 0..1     sRGB
    opacity : float in 0..1
    label : int or None
    iso : float or None
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    colour: tuple[float, float, float]
    opacity: float = 1.0
    label: int | None = None
    iso: float | None = None


def _image(volume: Volume, values: np.ndarray, step: tuple[int, int, int] = (1, 1, 1)) -> Any:
    import pyvista

    if min(volume.shape) < 2:
        raise InputError(f"{volume.name} is {' x '.join(map(str, volume.shape))} voxels: a surface needs at least two "
                         "voxels along every axis (a single slice has no inside)")

    spacing = tuple(float(a) * k for a, k in zip(volume.spacing, step))
    image = pyvista.ImageData(dimensions=values.shape, spacing=spacing)
    image.point_data["values"] = np.ascontiguousarray(values).ravel(order="F")
    return image


def _to_world(volume: Volume, points: np.ndarray, faces: np.ndarray,
              start: tuple[float, ...] = (0, 0, 0)) -> tuple[np.ndarray, np.ndarray]:
    """Index-frame mm (spacing applied; ``start``: the voxel index of a cropped image's first voxel) -> LPS
    world; a mirroring direction matrix flips the winding back."""
    d = np.asarray(volume.direction, dtype=np.float64)
    shifted = np.asarray(points, dtype=np.float64) + np.asarray(start) * np.asarray(volume.spacing)
    world = shifted @ d.T + np.asarray(volume.origin, dtype=np.float64)
    return world, faces[:, [0, 2, 1]] if np.linalg.det(d) < 0 else faces


def _compact(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Only the vertices ``faces`` use, renumbered."""
    used, inverse = np.unique(faces, return_inverse=True)
    return points[used], inverse.reshape(faces.shape).astype(np.int64)


def palette(count: int) -> list[tuple[float, float, float]]:
    """``count`` distinct colours: matplotlib's tab20, in a light-then-dark order, repeated."""
    from matplotlib import colormaps

    colours = colormaps["tab20"].colors  # type: ignore[attr-defined]  # tab20 is a ListedColormap: it has them
    order = list(colours[0::2]) + list(colours[1::2])
    return [(float(r), float(g), float(b)) for r, g, b in (order[i % len(order)] for i in range(count))]


def check_labels(volume: Volume, labels: list[int] | None) -> list[int]:
    """The labels asked for (None: all present), each checked to exist."""
    values = volume.values
    if not (np.issubdtype(values.dtype, np.integer) or np.all(np.mod(values, 1) == 0)):
        lo, hi = volume.value_range()
        raise ConfigError(f"{volume.name} holds continuous values ({lo:.6g} to {hi:.6g}), not labels; "
                          f"use {param('iso')} VALUE or {param('volume')}")
    present = volume.labels()
    if labels is None:
        if not present:
            raise InputError(f"{volume.name} has no labels other than the background 0")
        return present
    missing = [v for v in labels if v not in present]
    if missing:
        named = ", ".join(f"{v} ({volume.label_names[v]})" if v in volume.label_names else str(v) for v in present)
        raise ConfigError(f"label{'s' if len(missing) > 1 else ''} {', '.join(map(str, missing))} not in "
                          f"{volume.name}; it has {named}")
    return list(labels)


def _inside(values: np.ndarray, labels: list[int], every: bool = False) -> np.ndarray:
    """``values in labels`` as a bool array (``every``: the labels are all the non-zero values).

    A few labels are compared one by one (a vectorised comparison of the frog's 32 million voxels
    takes a twentieth of a gather through a table); more 8- and 16-bit labels go through a look-up
    table, one gather (``np.isin`` sorts, slower still); a signed value reads its two's complement slot."""
    if every:
        return values != 0
    if len(labels) <= FEW_LABELS:
        inside = values == labels[0]
        for label in labels[1:]:
            inside |= values == label
        return inside
    if np.issubdtype(values.dtype, np.integer) and values.dtype.itemsize <= 2:
        table = np.zeros(1 << (8 * values.dtype.itemsize), dtype=bool)
        table[np.asarray(labels, dtype=np.int64) % len(table)] = True
        return table[values.view(values.dtype.str.replace("i", "u"))]
    return np.isin(values, labels)


def _crop(values: np.ndarray, labels: list[int], every: bool = False) -> tuple[tuple[int, int, int], np.ndarray]:
    """The box of voxels holding ``labels`` and one voxel round it (SurfaceNets then sees the same
    boundaries: every other label is background to it anyway), and the index of its first voxel;
    ``every``: the labels are all the volume holds."""
    inside = _inside(values, labels, every)
    plane = np.asarray(inside.any(axis=2))   # the rows and columns from this plane, the slices from the volume
    hits = [np.flatnonzero(plane.any(axis=1)), np.flatnonzero(plane.any(axis=0)),
            np.flatnonzero(inside.any(axis=(0, 1)))]
    start = [max(int(hit[0]) - 1, 0) for hit in hits]
    stop = [min(int(hit[-1]) + 2, n) for hit, n in zip(hits, values.shape)]
    box = tuple(slice(a, b) for a, b in zip(start, stop))
    return tuple(start), values[box]  # type: ignore[return-value]


def voxel_step(spacing: tuple[float, float, float], detail: float) -> tuple[int, int, int]:
    """Every how many voxels along each axis to sample a label map so its voxels stay under ``detail``
    mm (at least 1: the volume's own voxels)."""
    return tuple(max(1, int(detail // float(a))) if detail > 0 else 1 for a in spacing)  # type: ignore[return-value]


def _sample(values: np.ndarray, start: tuple[int, int, int], step: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The voxels at the centre of every ``step`` block of the whole volume (``values`` is its box from
    voxel ``start``), with one background voxel round them (so a label at the box's edge still closes),
    and the volume index of the first one."""
    offset = np.array([(k // 2 - a) % k for a, k in zip(start, step)])
    sampled = values[tuple(slice(o, None, k) for o, k in zip(offset, step))]
    return np.pad(sampled, 1), np.asarray(start) + offset - np.array(step)


def label_surfaces(volume: Volume, labels: list[int] | None = None, *, smoothing: int | None = None,
                   opacity: list[float] | None = None, step: tuple[int, int, int] = (1, 1, 1)) -> list[Surface]:
    """One closed surface per label (``None``: every label present), coloured from the label table
    or the palette; ``smoothing`` iterations (0: the voxels' staircase).

    ``step``: sample the label map every so many voxels along each axis first (``voxel_step``):
    a display that resolves a lens, far coarser than the voxels, is drawn from far fewer
    triangles, and SurfaceNets and the decimation then visit that many fewer."""
    every = labels is None
    labels = check_labels(volume, labels)
    opacity = _per_surface(opacity, len(labels))
    iterations = LABEL_SMOOTHING if smoothing is None else int(smoothing)
    meshes = _label_meshes(volume, labels, iterations, (step[0], step[1], step[2]), every)
    if tuple(step) != (1, 1, 1):
        # A label thinner than a step can fall between the sampled voxels: those few labels are taken
        # again from their own voxels (a small box, a few triangles), never left out.
        thin = [label for label in labels if len(meshes[label][1]) < MIN_SAMPLED_FACES]
        if thin:
            meshes.update(_label_meshes(volume, thin, iterations, (1, 1, 1)))
    colours = palette(len(labels))
    out = []
    for n, label in enumerate(labels):
        points, own = meshes[label]
        name = volume.label_names.get(label, f"label {label}")
        colour = volume.label_colours.get(label, colours[n])
        out.append(Surface(name, points, own, colour, opacity[n], label=label))
    return out


def _label_meshes(volume: Volume, labels: list[int], iterations: int, step: tuple[int, int, int],
                  every: bool = False) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """label -> (vertices in LPS mm, outward faces): one SurfaceNets pass over every label at once
    (``every``: the labels are all the volume holds)."""
    from .read import vtk_quiet

    start: tuple[int, int, int] | np.ndarray  # a voxel index: _sample moves it
    start, values = _crop(volume.values, labels, every)  # a few organs of a whole body: far fewer voxels to visit
    if step != (1, 1, 1):
        values, start = _sample(values, start, step)
    image = _image(volume, values, step)
    with vtk_quiet():
        mesh = image.contour_labels("all", select_inputs=labels, output_mesh_type="triangles",
                                    smoothing=iterations > 0, smoothing_iterations=max(iterations, 1), scalars="values")
    faces = np.asarray(mesh.regular_faces, dtype=np.int64) if mesh.n_cells else np.zeros((0, 3), np.int64)
    pair = np.asarray(mesh.cell_data["boundary_labels"]) if mesh.n_cells else np.zeros((0, 2))
    # Every face once for each label it bounds, in face order within a label (one sort, not a pass
    # over all faces per label); as its second label's face it is turned round (it points out of the first).
    n = len(faces)
    owner = np.concatenate([pair[:, 0], pair[:, 1]]).astype(np.int64)
    both = np.concatenate([faces, faces[:, [0, 2, 1]]])
    order = np.argsort(owner * max(n, 1) + np.tile(np.arange(n), 2), kind="stable")
    owner, both = owner[order], both[order]
    first = np.searchsorted(owner, labels)
    last = np.searchsorted(owner, labels, side="right")
    points = np.asarray(mesh.points)
    out = {}
    for label, a, b in zip(labels, first, last):
        own_points, own = _compact(points, both[a:b])
        out[label] = _to_world(volume, own_points, own, tuple(start))
    return out


def iso_surfaces(volume: Volume, values: list[float], *, smoothing: int | None = None,
                 opacity: list[float] | None = None) -> list[Surface]:
    """One surface per iso value (each inside the data range), through flying edges."""
    lo, hi = volume.value_range()
    for v in values:
        if not (lo < v < hi):
            raise ConfigError(f"iso value {v:g} is outside the data range of {volume.name}, {lo:.6g} to {hi:.6g}; "
                              "choose a value inside it")
    opacity = _per_surface(opacity, len(values))
    from .read import vtk_quiet

    image = _image(volume, volume.values.astype(np.float32, copy=False))
    colours = palette(len(values))
    out = []
    for n, value in enumerate(values):
        with vtk_quiet():
            mesh = image.contour([float(value)], scalars="values", method="flying_edges")
            if smoothing:
                mesh = mesh.smooth_taubin(n_iter=int(smoothing))
        faces = np.asarray(mesh.regular_faces, dtype=np.int64) if mesh.n_cells else np.zeros((0, 3), np.int64)
        # VTK winds towards lower values; ours point out of the region above the value: the same.
        points, faces = _to_world(volume, np.asarray(mesh.points, dtype=np.float64), faces)
        out.append(Surface(f"iso {value:g}", points, faces, colours[n], opacity[n], iso=float(value)))
    return out


def _per_surface(opacity: list[float] | None, count: int) -> list[float]:
    """``--opacity``: one value for every surface, or one per surface in order."""
    if opacity is None:
        return [1.0] * count
    if len(opacity) == 1:
        opacity = list(opacity) * count
    if len(opacity) != count:
        raise ConfigError(f"{param('opacity')} takes one value or one per surface ({count}), got {len(opacity)}")
    for a in opacity:
        if not (0.0 < a <= 1.0):
            raise ConfigError(f"{param('opacity')} values must be in (0, 1], got {a:g}")
    return [float(a) for a in opacity]
