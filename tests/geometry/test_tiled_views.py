"""``camera_mesh.tiled_views_mesh``: orthographic views tiled into one mesh camera (the depth maps' pass)."""

from __future__ import annotations

import numpy as np

from povh3d.geometry.camera_mesh import tiled_views_mesh
from povh3d.geometry.view_bank import bank_front_clearance

from tests.support.arrays import square_array
from tests.support.oracles import mesh_rays, view_bank_mesh


def _rays_mm(mesh, cols, rows):
    """Origins (mm) and unit directions POV-Ray shoots: the origin scaled, the normal by the inverse scale."""
    r = mesh_rays(mesh, cols, rows)
    scale = np.array(mesh.scale)
    d = r[:, 3:] / scale
    return r[:, :3] * scale, d / np.linalg.norm(d, axis=1, keepdims=True)


def test_each_tile_holds_the_rays_of_its_orthographic_camera():
    """Pixel (i, j) of view n's tile: direction (a, b, 1) through the cell centre (x_j, y_i, 0), started
    ``front_clearance`` before the screen: the ray of ``orthographic`` with location -fc (a, b, 1),
    right ``cols px``, up ``rows py`` (POV-Ray: location + ((j + 0.5)/W - 0.5) right + (0.5 - (i + 0.5)/H) up)."""
    views, cells, pitch, fc = (2, 3), (5, 4), (0.7, 0.45), 12.5
    slopes = np.array([[0.1 * k - 0.1, 0.3 - 0.2 * l] for l in range(2) for k in range(3)]) + [0.013, -0.007]
    mesh = tiled_views_mesh(slopes, views, cells, pitch, fc)
    assert mesh.image_size == (3 * 5 + 1, 2 * 4 + 1)
    rows, cols = np.meshgrid(np.arange(8), np.arange(15), indexing="ij")
    origin, direction = _rays_mm(mesh, cols.ravel(), rows.ravel())
    l, i, k, j = rows.ravel() // 4, rows.ravel() % 4, cols.ravel() // 5, cols.ravel() % 5
    a, b = slopes[l * 3 + k].T
    x = ((j + 0.5) / 5 - 0.5) * 5 * 0.7
    y = (0.5 - (i + 0.5) / 4) * 4 * 0.45
    want = np.column_stack([x - fc * a, y - fc * b, np.full_like(x, -fc)])
    unit = np.column_stack([a, b, np.ones_like(a)]) / np.sqrt(a * a + b * b + 1)[:, None]
    assert np.abs(origin - want).max() < 1e-12 and np.abs(direction - unit).max() < 1e-12
    # negative control: views in column-major order are other views' rays
    c = np.abs(direction - np.column_stack([*slopes[k * 2 + l].T, np.ones_like(a)])
               / np.sqrt((slopes[k * 2 + l] ** 2).sum(1) + 1)[:, None]).max()
    assert c > 0.01


def test_a_lens_arrays_views_are_its_view_banks_rays():
    """With a lens array's slopes ``(u_k, v_l) / f`` over its lens centres, the tiled views are the render's
    own view bank (``view_bank``, built apart), pixel for pixel."""
    la = square_array(lx=6, ly=4, nx=3, ny=2)
    fc = bank_front_clearance(la, 5.0)
    ny, nx = la.require_views()
    s, f = la.panel.pitch_x, la.focal
    slopes = np.array([((k + 0.5 - nx / 2) * s / f, (ny / 2 - l - 0.5) * s / f) for l in range(ny) for k in range(nx)])
    tiled = tiled_views_mesh(slopes, (ny, nx), (la.lenses_x, la.lenses_y), (la.pitch_x, la.pitch_y), fc)
    bank = view_bank_mesh(la, fc)
    assert tiled.image_size == bank.image_size
    rows, cols = np.meshgrid(np.arange(ny * la.lenses_y), np.arange(nx * la.lenses_x), indexing="ij")
    got, want = _rays_mm(tiled, cols.ravel(), rows.ravel()), _rays_mm(bank, cols.ravel(), rows.ravel())
    assert np.abs(got[0] - want[0]).max() < 1e-9 and np.abs(got[1] - want[1]).max() < 1e-12
    # negative control: another clearance starts the rays elsewhere
    other = _rays_mm(tiled_views_mesh(slopes, (ny, nx), (la.lenses_x, la.lenses_y), (la.pitch_x, la.pitch_y),
                                      fc + 1), cols.ravel(), rows.ravel())
    assert np.abs(other[0] - want[0]).max() > 0.5
