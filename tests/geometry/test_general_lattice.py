"""General lattices given by two vectors (docs/geometry.md, "General lattices"), checked
without POV-Ray: which lens a pixel belongs to, its ray, and the sheared mesh camera.

Oracles: a brute-force search over every lens's parallelogram; for a cross-lenticular
sheet, the overlap of a vertical strip and a slanted strip worked out from the two
sheets directly (not from the lattice vectors); and the rotated square grid, which is
the lattice of the turned pitch vectors and must give the very same rays.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from povh3d.errors import ConfigError
from povh3d.geometry.lattice import cross_lenticular_basis
from povh3d.geometry.lattice_mesh import lens_mesh
from povh3d.geometry.lens_array import LensArray, Panel, lattice_array
from povh3d.display.presets import lens_array as preset_array
from povh3d.display.presets import parse_lattice
from povh3d.geometry.rays import pixel_rays

from tests.geometry.test_rotated_lattice import simulate_lookup

PANEL = Panel(60, 45, 0.1, 0.1)
BASES = {"cross-6.34": cross_lenticular_basis(0.55, 0.55, 6.34), "cross-18.43": cross_lenticular_basis(0.55, 0.5, 18.43),
         "skewed": ((0.6, 0.05), (0.3, 0.6)), "cross-turned": cross_lenticular_basis(0.6, 0.6, 6.34, turn_deg=18.43)}


def lattice(name: str, lenses=(16, 14)) -> LensArray:
    return lattice_array(BASES[name], *lenses, 1.5, PANEL)


@pytest.mark.parametrize("name", BASES)
def test_pixel_belongs_to_the_parallelogram_that_holds_it(name):
    la = lattice(name)
    centres, dirs, inside = pixel_rays(la)
    X, Y = np.meshgrid(*PANEL.pixel_centres())
    b = np.array(la.basis).T
    lenses = la.lens_centres().reshape(-1, 2)
    st = np.einsum("ij,hwnj->hwni", np.linalg.inv(b), np.stack([X, Y], -1)[:, :, None, :] - lenses)
    # Half-open cells: a pixel centre on a border goes to the lens on the right (below).
    st[..., 1] *= -1
    cell = np.all((st >= -0.5 - 1e-9) & (st < 0.5 - 1e-9), axis=-1)  # (H, W, lenses)
    np.testing.assert_array_equal(inside, cell.any(axis=-1))
    assert np.all(cell.sum(axis=-1) <= 1)
    np.testing.assert_allclose(centres[inside], lenses[cell.argmax(axis=-1)][inside], atol=1e-12)
    u = np.stack([X, Y], -1) - centres
    expected = np.concatenate([u, np.full(u.shape[:2] + (1,), la.focal)], axis=-1)
    expected /= np.linalg.norm(expected, axis=-1, keepdims=True)
    np.testing.assert_allclose(dirs[inside], expected[inside], atol=1e-12)


@pytest.mark.parametrize("slant", [6.34, 18.43, -9.46])
def test_cross_lenticular_cells_are_the_overlaps_of_the_two_sheets(slant):
    # Vertical strips |x - xj| < p/2 and slanted strips |n.(x, y) - d_i| < p/2, n = (-sin, cos):
    # a pixel's lens centre is where its vertical lenticule axis meets its slanted one.
    p = 0.55
    la = lattice_array(cross_lenticular_basis(p, p, slant), 16, 14, 1.5, PANEL)
    centres, _, inside = pixel_rays(la)
    X, Y = np.meshgrid(*PANEL.pixel_centres())
    t = math.radians(slant)
    j = np.floor(X / p + la.lenses_x / 2)        # vertical strip
    xj = (j + 0.5 - la.lenses_x / 2) * p
    across = -math.sin(t) * X + math.cos(t) * Y  # position across the slanted lenticules
    i = np.floor(la.lenses_y / 2 - across / p)
    d = (la.lenses_y / 2 - i - 0.5) * p
    axis_y = (d + math.sin(t) * xj) / math.cos(t)  # the slanted axis n.(x, y) = d at x = xj
    expected = np.stack([xj, axis_y], axis=-1)
    np.testing.assert_allclose(centres[inside], expected[inside], atol=1e-12)
    assert inside.mean() > 0.99


@pytest.mark.parametrize("rotation", [6.34, -30.0])
def test_a_turned_square_grid_is_the_lattice_of_its_turned_vectors(rotation):
    square = LensArray("square", 16, 14, 0.55, 0.5, 1.5, PANEL, rotation)
    t = math.radians(rotation)
    vectors = ((0.55 * math.cos(t), 0.55 * math.sin(t)), (-0.5 * math.sin(t), 0.5 * math.cos(t)))
    general = lattice_array(vectors, 16, 14, 1.5, PANEL)
    for a, b in zip(pixel_rays(square), pixel_rays(general)):
        np.testing.assert_allclose(a, b, atol=1e-12)


@pytest.mark.parametrize("name", BASES)
def test_sheared_mesh_camera_traces_every_pixel_exactly(name):
    la = lattice(name)
    mesh = lens_mesh(la, 20.0)
    assert mesh.shear is not None and mesh.uvs.min() > 0 and mesh.uvs.max() < 1
    origin, normal, found = (mesh.crop(a[1:, :-1]) for a in simulate_lookup(mesh))
    k = np.array(mesh.shear).reshape(2, 2)  # POV-Ray: origins by K, normals by K^-T
    origin = np.concatenate([origin[..., :2] @ k.T, origin[..., 2:]], axis=-1)
    normal = np.concatenate([normal[..., :2] @ np.linalg.inv(k), normal[..., 2:]], axis=-1)
    centres, dirs, inside = pixel_rays(la)
    assert np.all(found[inside] > -1e-9) and np.all(found[~inside] < 0)
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    # Exact but for the tie shift off pixel centres on cell edges (all these lattices have
    # some): TIE_SHIFT of a pixel makes the corner offsets differ in length by ~1e-5.
    np.testing.assert_allclose(d[inside], dirs[inside], atol=2e-5)
    hit = origin[..., :2] - (origin[..., 2] / d[..., 2])[..., None] * d[..., :2]
    np.testing.assert_allclose(hit[inside], centres[inside], atol=5e-4)  # 0.005 pixel


def test_unsheared_parallelograms_would_miss(monkeypatch):
    # Control: the parallelograms written as they are, POV-Ray's normalised-normal interpolation bends the rays.
    from povh3d.geometry import lattice_mesh

    monkeypatch.setattr(lattice_mesh, "_unshear", lambda la, ox, oy, u, v: (None, ox, oy, u, v))
    la = lattice("skewed")
    mesh = lens_mesh(la, 20.0)
    assert mesh.shear is None
    _, normal, _ = (mesh.crop(a[1:, :-1]) for a in simulate_lookup(mesh))
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    _, dirs, inside = pixel_rays(la)
    assert np.abs(d[inside] - dirs[inside]).max() > 50 * 2e-5  # measured 4e-3


def test_lattice_field_forms_and_preset():
    assert parse_lattice("0.6,0;0.1,0.6") == ((0.6, 0.0), (0.1, 0.6))
    assert parse_lattice([[-0.6, 0], [0.1, -0.6]]) == ((0.6, 0.0), (-0.1, 0.6))  # oriented: same lattice
    a1, a2 = parse_lattice("cross:2.12,6.34")
    assert a1 == pytest.approx((2.12, 2.12 / 9), rel=1e-3) and a2[0] == 0
    la = preset_array("cross-lenticular-ipad")
    assert la.grid == "lattice" and la.pitch_x == pytest.approx(2.12) and la.pitch_y == pytest.approx(2.12)
    assert pixel_rays(la)[2].all(), "the preset's lenses cover the whole panel"
    assert la.views is None and la.as_record()["lattice_mm"][0][0] == pytest.approx(2.12)
    turned = preset_array("cross-lenticular-ipad", lens_rotation=18.43)
    assert turned.basis[1][0] < 0 and pixel_rays(turned)[2].all()


@pytest.mark.parametrize("text", ["0.6,0", "0.6,0;0.6,0.01", "cross:0.8", "cross:-1,5", "cross:1,50", "a,b;c,d",
                                  "nan,0;0,1", "0,0;0,1"])
def test_bad_lattices_are_one_config_error(text):
    with pytest.raises(ConfigError):
        preset_array("demo", lattice=text)


def test_lattice_with_grid_options_is_refused():
    with pytest.raises(ConfigError, match="drop ppl"):
        preset_array("demo", lattice="cross:0.8,6.34", ppl=4)
    with pytest.raises(ConfigError, match="turn its vectors"):
        LensArray("lattice", 4, 4, 0.6, 0.6, 1.5, PANEL, 5.0, ((0.6, 0.0), (0.0, 0.6)))
    with pytest.raises(ConfigError, match="build it with lattice_array"):
        LensArray("lattice", 4, 4, 0.6, 0.6, 1.5, PANEL, 0.0, ((0.6, 0.1), (0.0, 0.7)))


@pytest.mark.parametrize("name", BASES)
def test_lens_index_map_names_the_owning_lens(name):
    # extract / preview / refocus read each lens from its own pixels (image/elemental.py).
    from povh3d.image.elemental import lens_index_map

    la = lattice(name)
    centres, _, inside = pixel_rays(la)
    index = lens_index_map(la)
    np.testing.assert_array_equal(index >= 0, inside)
    np.testing.assert_allclose(la.lens_centres().reshape(-1, 2)[index[inside]], centres[inside], atol=1e-12)


def test_lens_count_gives_the_panel_that_holds_every_cell():
    la = preset_array("demo", lattice="cross:0.8,6.34", lenses=[10, 8])
    assert (la.lenses_x, la.lenses_y) == (10, 8)
    w, h = la.panel.size_mm
    corners = la.lens_centres()[..., None, :] + np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) @ np.array(la.basis) / 2
    assert np.all(np.abs(corners[..., 0]) <= w / 2 + 1e-9) and np.all(np.abs(corners[..., 1]) <= h / 2 + 1e-9)
    assert w / 2 - np.abs(corners[..., 0]).max() < la.panel.pitch_x  # and no more than that
