import numpy as np
import pytest

from povh3d.image.colour import decode, encode, linear_to_srgb, mean_in_linear_light, srgb_to_linear
from povh3d.geometry.footprint import GRID, angular_grid, latin_hypercube, scrambled_sobol


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


def test_sobol_points_are_scipys_sequence_on_the_grid():
    """The unscrambled sequence is SciPy's (an independent implementation), floored onto the grid."""
    qmc = pytest.importorskip("scipy.stats.qmc")
    expected = np.floor(qmc.Sobol(4, scramble=False).random(1024) * GRID) / GRID - 0.5
    assert np.array_equal(scrambled_sobol(1024, None), expected)
    assert np.array_equal(scrambled_sobol(24, None, start=1000), expected[1000:])
    assert not np.array_equal(scrambled_sobol(1024, 1), expected)   # scrambled: another set


def _is_net(points, m):
    """Whether every ``2^a x 2^(m-a)`` box of the first two axes holds one of ``2^m`` points."""
    u = points[:, :2] + 0.5
    return all(len({(int(x * 2 ** a), int(y * 2 ** (m - a))) for x, y in u}) == 2 ** m for a in range(m + 1))


@pytest.mark.parametrize("seed", [1, 7])
def test_scrambled_sobol_points_stratify_axes_and_planes_and_continue(seed):
    """Every aligned block of ``2^m`` scrambled points hits each of ``2^m`` strata of every axis once,
    and is a net of the first two axes' plane (one point in every elementary box); a later block
    continues the same sequence, and another seed is another set.  A Latin hypercube of 16, the
    negative control, stratifies the axes but not the plane."""
    points = scrambled_sobol(64, seed)
    assert np.all(points >= -0.5) and np.all(points < 0.5) and np.array_equal(points, np.round(points * GRID) / GRID)
    for m in (2, 4, 6):
        for block in points.reshape(-1, 2 ** m, 4):
            assert all(len(set(np.floor((block[:, a] + 0.5) * 2 ** m).astype(int))) == 2 ** m for a in range(4))
            assert _is_net(block, m)
    assert np.array_equal(scrambled_sobol(40, seed, start=24), points[24:])
    assert not np.allclose(scrambled_sobol(64, seed + 1), points)
    assert not _is_net(latin_hypercube(16, seed), 4)
