import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.image.quilt import (auto_grid, bank_to_quilt_order, parse_quilt_name, quilt_name, quilt_to_bank_order,
                                quilt_to_views, view_aspect, views_to_quilt)


def test_view_zero_is_bottom_left_and_order_runs_right_then_up():
    views = np.zeros((6, 2, 3, 1), np.uint8)
    for q in range(6):
        views[q] = q
    quilt = views_to_quilt(views, 3, 2)[..., 0]
    assert quilt[-1, 0] == 0 and quilt[-1, -1] == 2  # bottom row: views 0, 1, 2 left to right
    assert quilt[0, 0] == 3 and quilt[0, -1] == 5    # top row: views 3, 4, 5


@settings(max_examples=30, deadline=None)
@given(cols=st.integers(1, 5), rows=st.integers(1, 4), h=st.integers(1, 5), w=st.integers(1, 5), data=st.data())
def test_quilt_round_trip(cols, rows, h, w, data):
    n = data.draw(st.integers(1, cols * rows))
    views = np.random.default_rng(n).integers(0, 65535, (n, h, w, 3), dtype=np.uint16)
    assert np.array_equal(quilt_to_views(views_to_quilt(views, cols, rows), cols, rows, n), views)


def test_a_device_quilt_is_padded_at_the_right_and_top():
    # the vendor's viewPortion reads the tiles from the bottom left of a quilt a few pixels larger
    views = np.random.default_rng(2).integers(1, 256, (5, 3, 4, 3), dtype=np.uint8)
    padded = views_to_quilt(views, 3, 2, size=(14, 8))
    plain = views_to_quilt(views, 3, 2)
    assert padded.shape == (8, 14, 3)
    assert np.array_equal(padded, np.pad(plain, ((2, 0), (0, 2), (0, 0))))
    assert not np.array_equal(padded[:6, :12], plain)   # control: the padding is not at the bottom
    with pytest.raises(ConfigError):
        views_to_quilt(views, 3, 2, size=(11, 8))


def test_name_carries_grid_and_aspect():
    name = quilt_name("scene", 8, 6, 0.75)
    assert name == "scene_qs8x6a0.75.png"
    assert parse_quilt_name(name) == (8, 6, 0.75)
    assert parse_quilt_name("dir/x_qs5x9a1.7778.png") == (5, 9, 1.7778)
    assert parse_quilt_name("plain.png") is None


def test_bank_order_is_reversed_leftmost_camera_first():
    bank = np.arange(4)[None, :, None, None, None] * np.ones((1, 4, 2, 2, 3), int)
    q = bank_to_quilt_order(bank)
    assert q[0, 0, 0, 0] == 3  # k = Nx-1 (right of the lens centre) sees from the left
    assert np.array_equal(quilt_to_bank_order(q), bank)


def test_bad_grids():
    with pytest.raises(ConfigError, match="do not fit"):
        views_to_quilt(np.zeros((7, 2, 2, 3), np.uint8), 3, 2)
    with pytest.raises(ConfigError, match="equal views"):
        quilt_to_views(np.zeros((5, 9, 3), np.uint8), 3, 2)


# -- the aspect in the name is the view's physical shape --------------------------------------------
def _extent(a):
    return a.lenses_x * a.pitch_x, a.lenses_y * a.pitch_y


def test_aspect_is_physical_not_the_tiles_pixel_shape():
    from povh3d.display.presets import lens_array, lens_array_from_fields

    # 32 x 30 mm lenticular panel: 40 lenses of 8 views, 300 rows -> views of 40 x 300 pixels
    a = lens_array_from_fields({"grid": "lenticular", "lenses": 40, "ppl": 8, "rows": 300,
                                "pixel_pitch": 0.1, "focal": 1.0})
    assert _extent(a) == pytest.approx((32.0, 30.0))
    assert view_aspect(*_extent(a)) == pytest.approx(32 / 30)
    assert 40 / 300 != pytest.approx(view_aspect(*_extent(a)))     # the old, pixel-shape answer
    assert quilt_name("s", 8, 1, view_aspect(*_extent(a))) == "s_qs8x1a1.0667.png"
    b = lens_array("alioscopy-42")                                   # 930 x 523 mm
    assert quilt_name("s", 8, 1, view_aspect(*_extent(b))).endswith("a1.7778.png")


def test_auto_grid_takes_the_device_layout_then_the_squarest_quilt():
    assert auto_grid(48, (560, 420), (8, 6)) == (8, 6)                # Looking Glass Portrait
    assert auto_grid(48, (560, 420), (5, 9)) != (5, 9)                # another device's layout does not fit
    c, r = auto_grid(48, (560, 420))
    assert c * r == 48 and (c, r) == (8, 6)                           # 3360 x 3360
    assert auto_grid(8, (300, 40)) == (8, 1)                          # tall narrow tiles: one row
    assert auto_grid(7, (10, 10)) == (7, 1)
    with pytest.raises(ConfigError):
        auto_grid(0, (1, 1))


def _viewer(l, k, ny, nx):
    # the viewer of bank view (l, k) stands along -(u_k, v_l, f): its x, y (conventions)
    u = (k + 0.5 - nx / 2)
    v = (ny / 2 - l - 0.5)
    return -u, -v


@pytest.mark.parametrize("ny,nx", [(3, 4), (4, 4), (5, 2)])
def test_all_rows_run_left_to_right_then_upward_by_viewer_position(ny, nx):
    bank = np.zeros((ny, nx, 1, 1, 2))
    for l in range(ny):
        for k in range(nx):
            bank[l, k, 0, 0] = _viewer(l, k, ny, nx)
    tiles = bank_to_quilt_order(bank, "all")[:, 0, 0]
    order = np.array([(t // nx, t % nx) for t in range(ny * nx)])     # (quilt row from the bottom, column)
    assert np.all(np.diff(tiles.reshape(ny, nx, 2)[..., 0], axis=1) > 0)   # viewer moves right along a row
    assert np.all(np.diff(tiles.reshape(ny, nx, 2)[..., 1], axis=0) > 0)   # and up row by row
    assert len(order) == len(tiles)
    assert np.array_equal(quilt_to_bank_order(bank_to_quilt_order(bank, "all"), ny), bank)
    # negative control: the bank's own order (no reversal) runs the viewer leftward
    naive = bank.reshape(-1, 1, 1, 2)[:, 0, 0].reshape(ny, nx, 2)
    assert not np.all(np.diff(naive[..., 0], axis=1) > 0)


def test_centre_row_and_refusals():
    bank = np.arange(5)[:, None, None, None, None] * np.ones((5, 3, 1, 1, 1))
    assert np.all(bank_to_quilt_order(bank, "centre") == 2)
    with pytest.raises(ConfigError, match="rows"):
        bank_to_quilt_order(bank)
    with pytest.raises(ConfigError, match="centre or all"):
        bank_to_quilt_order(bank, "middle")


def test_a_device_quilt_from_the_rendered_views_equals_the_one_gathered_from_the_h3d():
    """The vendor's cameras keep their views apart; the quilt tiled from them is the one gathered back
    out of the interleaved image, pixel for pixel (and a bank in the wrong order is not)."""
    from povh3d.display.looking_glass import device
    from povh3d.display.quilt import QuiltViews, device_quilt, quilt_array
    from povh3d.image.interleave import interleave
    from povh3d.image.quilt import quilt_to_bank_order

    dev = device("looking-glass-portrait")
    array = quilt_array(dev, QuiltViews(40.0, dev.nominal_size_mm, "test"))
    tw, th = dev.tile_size
    tiles = np.random.default_rng(5).integers(0, 256, (dev.views, th, tw, 3), dtype=np.uint8)
    bank = quilt_to_bank_order(tiles)
    h3d = interleave(bank)
    gathered = device_quilt(h3d, array, dev)
    assert np.array_equal(device_quilt(h3d, array, dev, bank), gathered)
    assert not np.array_equal(device_quilt(h3d, array, dev, tiles[None]), gathered)   # control: quilt order
