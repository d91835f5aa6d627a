import numpy as np
import pytest

from povh3d.image.interleave import extract, interleave
from povh3d.image.colour import from_linear, to_linear
from povh3d.image.resample import (resample_matrix, resample_micro_images,
    trade_views_for_lenses)


def test_srgb_round_trip_and_half_grey():
    x = np.arange(256, dtype=np.uint8)
    assert np.array_equal(from_linear(to_linear(x)), x)
    x16 = np.arange(0, 65536, 7, dtype=np.uint16)
    assert np.abs(from_linear(to_linear(x16), np.uint16).astype(int) - x16).max() <= 1
    assert from_linear(np.float32(0.5)) == 188  # linear 50 % is sRGB 188, not 128


@pytest.mark.parametrize("n_in, n_out", [(30, 10), (7, 3), (4, 9), (5, 5)])
def test_resample_matrix_rows_sum_to_one(n_in, n_out):
    m = resample_matrix(n_in, n_out)
    assert m.shape == (n_out, n_in) and np.allclose(m.sum(axis=1), 1) and (m >= 0).all()


def test_30_to_10_pixels_per_lens_averages_in_linear_light():
    rng = np.random.default_rng(1)
    h3d = rng.integers(0, 256, (6, 4 * 30, 3), dtype=np.uint8)  # lenticular, 4 lenses of 30 px
    out = resample_micro_images(h3d, (1, 30), (1, 10))
    assert out.shape == (6, 40, 3)
    expect = from_linear(to_linear(h3d).reshape(6, 40, 3, 3).mean(axis=2))  # 3 neighbours -> 1
    assert np.abs(out.astype(int) - expect.astype(int)).max() <= 1
    naive = h3d.reshape(6, 40, 3, 3).astype(float).mean(axis=2)  # sRGB averaging: a negative control
    assert np.abs(out.astype(float) - naive).max() > 5


def test_micro_images_never_mix_across_lenses():
    h3d = np.zeros((4, 6 * 8, 3), np.uint8)
    h3d[:, 8:16] = 255  # lens 1 white, others black
    out = resample_micro_images(h3d, (1, 8), (1, 3))
    assert (out[:, 3:6] == 255).all() and (out[:, :3] == 0).all() and (out[:, 6:] == 0).all()
    assert np.array_equal(resample_micro_images(h3d, (1, 8), (1, 8)), h3d)


def test_trading_views_for_lenses_keeps_size_and_angles():
    ly, lx, nx = 4, 5, 6
    views = np.zeros((1, nx, ly, lx, 3), np.uint8)
    for k in range(nx):
        views[0, k] = 40 * k  # each view a flat grey
    out = trade_views_for_lenses(interleave(views), (1, 6), (1, 2))  # 6 PPL -> 3 lenses of 2 PPL (Fig. C.2)
    assert out.shape == (ly, lx * nx, 3)
    got = extract(out, (1, 2))
    assert got.shape[3] == 3 * lx
    lin = to_linear(np.array([40 * k for k in range(nx)], np.uint8))
    for m in range(2):
        assert np.abs(got[0, m].astype(int) - int(from_linear(lin[3 * m:3 * m + 3].mean()))).max() <= 1
    with pytest.raises(ValueError, match="multiple"):
        trade_views_for_lenses(interleave(views), (1, 6), (1, 4))
