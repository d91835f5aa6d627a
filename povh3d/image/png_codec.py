"""PNG read (16-bit) and written (8- and 16-bit): libpng through imagecodecs, zlib and NumPy.

pypng's pure-Python rows took 8 s to read and 6.4 s to write an 8K (7680x4320)
16-bit RGB image, and Pillow reads 16-bit RGB as 8-bit.  Pillow's 8-bit writer
tries every row filter on every row: 2.5 times slower at 1920x1080 than the one
filter used here, for a slightly larger file.

Reading checks the chunks (their CRCs, the header) here and leaves the pixels
to libpng (``imagecodecs.png_decode``, 0.65 s for a 3840x2160 16-bit RGB file):
it undoes the row filters POV-Ray's libpng mixes row by row, as a numba loop
did before at the cost of a JIT compiler's start-up.  8-bit files too: every
POV-Ray frame is one, and importing Pillow (15-25 ms) cost a render more than
reading its frames.  Writing filters every row with Up (a NumPy subtraction, a few rows at
a time: an H3D image's rows are much alike) and deflates at level 1 with
run-length matching (``Z_RLE``: the runs Up leaves are what there is to find).
Only what povh3d reads and writes is handled: grey, grey+alpha, RGB or RGBA,
not interlaced; ``decode`` returns None for anything else, and the caller reads
it with pypng.
"""

from __future__ import annotations

import struct
import zlib
from typing import BinaryIO

import numpy as np

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Channels of each PNG colour type this module reads.
_PLANES = {0: 1, 4: 2, 2: 3, 6: 4}
#: Rows filtered and deflated at a time when writing: a few MB of temporaries.
_BLOCK_BYTES = 1 << 22


def decode(data: bytes) -> np.ndarray | None:
    """An 8- or 16-bit PNG's bytes as ``(H, W, C)`` uint8 or uint16; None when not one this module reads.

    Raises ``ValueError`` (or imagecodecs' ``PngError``) on a damaged file.
    """
    if not data.startswith(_SIGNATURE):
        raise ValueError("not a PNG file (no PNG signature)")
    pos, header = len(_SIGNATURE), None
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        crc = data[pos + 8 + length:pos + 12 + length]
        if len(crc) != 4:
            raise ValueError("truncated chunk")
        if struct.unpack(">I", crc)[0] != zlib.crc32(body, zlib.crc32(kind)):
            raise ValueError(f"{kind.decode('latin-1')} chunk fails its CRC check")
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IEND":
            break
        pos += 12 + length
    else:
        raise ValueError("no IEND chunk (truncated file)")
    if header is None:
        raise ValueError("no IHDR chunk")
    width, height, depth, colour, _, _, interlace = header
    if depth not in (8, 16) or colour not in _PLANES or interlace != 0:
        return None
    from imagecodecs import png_decode  # libpng; its module loads on this first call

    image = png_decode(data)
    dtype = np.uint16 if depth == 16 else np.uint8
    if image.dtype != dtype or image.size != height * width * _PLANES[colour]:
        raise ValueError(f"libpng read {image.shape} {image.dtype} from a {width}x{height} {depth}-bit header")
    return image.reshape(height, width, _PLANES[colour])


def encode(out: BinaryIO, image: np.ndarray, level: int = 1) -> None:
    """Write ``(H, W)`` or ``(H, W, C)`` uint8 or uint16 (C in 1..4) to ``out`` as a PNG
    of 8 or 16 bits per channel."""
    if image.ndim == 2:
        image = image[..., None]
    height, width, planes = image.shape
    colour = {1: 0, 2: 4, 3: 2, 4: 6}[planes]
    size = image.dtype.itemsize
    out.write(_SIGNATURE)
    _chunk(out, b"IHDR", struct.pack(">IIBBBBB", width, height, 8 * size, colour, 0, 0, 0))
    stride = width * planes * size
    block = max(1, _BLOCK_BYTES // stride)
    deflate = zlib.compressobj(level, zlib.DEFLATED, 15, 8, zlib.Z_RLE)
    previous = np.zeros(stride, dtype=np.uint8)
    filtered = np.empty((min(block, height), stride + 1), dtype=np.uint8)
    filtered[:, 0] = 2  # Up: each byte less the one above it (smooth images deflate well)
    for top in range(0, height, block):
        rows = np.ascontiguousarray(image[top:top + block], dtype=f">u{size}").view(np.uint8).reshape(-1, stride)
        part = filtered[:len(rows)]
        np.subtract(rows[0], previous, out=part[0, 1:])
        np.subtract(rows[1:], rows[:-1], out=part[1:, 1:])
        previous = rows[-1].copy()
        data = deflate.compress(part.tobytes())
        if data:
            _chunk(out, b"IDAT", data)
    _chunk(out, b"IDAT", deflate.flush())
    _chunk(out, b"IEND", b"")


def _chunk(out: BinaryIO, kind: bytes, body: bytes) -> None:
    out.write(struct.pack(">I", len(body)) + kind)
    out.write(body)
    out.write(struct.pack(">I", zlib.crc32(body, zlib.crc32(kind))))
