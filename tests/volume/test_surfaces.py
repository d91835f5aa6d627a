"""Surfaces of volumes against analytic values (an ellipsoid) and topology (closed label surfaces)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ellipeinc, ellipkinc

from povh3d.errors import ConfigError, InputError
from povh3d.volume.grid import Volume
from povh3d.volume.surfaces import iso_surfaces, label_surfaces
from tests.support.volumes import LABEL_BODY, LABEL_LEFT, LABEL_TOP, asymmetric_phantom, ellipsoid_field, turn


def ellipsoid_area(a: float, b: float, c: float) -> float:
    """Exact surface area (a >= b >= c), Legendre's form with incomplete elliptic integrals."""
    a, b, c = sorted((a, b, c), reverse=True)
    phi = np.arccos(c / a)
    m = a * a * (b * b - c * c) / (b * b * (a * a - c * c))
    return 2 * np.pi * c * c + 2 * np.pi * a * b / np.sin(phi) * (
        ellipeinc(phi, m) * np.sin(phi) ** 2 + ellipkinc(phi, m) * np.cos(phi) ** 2)


def area_and_volume(vertices: np.ndarray, faces: np.ndarray) -> tuple[float, float]:
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    cross = np.cross(b - a, c - a)
    return 0.5 * np.linalg.norm(cross, axis=1).sum(), np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6


def open_edges(faces: np.ndarray) -> int:
    """Edges not shared by exactly two faces (0 for a closed, manifold surface)."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int((counts != 2).sum())


def test_ellipsoid_iso_surface_area_and_volume_within_one_percent():
    axes, spacing = (22.0, 15.0, 10.0), (0.8, 1.0, 1.25)
    volume = ellipsoid_field(axes, spacing, (64, 40, 24))
    (surface,) = iso_surfaces(volume, [0.0])
    area, enclosed = area_and_volume(surface.vertices, surface.faces)
    assert open_edges(surface.faces) == 0
    assert enclosed == pytest.approx(4 / 3 * np.pi * np.prod(axes), rel=0.01)   # positive: outward faces
    assert area == pytest.approx(ellipsoid_area(*axes), rel=0.01)
    # Negative control: the wrong semi-axes are more than 1 % off.
    assert abs(area / ellipsoid_area(22.5, 15.0, 10.0) - 1) > 0.01


def test_iso_surface_follows_origin_and_direction():
    axes, spacing = (10.0, 6.0, 4.0), (1.0, 1.0, 1.0)
    base = ellipsoid_field(axes, spacing, (25, 17, 13))
    moved = Volume(base.values, spacing, origin=(100.0, -50.0, 20.0), direction=turn(90.0))
    (surface,) = iso_surfaces(moved, [0.0])
    centre = moved.index_to_world() @ np.append((np.asarray(base.shape) - 1) / 2, 1.0)
    extent = np.ptp(surface.vertices, axis=0)
    assert surface.vertices.mean(axis=0) == pytest.approx(centre[:3], abs=0.3)
    assert extent == pytest.approx([12.0, 20.0, 8.0], rel=0.05)   # the long i axis now along LPS y


@pytest.mark.parametrize("direction", [np.eye(3), np.diag([-1.0, 1.0, 1.0])], ids=["identity", "mirrored"])
def test_label_surfaces_are_closed_and_outward(direction):
    phantom = asymmetric_phantom(direction=direction)
    voxel = np.prod(phantom.spacing)
    for smoothing in (0, None):
        surfaces = label_surfaces(phantom, None, smoothing=smoothing)
        assert [s.label for s in surfaces] == [LABEL_BODY, LABEL_LEFT, LABEL_TOP]
        for surface in surfaces:
            _, enclosed = area_and_volume(surface.vertices, surface.faces)
            assert open_edges(surface.faces) == 0, surface.name
            voxels = (phantom.values == surface.label).sum() * voxel
            if smoothing == 0:   # the staircase between voxel centres of different labels: exactly the voxels
                assert enclosed == pytest.approx(voxels, rel=1e-6), surface.name
            else:                # smoothing rounds the corners off (small markers most): less, never negative
                assert 0.1 * voxels < enclosed < voxels, surface.name


def test_label_table_colours_and_names_are_used():
    phantom = asymmetric_phantom()
    named = Volume(phantom.values, phantom.spacing, label_names={2: "kidney"}, label_colours={2: (1.0, 0.0, 0.0)})
    surface = label_surfaces(named, [2], opacity=[0.4])[0]
    assert (surface.name, surface.colour, surface.opacity) == ("kidney", (1.0, 0.0, 0.0), 0.4)


def test_bad_choices_are_one_line_errors():
    phantom = asymmetric_phantom()
    with pytest.raises(ConfigError, match=r"labels? 9 not in phantom; it has 1, 2, 3"):
        label_surfaces(phantom, [2, 9])
    field = ellipsoid_field((5.0, 5.0, 5.0), (1.0, 1.0, 1.0), (12, 12, 12))
    lo, hi = field.value_range()
    with pytest.raises(ConfigError, match=f"outside the data range of ellipsoid, {lo:.6g} to {hi:.6g}"):
        iso_surfaces(field, [2.0])
    with pytest.raises(ConfigError, match="not labels"):
        label_surfaces(field, None)
    with pytest.raises(ConfigError, match="one per surface"):
        label_surfaces(phantom, [1, 2], opacity=[0.5, 0.5, 0.5])
    with pytest.raises(InputError, match="24 x 20 x 1 voxels: a surface needs at least two"):
        label_surfaces(Volume(phantom.values[:, :, 8:9], phantom.spacing, name="phantom"), None)


@pytest.mark.parametrize("label", [LABEL_LEFT, LABEL_TOP])
def test_staircase_surface_wraps_the_labels_voxels_in_world_space(label):
    # Unsmoothed, a box of voxels gives a surface half a voxel outside their centres: its corners are
    # the box's corners through the volume's geometry (origin, spacing, a turned direction).
    phantom = asymmetric_phantom(direction=turn(30.0))
    (surface,) = label_surfaces(phantom, [label], smoothing=0)
    index = np.argwhere(phantom.values == label)
    lo, hi = index.min(axis=0) - 0.5, index.max(axis=0) + 0.5
    corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    world = (corners @ phantom.index_to_world().T)[:, :3]
    assert surface.vertices.min(axis=0) == pytest.approx(world.min(axis=0), abs=1e-6)
    assert surface.vertices.max(axis=0) == pytest.approx(world.max(axis=0), abs=1e-6)


def test_sampled_label_map_is_the_staircase_of_every_steps_centre_voxel():
    # A ball of label 7 (radius 9 mm) in a turned, anisotropic volume, sampled every (3, 3, 2) voxels:
    # unsmoothed, the surface encloses exactly the sampled voxels, each step x spacing in size, and its
    # box is theirs (centres +- half a step) through the volume's geometry.
    spacing, shape, step = (1.0, 0.8, 1.5), (40, 44, 30), (3, 3, 2)
    centre = (np.asarray(shape) - 1) / 2 * spacing + np.array([1.3, -0.7, 0.4])
    grid = np.stack(np.meshgrid(*(np.arange(n) * s for n, s in zip(shape, spacing)), indexing="ij"), axis=-1)
    values = np.where(np.linalg.norm(grid - centre, axis=-1) < 9.0, 7, 0).astype(np.uint8)
    volume = Volume(values, spacing, origin=(10.0, -4.0, 2.0), direction=turn(30.0))
    (surface,) = label_surfaces(volume, [7], smoothing=0, step=step)
    assert open_edges(surface.faces) == 0
    offset = np.array([k // 2 for k in step])
    sampled = values[offset[0]::3, offset[1]::3, offset[2]::2] == 7
    _, enclosed = area_and_volume(surface.vertices, surface.faces)
    assert enclosed == pytest.approx(sampled.sum() * np.prod(spacing) * np.prod(step), rel=1e-6)
    index = np.argwhere(sampled) * step + offset
    lo, hi = index.min(axis=0) - np.array(step) / 2, index.max(axis=0) + np.array(step) / 2
    # The surface taken back to voxel indices through the volume's geometry (origin, spacing, turn).
    back = (np.c_[surface.vertices, np.ones(len(surface.vertices))] @ np.linalg.inv(volume.index_to_world()).T)[:, :3]
    assert back.min(axis=0) == pytest.approx(lo, abs=1e-6) and back.max(axis=0) == pytest.approx(hi, abs=1e-6)
    # The ball's own volume, to a step's resolution; negative control: the grid sampled from voxel 0
    # (not every step's centre) is another staircase.
    assert enclosed == pytest.approx(4 / 3 * np.pi * 9.0 ** 3, rel=0.1)
    assert (values[::3, ::3, ::2] == 7).sum() != sampled.sum()


def test_voxel_step_keeps_voxels_under_the_detail():
    from povh3d.volume.surfaces import voxel_step

    assert voxel_step((1.0, 1.0, 1.5), 5.8) == (5, 5, 3)     # 5 mm, 5 mm, 4.5 mm: each under 5.8 mm
    assert voxel_step((1.0, 1.0, 1.5), 0.4) == (1, 1, 1)     # finer than a voxel: the voxels themselves
    assert voxel_step((1.0, 1.0, 1.5), 0.0) == (1, 1, 1)


def test_a_label_thinner_than_the_step_is_kept_from_its_own_voxels():
    # A one-voxel plate (label 5) beside a big block (label 2): sampled every 4 voxels the plate falls
    # between the samples; it comes back from its own voxels, closed, enclosing exactly its voxels.
    values = np.zeros((30, 30, 30), dtype=np.uint8)
    values[3:27, 3:27, 3:20] = 2
    values[4:26, 4:26, 21] = 5
    volume = Volume(values, (1.0, 1.0, 1.0))
    plate, = (s for s in label_surfaces(volume, None, smoothing=0, step=(4, 4, 4)) if s.label == 5)
    assert open_edges(plate.faces) == 0
    assert area_and_volume(plate.vertices, plate.faces)[1] == pytest.approx((values == 5).sum(), rel=1e-6)
    # Negative control: the sampled voxels alone hold none of it.
    assert not (values[2::4, 2::4, 2::4] == 5).any()


@pytest.mark.parametrize("dtype", ["uint8", "int8", "uint16", "int16", "int32", "float32"])
@pytest.mark.parametrize("order", ["C", "F"])
@pytest.mark.parametrize("few", [8, 0], ids=["compared", "table"])
def test_crop_is_the_labels_voxel_box_and_one_voxel_round_it(dtype, order, few, monkeypatch):
    # The crop against the box of np.argwhere over the labels' own voxels, for every dtype (label by
    # label; or the look-up table of 8- and 16-bit labels, a signed value's slot, np.isin for the
    # others) and both memory orders (VTK's files are Fortran-ordered).
    from povh3d.volume import surfaces
    from povh3d.volume.surfaces import _crop

    monkeypatch.setattr(surfaces, "FEW_LABELS", few)

    phantom = asymmetric_phantom()
    values = np.asarray(phantom.values, dtype=dtype, order=order)
    if dtype in ("int8", "int16"):
        values[1, 1, 1] = -3   # a negative label far from the others: its slot must stay its own
    for labels, every in (([LABEL_LEFT], False), ([LABEL_TOP, LABEL_LEFT], False), ([-3], False),
                          ([LABEL_BODY, LABEL_LEFT, LABEL_TOP], dtype not in ("int8", "int16"))):
        if -3 in labels and dtype not in ("int8", "int16"):
            continue
        index = np.argwhere(np.isin(values, labels))
        lo = np.maximum(index.min(axis=0) - 1, 0)
        hi = np.minimum(index.max(axis=0) + 2, values.shape)
        start, box = _crop(values, labels, every)
        assert start == tuple(lo) and np.array_equal(box, values[tuple(slice(a, b) for a, b in zip(lo, hi))])
    # Negative control: the labels' box without its one-voxel margin is another crop.
    assert _crop(values, [LABEL_LEFT])[0] != tuple(np.argwhere(values == LABEL_LEFT).min(axis=0))


@pytest.mark.parametrize("dtype", ["uint8", "uint16", "int16", "int64", "float64"])
def test_present_labels_are_numpys_unique_values(dtype):
    from povh3d.volume.grid import present_labels

    rng = np.random.default_rng(7)
    values = np.asfortranarray(rng.choice([0, 1, 5, 200, 255], size=(30, 20, 10)).astype(dtype))
    if dtype in ("int16", "float64"):
        values[0, 0, 0] = -4   # negative: the np.unique path, where -4 is a label too
    expected = [int(v) for v in np.unique(values) if v != 0]
    assert present_labels(values) == expected
    assert present_labels(np.zeros((2, 2, 2), dtype)) == []
    # Negative control: a value removed is not reported.
    values[values == 5] = 0
    assert 5 not in present_labels(values)
