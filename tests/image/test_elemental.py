"""Per-lens resampling: agrees with the exact reshape where one exists, never mixes lenses."""

import math

import numpy as np
import pytest

from povh3d.image.elemental import extract_views, lens_index_map
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.interleave import extract
from povh3d.display.presets import get_preset, lens_array_from_fields

from tests.support.arrays import lenticular_array, square_array
from tests.support.oracles import turn_elemental_images


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_resampled_extract_equals_exact_extract_on_whole_ppl(dtype):
    la = square_array(lx=7, ly=5, nx=4, ny=3)
    rng = np.random.default_rng(1)
    h3d = rng.integers(0, np.iinfo(dtype).max, (la.panel.height, la.panel.width, 3)).astype(dtype)
    assert np.array_equal(extract_views(h3d, la, (3, 4)), extract(h3d, (3, 4)))


@pytest.mark.parametrize("la", [square_array(lx=6, ly=4, nx=5, ny=5), lenticular_array(lx=6, rows=9, nx=4)],
                         ids=["square", "lenticular"])
def test_turn_equals_flipping_each_lens(la):
    ny, nx = la.views
    rng = np.random.default_rng(2)
    img = rng.integers(0, 255, (la.panel.height, la.panel.width, 3)).astype(np.uint8)
    flipped = img.reshape(la.lenses_y, ny, la.lenses_x, nx, 3)[:, ::-1, :, ::-1].reshape(img.shape)
    assert np.array_equal(turn_elemental_images(img, la), flipped)
    # Negative control: the identity is not a turn.
    assert not np.array_equal(img, flipped)


def test_hex_views_never_mix_lenses():
    la = lens_array_from_fields(get_preset("hex-5.6"))
    la = LensArray("hex", 20, 12, la.pitch_x, la.pitch_y, la.focal, Panel(190, 100, la.panel.pitch_x, la.panel.pitch_y))
    lens_map = lens_index_map(la)
    colours = np.random.default_rng(3).integers(0, 255, (la.lenses_x * la.lenses_y, 3)).astype(np.uint8)
    h3d = np.where((lens_map >= 0)[..., None], colours[np.maximum(lens_map, 0)], 0).astype(np.uint8)
    views = extract_views(h3d, la)
    assert views.shape[:2] == (9, 9)
    expected = colours.reshape(la.lenses_y, la.lenses_x, 3)
    inner = np.abs((np.arange(9) + 0.5 - 4.5))[None, :] * la.panel.pitch_x <= la.pitch_x / 2 - 0.3 * la.panel.pitch_x
    # Views whose offset stays inside the hexagon read only their own lens.
    for l in range(9):
        for k in range(9):
            u, v = (k + 0.5 - 4.5) * la.panel.pitch_x, (4.5 - l - 0.5) * la.panel.pitch_y
            if abs(u) / 2 + math.sqrt(3) / 2 * abs(v) < la.pitch_x / 2 - la.panel.pitch_x and inner[0, k]:
                assert np.array_equal(views[l, k], expected), (l, k)


def test_resampling_works_in_linear_light():
    la = LensArray("square", 1, 1, 0.4, 0.4, 1.0, Panel(4, 4, 0.1, 0.1))
    img = np.zeros((4, 4, 1), np.uint8)
    img[:, 2:] = 255
    # Half way between a black and a white pixel: linear 0.5 -> sRGB 188, not 128.
    pts = np.array([[0.0, 0.05]])
    from povh3d.image.elemental import sample_in_lens
    assert sample_in_lens(img, la, pts, np.array([0]))[0, 0] == 188


def test_hex_inside_is_the_true_hexagon():
    # pixel_rays: a pixel is inside when it lies in its lens's hexagon (flat sides
    # at |dx| = px/2, slanted |dx|/2 + sqrt(3)/2 |dy| = px/2); the circumradius disc
    # used before wrongly took about 2,300 hex-5.6 pixels past the outer rows.
    from povh3d.geometry.rays import pixel_rays

    la = lens_array_from_fields(get_preset("hex-5.6"))
    centres, _, inside = pixel_rays(la)
    X, Y = np.meshgrid(*la.panel.pixel_centres())
    dx, dy = np.abs(X - centres[..., 0]), np.abs(Y - centres[..., 1])
    assert np.all(dx[inside] / 2 + math.sqrt(3) / 2 * dy[inside] <= la.pitch_x / 2 * (1 + 1e-9))
    assert np.all(dx[inside] <= la.pitch_x / 2 * (1 + 1e-9))
    area = la.lenses_x * la.lenses_y * la.pitch_x * la.pitch_y / (la.panel.pitch_x * la.panel.pitch_y)
    assert abs(inside.sum() - area) < 0.01 * area  # hexagon area = px * py per lens
    # Negative control: the circumradius disc takes ~2,300 more pixels.
    near = np.zeros(X.shape, bool)
    r2 = (la.pitch_x / math.sqrt(3)) ** 2
    cs = la.lens_centres().reshape(-1, 2)
    i = np.clip(np.rint(la.lenses_y / 2 - 0.5 - Y / la.pitch_y).astype(int), 0, la.lenses_y - 1)
    for di in (-1, 0, 1):
        ii = np.clip(i + di, 0, la.lenses_y - 1)
        for dj in (-1, 0, 1):
            jj = np.clip(np.rint(X / la.pitch_x + la.lenses_x / 2 - 0.5 - (ii % 2) / 2).astype(int) + dj, 0, la.lenses_x - 1)
            c = cs[ii * la.lenses_x + jj]
            near |= (X - c[..., 0]) ** 2 + (Y - c[..., 1]) ** 2 <= r2
    assert near.sum() - inside.sum() > 2000


@pytest.mark.parametrize("la", [LensArray("hex", 12, 10, 0.6, 0.6 * math.sqrt(3) / 2, 1.5, Panel(80, 60, 0.1, 0.1)),
                                LensArray("square", 11, 8, 0.7, 0.7, 1.5, Panel(80, 60, 0.1, 0.1))],
                         ids=["hex", "fractional"])
def test_nearest_in_lens_picks_the_lens_pixel_weighed_most(la):
    # ids are picked, never blended: each view pixel takes a pixel of its own lens, the nearest of the
    # four the bilinear sample weighs (or, with none of them in the lens, the nearest pixel at all)
    from povh3d.image.elemental import nearest_in_lens, view_points

    pts, lens = view_points(la)
    lens_map = lens_index_map(la)
    H, W = lens_map.shape
    picked = nearest_in_lens(np.arange(H * W).reshape(H, W), la, pts, lens)
    r, c = np.divmod(picked, W)
    centre = np.stack([(c + 0.5 - W / 2) * 0.1, (H / 2 - r - 0.5) * 0.1], axis=-1)
    distance = np.linalg.norm(centre - pts, axis=-1)
    own = lens_map[r, c] == lens
    col, row = pts[..., 0] / 0.1 + W / 2 - 0.5, H / 2 - 0.5 - pts[..., 1] / 0.1
    any_own = np.zeros(lens.shape, bool)
    nearest_own = np.full(lens.shape, np.inf)
    for dr in (0, 1):
        for dc in (0, 1):
            rr = np.clip(np.floor(row).astype(int) + dr, 0, H - 1)
            cc = np.clip(np.floor(col).astype(int) + dc, 0, W - 1)
            mine = lens_map[rr, cc] == lens
            any_own |= mine
            d = np.hypot((cc + 0.5 - W / 2) * 0.1 - pts[..., 0], (H / 2 - rr - 0.5) * 0.1 - pts[..., 1])
            nearest_own = np.where(mine, np.minimum(nearest_own, d), nearest_own)
    assert own[any_own].all() and any_own.mean() > 0.9
    assert np.allclose(distance[any_own], nearest_own[any_own])
    # negative control: the plain nearest pixel crosses into a neighbouring lens
    plain = lens_map[np.clip(np.rint(row).astype(int), 0, H - 1), np.clip(np.rint(col).astype(int), 0, W - 1)]
    assert (plain[any_own] != lens[any_own]).any()
