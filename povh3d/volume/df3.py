"""POV-Ray's ``df3`` density files, and where POV-Ray puts their samples.

The format (POV-Ray 3.7, ``Read_Density_File``): three big-endian ``uint16``
sizes ``nx, ny, nz``, then ``nx * ny * nz`` big-endian values, ``x`` fastest,
then ``y``, then ``z``.  The value width (8, 16 or 32 bit) is not stored: POV-Ray
infers it from the file size.  A value ``q`` reads as the density ``q / (2^bits - 1)``.

Where the samples sit (``density_pattern``): the pattern fills the unit cube
``0 <= u < 1`` (zero outside).  Along one axis with ``M`` samples,

- ``interpolate 0`` (none): sample ``m`` fills the cell ``m/M <= u < (m+1)/M``;
- ``interpolate 1`` (trilinear): sample ``m`` is the value *at* ``u = m/M``, and
  between ``m/M`` and ``(m+1)/M`` POV-Ray blends samples ``m`` and ``(m+1) mod M``:
  the last cell wraps round to the first sample.

So the two modes are half a sample apart, and trilinear has no sample at ``u = 1``.
povh3d writes the volume with one extra sample on every side, a copy of the
edge (``M = n + 2``; sample ``m`` holds voxel ``m - 1``) and maps voxel index
``t`` to ``u = (t + 1 + shift) / M`` (``SAMPLE_SHIFT``).  The physical box,
voxel centres +- half a voxel, is then well inside the cube: never in the
wrapping cell, and its faces show the edge voxels' values (clamp to edge).
Pure NumPy: bytes in, bytes out.
"""

from __future__ import annotations

import struct

import numpy as np

from ..errors import ConfigError, InputError, param

BITS = (8, 16)
HEADER = struct.Struct(">3H")
#: Voxel index ``t`` of the padded grid sits at ``u = (t + 1 + SAMPLE_SHIFT[interpolate]) / M``.
SAMPLE_SHIFT = {0: 0.5, 1: 0.0}
PAD = 1


def _dtype(bits: int) -> np.dtype:
    if bits not in BITS:
        raise ConfigError(f"{param('df3_bits')} must be 8 or 16, got {bits!r}")
    return np.dtype(">u1" if bits == 8 else ">u2")


def quantise(fractions: np.ndarray, bits: int) -> np.ndarray:
    """Densities in ``[0, 1]`` (clipped) to the integers POV-Ray reads back as ``q / (2^bits - 1)``."""
    top = (1 << bits) - 1
    q = np.clip(np.asarray(fractions, dtype=np.float32), 0.0, 1.0)
    q *= top
    np.rint(q, out=q)
    return q.astype(_dtype(bits).newbyteorder("="))


def padded_shape(shape: tuple[int, int, int]) -> tuple[int, int, int]:
    """The df3 grid written for a volume of ``shape`` voxels: one edge copy on each side."""
    nx, ny, nz = shape
    return int(nx) + 2 * PAD, int(ny) + 2 * PAD, int(nz) + 2 * PAD


def df3_bytes(samples: np.ndarray, bits: int) -> bytes:
    """A df3 file of already quantised ``samples`` (``(nx, ny, nz)`` integers, index ``[x, y, z]``),
    padded with an edge copy on every side (see the module notes)."""
    dtype = _dtype(bits)
    samples = np.asarray(samples)
    if samples.ndim != 3:
        raise ConfigError(f"a density file holds a 3D grid, got shape {samples.shape}")
    shape = padded_shape(samples.shape)
    if max(shape) > 0xFFFF:
        raise ConfigError(f"a df3 file holds at most 65533 voxels a side, the volume has {samples.shape}; "
                          "crop or resample it")
    if np.issubdtype(samples.dtype, np.integer) and (samples.min() < 0 or samples.max() > (1 << bits) - 1):
        raise ConfigError(f"df3 values must lie within 0..{(1 << bits) - 1}")
    grid = np.pad(samples, PAD, mode="edge")
    # x fastest: Fortran order of [x, y, z].
    return HEADER.pack(*shape) + grid.astype(dtype, copy=False).tobytes(order="F")


def read_df3(data: bytes, *, name: str = "density file") -> tuple[np.ndarray, int]:
    """The ``(nx, ny, nz)`` densities in ``[0, 1]`` and the bit depth, read as POV-Ray reads them."""
    if len(data) < HEADER.size:
        raise InputError(f"{name}: too short for a df3 header (6 bytes)")
    shape = HEADER.unpack_from(data)
    count = int(np.prod(shape))
    body = len(data) - HEADER.size
    widths = {count * 4: 32, count * 2: 16, count: 8}
    if count == 0 or body not in widths:
        raise InputError(f"{name}: {body} bytes of data do not fit {shape[0]}x{shape[1]}x{shape[2]} values "
                         "of 8, 16 or 32 bits")
    bits = widths[body]
    raw = np.frombuffer(data, dtype=np.dtype(f">u{bits // 8}"), offset=HEADER.size)
    return raw.reshape(shape, order="F").astype(np.float64) / ((1 << bits) - 1), bits
