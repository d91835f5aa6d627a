import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.image.interleave import extract, interleave, tile_elemental_images


def test_interleave_follows_conventions_index_formula():
    rng = np.random.default_rng(1)
    views = rng.integers(0, 255, size=(2, 3, 4, 5, 3), dtype=np.uint8)  # Ny, Nx, Ly, Lx, C
    h3d = interleave(views)
    assert h3d.shape == (8, 15, 3)
    for i, l, j, k in [(0, 0, 0, 0), (3, 1, 4, 2), (2, 0, 1, 1)]:
        assert np.array_equal(h3d[i * 2 + l, j * 3 + k], views[l, k, i, j])


@settings(max_examples=80, deadline=None)
@given(ny=st.integers(1, 6), nx=st.integers(1, 9), ly=st.integers(1, 7), lx=st.integers(1, 7),
       channels=st.sampled_from([None, 1, 3, 4]), dtype=st.sampled_from([np.uint8, np.uint16, np.float32]),
       seed=st.integers(0, 2**32 - 1))
def test_extract_inverts_interleave(ny, nx, ly, lx, channels, dtype, seed):
    rng = np.random.default_rng(seed)
    shape = (ny, nx, ly, lx) + ((channels,) if channels else ())
    views = rng.integers(0, 60000, size=shape).astype(dtype)
    h3d = interleave(views)
    assert h3d.dtype == views.dtype
    assert np.array_equal(extract(h3d, (ny, nx)), views)
    assert np.array_equal(interleave(extract(h3d, (ny, nx))), h3d)


def test_tile_elemental_images_is_interleave_transposed():
    rng = np.random.default_rng(2)
    elemental = rng.random((3, 4, 2, 5, 3))  # Ly, Lx, Ny, Nx, C
    views = elemental.transpose(2, 3, 0, 1, 4)
    assert np.array_equal(tile_elemental_images(elemental), interleave(views))


def test_extract_rejects_partial_lenses():
    with pytest.raises(ValueError, match="whole lenses"):
        extract(np.zeros((10, 10, 3)), (3, 3))


@pytest.mark.parametrize("shape", [(1, 8, 601, 240, 3), (3, 5, 397, 160, 4)])
def test_large_stacks_split_over_threads_match_one_transpose(shape):
    # Big enough (over 2 MB) that on two or more cores the copy is split by lens rows over worker threads,
    # with a lens-row count that does not divide evenly.
    rng = np.random.default_rng(3)
    views = rng.integers(0, 255, size=shape, dtype=np.uint8)
    ny, nx, ly, lx, c = shape
    expected = views.transpose(2, 0, 3, 1, 4).reshape(ly * ny, lx * nx, c)
    h3d = interleave(views)
    assert np.array_equal(h3d, expected)
    assert np.array_equal(extract(h3d, (ny, nx)), views)
