"""df3 files: the layout POV-Ray reads (header, big-endian values, x fastest), 8 and 16 bit."""

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError, InputError
from povh3d.volume.df3 import df3_bytes, padded_shape, quantise, read_df3


def test_header_and_byte_order_by_hand():
    # A 2x1x1 grid [1, 258] at 16 bits, padded to 4x3x3: header 4, 3, 3; the first row is 1, 1, 258, 258.
    data = df3_bytes(np.array([[[1]], [[258]]], dtype=np.uint16), 16)
    assert struct.unpack(">3H", data[:6]) == (4, 3, 3)
    assert len(data) == 6 + 2 * 4 * 3 * 3
    assert data[6:14] == bytes([0, 1, 0, 1, 1, 2, 1, 2])


@pytest.mark.parametrize("bits", [8, 16])
def test_round_trip_x_fastest(bits):
    rng = np.random.default_rng(bits)
    top = (1 << bits) - 1
    samples = rng.integers(0, top + 1, size=(5, 4, 3)).astype(np.uint8 if bits == 8 else np.uint16)
    data = df3_bytes(samples, bits)
    # Independent parse: x fastest, then y, then z.
    nx, ny, nz = struct.unpack(">3H", data[:6])
    assert (nx, ny, nz) == padded_shape(samples.shape) == (7, 6, 5)
    flat = np.frombuffer(data[6:], dtype=f">u{bits // 8}")
    assert flat.size == nx * ny * nz
    grid = flat.reshape(nz, ny, nx).transpose(2, 1, 0)
    assert np.array_equal(grid[1:-1, 1:-1, 1:-1], samples)
    # The pad is a copy of the edge on every side.
    assert np.array_equal(grid[0, 1:-1, 1:-1], samples[0]) and np.array_equal(grid[-1, 1:-1, 1:-1], samples[-1])
    assert np.array_equal(grid[1:-1, 1:-1, 0], samples[:, :, 0]) and grid[0, 0, 0] == samples[0, 0, 0]
    densities, read_bits = read_df3(data)
    assert read_bits == bits
    assert np.allclose(densities[1:-1, 1:-1, 1:-1], samples / top)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-0.5, 1.5, allow_nan=False), min_size=1, max_size=30), st.sampled_from([8, 16]))
def test_quantise_error_is_half_a_step(values, bits):
    f = np.array(values, dtype=np.float32)
    q = quantise(f, bits)
    top = (1 << bits) - 1
    assert q.dtype.itemsize == bits // 8
    assert np.all(np.abs(q / top - np.clip(f, 0, 1)) <= 0.5 / top + 1e-6)


def test_8_bit_is_half_the_size_of_16():
    samples = np.zeros((10, 10, 10), dtype=np.uint8)
    assert len(df3_bytes(samples, 16)) - 6 == 2 * (len(df3_bytes(samples, 8)) - 6)


def test_bad_inputs():
    with pytest.raises(ConfigError, match="df3_bits must be 8 or 16"):
        df3_bytes(np.zeros((2, 2, 2), dtype=np.uint8), 12)
    with pytest.raises(ConfigError, match="0..255"):
        df3_bytes(np.full((2, 2, 2), 300, dtype=np.uint16), 8)
    with pytest.raises(InputError, match="do not fit"):
        read_df3(struct.pack(">3H", 2, 2, 2) + b"\0" * 7)
    with pytest.raises(InputError, match="header"):
        read_df3(b"\0\1")
