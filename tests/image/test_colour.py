"""The sRGB transfer functions (povh3d.colour): tables against the formula, the mean in linear light."""

import numpy as np
import pytest

from povh3d.image.colour import decode, encode, linear_to_srgb, mean_in_linear_light, srgb_to_linear


@pytest.mark.parametrize("code", [np.uint8, np.uint16])
@pytest.mark.parametrize("work", [np.float32, np.float64])
def test_decode_table_is_the_formula_for_every_code(code, work):
    top = np.iinfo(code).max
    codes = np.arange(top + 1, dtype=code)
    expected = srgb_to_linear(codes.astype(work) / work(top), work)
    got = decode(codes, work)
    assert got.dtype == work and np.array_equal(got, expected)
    # IEC 61966-2-1 anchors: 0 -> 0, top -> 1, code 0.04045*top in the linear toe.
    assert got[0] == 0 and got[-1] == pytest.approx(1.0, abs=1e-7)


def test_encode_inverts_decode():
    codes = np.arange(256, dtype=np.uint8)
    assert np.array_equal(encode(decode(codes)), codes)
    assert np.array_equal(encode(decode(np.arange(65536, dtype=np.uint16)), np.uint16), np.arange(65536))


def test_mean_in_linear_light_is_the_linear_mean_encoded():
    rng = np.random.default_rng(1)
    images = rng.integers(0, 256, (7, 5, 4, 3), dtype=np.uint8)
    linear = srgb_to_linear(images / 255.0)
    assert np.array_equal(mean_in_linear_light(images), np.rint(linear_to_srgb(linear.mean(axis=0)) * 255))
    # Black and white average to linear 0.5, sRGB code 188, not the code midpoint 128.
    pair = np.array([[[0, 0, 0]], [[255, 255, 255]]], np.uint8)
    assert mean_in_linear_light(pair).tolist() == [[188, 188, 188]]
