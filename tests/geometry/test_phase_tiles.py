"""Phase tiles of rational slanted sheets (``geometry.phase_tiles``).

Oracles: the ray of every pixel from docs/geometry.md (``pixel_rays``), reached
through POV-Ray's mesh-camera lookup simulated in NumPy; the thesis's panels'
periods (Philips: 4.5 subpixels a lens, 0.5 a row -> 9 x 9 cosets; Alioscopy:
8 and 1 -> 8 x 8); an irrational sheet has no tiles.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.phase_tiles import phase_tiles, tiles_mesh, uncovered
from povh3d.geometry.rays import pixel_rays

from tests.geometry.test_rotated_lattice import simulate_lookup


def sheet(per_row: float, slope: float, width: int = 96, height: int = 40, lenses: int | None = None) -> LensArray:
    """A sheet over a subpixel panel (cells 0.1/3 x 0.1 mm): ``per_row`` subpixels wide along a
    row, moving ``slope`` subpixels right per row down."""
    sx, sy = 0.1 / 3, 0.1
    turn = math.atan(slope * sx / sy)
    pitch = per_row * sx * math.cos(turn)
    reach = width * sx * math.cos(turn) + height * sy * abs(math.sin(turn))
    lx = lenses or (math.ceil(reach / pitch) + 1 if slope else math.floor(width / per_row))
    return LensArray("lenticular", lx, height, pitch, sy, 1.2, Panel(width, height, sx, sy), math.degrees(turn))


def test_periods_of_the_thesis_panels():
    assert phase_tiles(sheet(4.5, 0.5)).period == (9, 9)        # Philips, in subpixel units
    assert phase_tiles(sheet(8.0, 1.0)).period == (8, 8)        # Alioscopy
    assert phase_tiles(sheet(6.0, 0.0)).period == (6, 1)        # upright, 6 subpixels a lens
    assert phase_tiles(sheet(math.pi, 0.5)) is None            # no period: strips instead
    assert phase_tiles(LensArray("square", 10, 8, 0.6, 0.6, 1.5, Panel(60, 48, 0.1, 0.1))) is None


def test_tiles_are_a_permutation_of_the_panel():
    tiles = phase_tiles(sheet(4.5, 0.5, 100, 41))
    rows, cols = tiles.panel_index()
    w, h = tiles.image_size
    flat = (rows[:, None] * w + cols[None, :]).ravel()
    assert len(np.unique(flat)) == flat.size and flat.max() < w * h


@pytest.mark.parametrize("per_row,slope", [(4.5, 0.5), (8.0, 1.0), (8.0, -1.0), (6.0, 0.0), (4.5, 1 / 3)])
def test_every_pixel_ray_through_the_tiles(per_row, slope):
    la = sheet(per_row, slope)
    tiles = phase_tiles(la)
    mesh = tiles_mesh(la, tiles, 10.0)
    assert len(mesh.faces) == 2 * tiles.period[0] * tiles.period[1]
    assert mesh.uvs[:, 1].min() > 0 and mesh.uvs.max() < 1
    origin, normal, margin = (tiles.to_panel(a[1:, :-1]) for a in simulate_lookup(mesh))
    centres, dirs, inside = pixel_rays(la)
    assert inside.all()
    # Every lookup finds a face (the quad's inner diagonal is shared by one affine map).
    assert margin.min() >= 0
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    np.testing.assert_allclose(d, dirs, atol=1e-9)
    t = -origin[..., 2] / d[..., 2]
    np.testing.assert_allclose(origin[..., :2] + t[..., None] * d[..., :2], centres, atol=1e-9)


def test_ties_go_to_the_lens_on_the_right():
    # An Alioscopy sheet over an even number of lenses puts every 8th pixel centre on a lens border.
    la = sheet(8.0, 1.0, 96, 40, lenses=18)
    X, Y = la.to_lattice(*np.meshgrid(*la.panel.pixel_centres()))
    t = X / la.pitch_x + la.lenses_x / 2
    ties = np.abs(t - np.rint(t)) < 1e-9
    assert ties.sum() > 100
    tiles = phase_tiles(la)
    origin, normal, _ = (tiles.to_panel(a[1:, :-1]) for a in simulate_lookup(tiles_mesh(la, tiles, 10.0)))
    centres, dirs, inside = pixel_rays(la)
    ok = inside & ties
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    np.testing.assert_allclose(d[ok], dirs[ok], atol=1e-9)
    assert np.all(dirs[ok][:, 0] * math.cos(math.radians(la.rotation)) + dirs[ok][:, 1]
                  * math.sin(math.radians(la.rotation)) < 0)  # the left edge of the lens on the right


def test_uncovered_pixels_are_those_outside_every_lens():
    la = sheet(8.0, 1.0, 96, 40, lenses=8)  # too few lenses to cover the panel
    _, _, inside = pixel_rays(la)
    np.testing.assert_array_equal(uncovered(la), ~inside)
    assert uncovered(sheet(8.0, 1.0)) is None
