import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.image.quilt import (bank_to_quilt_order, parse_quilt_name, quilt_name, quilt_to_bank_order,
                                quilt_to_views, views_to_quilt)


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
