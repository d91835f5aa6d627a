import numpy as np
import pytest

from povh3d.image.colour import decode, encode, linear_to_srgb, mean_in_linear_light, srgb_to_linear
from povh3d.geometry.footprint import GRID, angular_grid, latin_hypercube


def test_angular_grid_cuts_the_pixel_angle_into_equal_cells():
    g = angular_grid(3)
    assert g.shape == (9, 4)
    assert np.all(g[:, :2] == 0)  # the aperture is left to antialiasing
    # Cell centres, on the 1/2048 grid that keeps mesh-camera corners exact in float32.
    np.testing.assert_allclose(sorted(set(g[:, 2])), [-1 / 3, 0, 1 / 3], atol=0.5 / GRID)
    assert np.array_equal(g * GRID, np.round(g * GRID))
    np.testing.assert_array_equal(angular_grid(1), np.zeros((1, 4)))


@pytest.mark.parametrize("count", [3, 7, 64, 2048])
def test_latin_hypercube_samples_sit_on_the_grid(count):
    s = latin_hypercube(count, seed=5)
    assert np.array_equal(s * GRID, np.round(s * GRID))
    with pytest.raises(ValueError, match="1 to 2048"):
        latin_hypercube(GRID + 1)


@pytest.mark.parametrize("count", [1, 7, 64])
def test_latin_hypercube_hits_every_stratum_of_every_axis_once(count):
    s = latin_hypercube(count, seed=3)
    assert s.shape == (count, 4) and np.all(s >= -0.5) and np.all(s < 0.5)
    strata = np.floor((s + 0.5) * count).astype(int)
    for axis in range(4):
        assert sorted(strata[:, axis]) == list(range(count))
    assert not np.array_equal(s, latin_hypercube(count, seed=4)) or count == 1


def test_srgb_round_trips_and_averages_in_linear_light():
    x = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-12)
    assert srgb_to_linear(0.5) == pytest.approx(0.214041, abs=1e-6)
    img = np.arange(256, dtype=np.uint8)
    np.testing.assert_array_equal(encode(decode(img), np.uint8), img)
    # Black and white average to linear 0.5, which sRGB encodes as 188, not 128.
    pair = np.array([[0], [255]], dtype=np.uint8)
    assert mean_in_linear_light(pair)[0] == 188
