"""The row gather (povh3d.image.kernels) against the NumPy reference paths."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.image import kernels as _kernels
from povh3d.image.interleave import extract, interleave
from tests.support.oracles import extract_reference, interleave_reference

DTYPES = [np.uint8, np.int8, np.uint16, np.int32, np.float32, np.float64, np.complex128]


@settings(max_examples=120, deadline=None)
@given(ny=st.integers(1, 5), nx=st.integers(1, 11), ly=st.integers(1, 6), lx=st.integers(1, 19),
       channels=st.sampled_from([None, 1, 2, 3, 4, 5]), dtype=st.sampled_from(DTYPES),
       seed=st.integers(0, 2**32 - 1))
def test_interleave_and_extract_match_reference(ny, nx, ly, lx, channels, dtype, seed):
    # Lens rows of more and fewer than 8 pixels exercise the packed 3-byte groups and their tails.
    rng = np.random.default_rng(seed)
    shape = (ny, nx, ly, lx) + ((channels,) if channels else ())
    views = rng.integers(0, 120, size=shape).astype(dtype)
    h3d = interleave(views)
    ref = interleave_reference(views)
    assert h3d.dtype == ref.dtype and np.array_equal(h3d, ref)
    assert np.array_equal(extract(h3d, (ny, nx)), extract_reference(ref, (ny, nx)))


def test_fast_path_is_taken_and_exact_at_full_hd():
    views = np.random.default_rng(0).integers(0, 256, (1, 8, 1080, 240, 3), dtype=np.uint8)
    calls = []
    original = _kernels.gather

    def spy(*args):
        calls.append(1)
        return original(*args)

    _kernels.gather = spy
    try:
        h3d = interleave(views)
        back = extract(h3d, (1, 8))
    finally:
        _kernels.gather = original
    assert len(calls) == 2  # neither fell back to the plane-by-plane copy
    assert np.array_equal(h3d, views.transpose(2, 0, 3, 1, 4).reshape(1080, 1920, 3))
    assert np.array_equal(back, views)


def test_last_pixel_of_the_buffer_is_not_over_read():
    # A view stack ending at a page boundary: no read past its last byte (that would fault), and the
    # last pixel still right.
    import mmap

    page = mmap.PAGESIZE
    n = (1 * 8 * 4 * 16 * 3)
    buf = mmap.mmap(-1, 2 * page)
    arr = np.frombuffer(buf, np.uint8, count=n, offset=2 * page - n).reshape(1, 8, 4, 16, 3)
    arr[...] = np.arange(arr.size, dtype=np.uint32).reshape(arr.shape) % 251
    assert np.array_equal(interleave(arr), interleave_reference(arr))


def test_non_contiguous_stacks_use_the_reference_path():
    views = np.random.default_rng(1).integers(0, 256, (2, 3, 5, 9, 3), dtype=np.uint8)
    strided = views[:, :, :, ::-1]
    assert not strided.flags.c_contiguous
    assert np.array_equal(interleave(strided), interleave_reference(strided))


def test_row_gather_negative_control_wrong_table_is_detected():
    # A deliberately wrong layout (views swapped) must not agree with the reference: the comparison can fail.
    views = np.random.default_rng(2).integers(0, 256, (1, 8, 6, 16, 3), dtype=np.uint8)
    out = np.empty((6, 128, 3), np.uint8)
    b = 3
    base = (np.arange(6) * 16 * b).astype(np.int64)
    j, k = np.arange(16)[:, None], np.arange(8)[None, :]
    table = ((7 - k) * 6 * 16 * b + j * b).reshape(1, -1).astype(np.int32)
    assert _kernels.row_gather(views, b, base, np.zeros(6, np.intp), table, out)
    assert not np.array_equal(out, interleave_reference(views))
    assert np.array_equal(out, interleave_reference(views[:, ::-1]))


@pytest.mark.parametrize("pixel_bytes", [1, 2, 3])
@pytest.mark.parametrize("offset", [-1, "past the end"])
def test_row_gather_refuses_offsets_outside_the_source(pixel_bytes, offset):
    # NumPy wraps negative indices and take(mode="clip") clamps the rest, so
    # row_gather itself must refuse a table that reaches outside the source, before any load.
    src = np.arange(4 * 8 * pixel_bytes, dtype=np.uint8)
    table = (np.arange(8) * pixel_bytes).reshape(1, -1).astype(np.int32)
    base = np.zeros(4, np.int64)
    out = np.zeros(4 * 8 * pixel_bytes, np.uint8)
    if offset == -1:
        table[0, 3] = -1
    else:
        base[-1] = src.size - 8 * pixel_bytes + 1  # the last row's last pixel ends one byte past the source
    with pytest.raises(IndexError, match="outside the source"):
        _kernels.row_gather(src, pixel_bytes, base, np.zeros(4, np.intp), table, out)
    assert not out.any()
    base[-1] = src.size - 8 * pixel_bytes  # in range: gathers the last row exactly
    table[0, 3] = 3 * pixel_bytes
    assert _kernels.row_gather(src, pixel_bytes, base, np.zeros(4, np.intp), table, out)
    assert np.array_equal(out[-8 * pixel_bytes:], src[-8 * pixel_bytes:])


@pytest.mark.parametrize("pixel_bytes", [1, 2, 3, 4, 6, 8])
def test_row_gather_at_any_byte_offset(pixel_bytes):
    # Pixels that start off their size's grid (an odd byte for 2-byte pixels) take the overlapping
    # view's path: checked against a byte-by-byte gather written out here.
    rng = np.random.default_rng(pixel_bytes)
    src = rng.integers(0, 256, 400, dtype=np.uint8)
    table = rng.integers(0, 40, (3, 7)) * pixel_bytes + 1   # +1: off the grid
    tid = rng.integers(0, 3, 5).astype(np.intp)
    base = rng.integers(0, 100, 5).astype(np.int64)
    out = np.zeros(5 * 7 * pixel_bytes, np.uint8)
    assert _kernels.row_gather(src, pixel_bytes, base, tid, table, out)
    expected = np.array([src[base[r] + table[tid[r], q] + c] for r in range(5) for q in range(7)
                         for c in range(pixel_bytes)], np.uint8)
    assert np.array_equal(out, expected)
    # Negative control: the same gather on the grid (without the +1) reads other bytes.
    assert _kernels.row_gather(src, pixel_bytes, base, tid, table - 1, out)
    assert not np.array_equal(out, expected)
