"""Rotated lattices (docs/geometry.md, "Rotated lattices"): which lens a pixel
belongs to, its ray, and the mesh camera that traces it, checked without POV-Ray.

The ownership oracle is brute force over every lens: a pixel belongs to the lens
whose cell, turned by the rotation, holds its centre (hex: the nearest centre).
The mesh camera is simulated as POV-Ray 3.7 looks it up (tests/geometry/test_cameras.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from povh3d.errors import ConfigError
from povh3d.geometry.lattice_mesh import lens_mesh
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays

PANEL = Panel(60, 45, 0.1, 0.1)
SQRT3_2 = math.sqrt(3) / 2


def rotated(grid: str, rotation: float) -> LensArray:
    if grid == "lenticular":
        return LensArray("lenticular", 14, 45, 0.55, 0.1, 1.5, PANEL, rotation)
    py = 0.55 * SQRT3_2 if grid == "hex" else 0.55
    return LensArray(grid, 14, 12, 0.55, py, 1.5, PANEL, rotation)


CASES = [(g, r) for g in ("square", "hex", "lenticular") for r in (6.34, 9.46, -30.0, 45.0)]


@pytest.mark.parametrize("rotation", [-45.0, 45.01, 90.0, float("nan"), float("inf"), True, "6"])
def test_rotation_outside_the_range_is_refused(rotation):
    with pytest.raises(ConfigError, match=r"within \(-45, 45\]"):
        LensArray("square", 10, 8, 0.6, 0.6, 1.5, PANEL, rotation)


@pytest.mark.parametrize("grid,rotation", CASES)
def test_pixel_belongs_to_the_cell_that_holds_it(grid, rotation):
    la = rotated(grid, rotation)
    centres, dirs, inside = pixel_rays(la)
    X, Y = np.meshgrid(*PANEL.pixel_centres())
    t = math.radians(rotation)
    lattice = la.lens_centres().reshape(-1, 2)
    # Offsets from every lens centre, turned back into the lattice frame: (H, W, lenses).
    dx, dy = X[..., None] - lattice[:, 0], Y[..., None] - lattice[:, 1]
    ux, uy = math.cos(t) * dx + math.sin(t) * dy, -math.sin(t) * dx + math.cos(t) * dy
    if grid == "hex":
        d2 = ux ** 2 + uy ** 2
        best = d2.argmin(axis=-1)
        own = lattice[best]
        ox, oy = np.take_along_axis(ux, best[..., None], -1)[..., 0], np.take_along_axis(uy, best[..., None], -1)[..., 0]
        holds = (np.abs(ox) <= la.pitch_x / 2 + 1e-9) & (np.abs(ox) / 2 + SQRT3_2 * np.abs(oy) <= la.pitch_x / 2 + 1e-9)
        np.testing.assert_array_equal(inside, holds)
        np.testing.assert_allclose(centres[inside], own[inside], atol=1e-12)
    else:
        hy = np.inf if grid == "lenticular" else la.pitch_y / 2
        cell = (np.abs(ux) < la.pitch_x / 2) & (np.abs(uy) < hy)
        np.testing.assert_array_equal(inside, cell.any(axis=-1))
        j = cell.argmax(axis=-1)
        if grid == "lenticular":
            # The point of the lenticule's axis beside the pixel: the pixel minus its offset across it.
            uj = np.take_along_axis(ux, j[..., None], -1)[..., 0]
            foot = np.stack([X - uj * math.cos(t), Y - uj * math.sin(t)], axis=-1)
            np.testing.assert_allclose(centres[inside], foot[inside], atol=1e-12)
        else:
            np.testing.assert_allclose(centres[inside], lattice[j][inside], atol=1e-12)
    # The ray: normalize(u, v, f) with (u, v) the offset from that point (across it, for a lenticule).
    u = np.stack([X, Y], axis=-1) - centres
    expected = np.concatenate([u, np.full(u.shape[:2] + (1,), la.focal)], axis=-1)
    expected /= np.linalg.norm(expected, axis=-1, keepdims=True)
    np.testing.assert_allclose(dirs[inside], expected[inside], atol=1e-12)
    if grid == "lenticular":  # the offset is square to the lenticule
        along = -math.sin(t) * u[..., 0] + math.cos(t) * u[..., 1]
        np.testing.assert_allclose(along[inside], 0, atol=1e-12)


def simulate_lookup(mesh):
    """POV-Ray 3.7's mesh_camera lookup of every image pixel: origin, direction, face margin."""
    W, H1 = mesh.image_size
    cols, rows = np.meshgrid(np.arange(W), np.arange(H1))
    p = np.stack([cols / W, 1 - rows / H1], axis=-1).reshape(-1, 2)
    tri = mesh.uvs[mesh.faces]
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    v0, v1 = b - a, c - a
    den = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    out_o, out_n, out_m = [], [], []
    for chunk in np.array_split(np.arange(len(p)), max(1, len(p) // 500)):
        d = p[chunk, None, :] - a[None]
        w1 = (d[..., 0] * v1[:, 1] - d[..., 1] * v1[:, 0]) / den
        w2 = (v0[:, 0] * d[..., 1] - v0[:, 1] * d[..., 0]) / den
        w = np.stack([1 - w1 - w2, w1, w2], axis=-1)
        margin = w.min(axis=-1)
        face = margin.argmax(axis=1)
        bary = w[np.arange(len(chunk)), face]
        idx = mesh.faces[face]
        n = mesh.normals[idx] / np.linalg.norm(mesh.normals[idx], axis=-1, keepdims=True)
        out_o.append(np.einsum("pk,pkd->pd", bary, mesh.vertices[idx]))
        out_n.append(np.einsum("pk,pkd->pd", bary, n))
        out_m.append(margin[np.arange(len(chunk)), face])
    shape = (H1, W)
    return (np.concatenate(out_o).reshape(*shape, 3), np.concatenate(out_n).reshape(*shape, 3),
            np.concatenate(out_m).reshape(shape))


@pytest.mark.parametrize("grid,rotation", [(g, r) for g in ("square", "hex", "lenticular") for r in (6.34, 9.46)])
def test_mesh_camera_traces_the_ray_of_every_rotated_pixel(grid, rotation):
    la = rotated(grid, rotation)
    front_clearance = 20.0
    mesh = lens_mesh(la, front_clearance)
    assert mesh.uvs.min() > 0 and mesh.uvs.max() < 1, "POV-Ray aborts on UV outside 0..1"
    origin, normal, found = simulate_lookup(mesh)
    crop = lambda a: mesh.crop(a[1:, :-1])  # noqa: E731  (as the method assembles it)
    origin, normal, found = crop(origin), crop(normal), crop(found)
    centres, dirs, inside = pixel_rays(la)
    # Pixels of a lens fall in its face (a pixel centre within 1e-9 of an edge is a tie).
    assert np.all(found[inside] > -1e-9)
    assert np.all(found[~inside] < 0), "a pixel outside every lens found a face"
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    np.testing.assert_allclose(d[inside], dirs[inside], atol=1e-9)
    t = -origin[..., 2] / d[..., 2]
    hit = origin[..., :2] + t[..., None] * d[..., :2]
    np.testing.assert_allclose(hit[inside], centres[inside], atol=1e-9)
