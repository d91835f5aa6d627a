"""PNG coding (image/png_codec.py) against pypng, Pillow and the PNG specification's filters
written out independently here; POV-Ray's own 16-bit output read both ways."""

from __future__ import annotations

import io
import struct
import subprocess
import zlib

import numpy as np
import png
import pytest
from PIL import Image

from povh3d.errors import InputError
from povh3d.image import png_codec
from povh3d.image.io import decode_png, read_png, write_png
from povh3d.povray.process import find_povray


def _pypng_read(data: bytes) -> np.ndarray:
    width, height, rows, info = png.Reader(bytes=data).asDirect()
    return np.vstack([np.asarray(r, dtype=np.uint16) for r in rows]).reshape(height, width, info["planes"])


def _encoded(image: np.ndarray) -> bytes:
    out = io.BytesIO()
    png_codec.encode(out, image)
    return out.getvalue()


@pytest.mark.parametrize("planes", [1, 2, 3, 4])
@pytest.mark.parametrize("shape", [(1, 1), (7, 13), (64, 33)])
def test_round_trip_and_pypng_agree(planes, shape, monkeypatch):
    monkeypatch.setattr(png_codec, "_BLOCK_BYTES", 100)  # many blocks: the Up filter across block edges
    rng = np.random.default_rng(planes * 100 + shape[0])
    image = rng.integers(0, 65536, (*shape, planes), dtype=np.uint16)
    data = _encoded(image)
    assert np.array_equal(png_codec.decode(data), image)
    assert np.array_equal(_pypng_read(data), image)  # another reader agrees


@pytest.mark.parametrize("planes", [1, 2, 3, 4])
def test_8_bit_files_read_by_pillow_and_pypng(planes, monkeypatch):
    monkeypatch.setattr(png_codec, "_BLOCK_BYTES", 64)
    image = np.random.default_rng(planes).integers(0, 256, (23, 17, planes), dtype=np.uint8)
    image[5:9] = 7  # runs, for the run-length matching
    data = _encoded(image)
    with Image.open(io.BytesIO(data)) as im:
        assert np.array_equal(np.asarray(im).reshape(image.shape), image)
    assert np.array_equal(_pypng_read(data), image)
    assert np.array_equal(decode_png(data, "x.png"), image)


def test_reads_pypng_files():
    image = np.random.default_rng(1).integers(0, 65536, (9, 11, 3), dtype=np.uint16)
    out = io.BytesIO()
    png.Writer(11, 9, bitdepth=16, greyscale=False).write(out, image.reshape(9, -1))
    assert np.array_equal(png_codec.decode(out.getvalue()), image)


def _paeth(a: int, b: int, c: int) -> int:
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def _spec_filtered_png(image: np.ndarray, kinds: list[int]) -> bytes:
    """A PNG whose row r uses filter ``kinds[r]``, filtered byte by byte as the PNG spec says."""
    height, width, planes = image.shape
    raw = image.astype(">u2").view(np.uint8).reshape(height, -1).astype(int)
    bpp, out = planes * 2, bytearray()
    for r, kind in enumerate(kinds):
        out.append(kind)
        for i, x in enumerate(raw[r]):
            a = raw[r, i - bpp] if i >= bpp else 0
            b = raw[r - 1, i] if r > 0 else 0
            c = raw[r - 1, i - bpp] if r > 0 and i >= bpp else 0
            pred = [0, a, b, (a + b) // 2, _paeth(a, b, c)][kind]
            out.append((x - pred) % 256)

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    colour = {1: 0, 2: 4, 3: 2, 4: 6}[planes]
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, colour, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(bytes(out))) + chunk(b"IEND", b""))


@pytest.mark.parametrize("planes", [1, 3, 4])
def test_every_filter_type_is_undone(planes):
    rng = np.random.default_rng(planes)
    image = rng.integers(0, 65536, (10, 6, planes), dtype=np.uint16)
    data = _spec_filtered_png(image, [4, 0, 1, 2, 3, 4, 4, 3, 2, 1])
    assert np.array_equal(png_codec.decode(data), image)
    assert np.array_equal(_pypng_read(data), image)  # the oracle encoder itself is right


@pytest.mark.povray
def test_povray_16_bit_output(tmp_path):
    """libpng's adaptive filters, as in every 16-bit frame povh3d reads."""
    scene = tmp_path / "s.pov"
    scene.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1 }\ncamera { location <0,0,-4> look_at 0 }\n"
                     "light_source { <3,4,-5> rgb 1 }\nsphere { 0, 1 pigment { gradient x colour_map "
                     "{ [0 rgb <1,0.2,0>] [1 rgb <0,0.3,1>] } } }\nplane { y, -1 pigment { checker } }\n")
    subprocess.run([find_povray(), f"+I{scene}", f"+O{tmp_path / 'o.png'}", "+W97", "+H61", "+FN16", "-D", "-GA",
                    "+A0.1"], check=True, capture_output=True, cwd=tmp_path, timeout=120)
    data = (tmp_path / "o.png").read_bytes()
    ours = png_codec.decode(data)
    assert ours.shape == (61, 97, 3) and len(np.unique(ours)) > 1000  # a real 16-bit image
    assert np.array_equal(ours, _pypng_read(data))


def test_io_writes_and_reads_16_bit(tmp_path):
    image = np.random.default_rng(2).integers(0, 65536, (20, 30, 3), dtype=np.uint16)
    write_png(tmp_path / "a.png", image)
    assert np.array_equal(read_png(tmp_path / "a.png"), image)
    assert np.array_equal(_pypng_read((tmp_path / "a.png").read_bytes()), image)


@pytest.mark.parametrize("damage", ["truncate", "flip"])
def test_damaged_16_bit_file_is_one_error(damage):
    data = bytearray(_encoded(np.random.default_rng(3).integers(0, 65536, (20, 30, 3), dtype=np.uint16)))
    if damage == "truncate":
        data = data[: len(data) // 2]
    else:
        data[60] ^= 0xFF  # inside the image data: the chunk's CRC no longer matches
    with pytest.raises(InputError, match="cannot read 'x.png'"):
        decode_png(bytes(data), "x.png")
