"""POV-Ray's frames as PPM (issue 40): the reader against hand-made files and against the PNG
POV-Ray writes of the same render."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from povh3d.errors import InputError
from povh3d.image.io import decode_image, read_image, read_png
from povh3d.image.ppm import decode_ppm, encode_ppm, ppm_layout

SAMPLE = Path(__file__).resolve().parents[2] / "sample_models" / "sample.pov"
POVRAY_HEAD = (b"P6\n# Software: POV-Ray 3.7.0.10.unofficial\n# Render Date: 2026-11-29 10:35:40Z\n"
               b"# Platform: x86_64-pc-linux-gnu\n# Compiler: g++\n")


def test_the_header_with_povray_s_comments():
    head = POVRAY_HEAD + b"320 240\n65535\n"
    layout = ppm_layout(head + b"\x00")
    assert (layout.width, layout.height, layout.depth, layout.offset) == (320, 240, 2, len(head))
    assert layout.size == len(head) + 320 * 240 * 6
    assert ppm_layout(b"P6 3 2 255\n").size == 11 + 18
    for bad in (b"P5\n3 2\n255\n", b"P6\n3 2\n1023\n", b"P6\n3 2\n255", b"P6\n# cut", b"P6\n0 2\n255\n",
                b"\x89PNG\r\n\x1a\n"):
        assert ppm_layout(bad) is None, bad


def test_16_bit_samples_are_big_endian():
    # 0x0102 = 258 in the file's order; read in the machine's (little-endian) order it would be 513
    data = b"P6\n1 1\n65535\n" + bytes([1, 2, 0, 255, 255, 0])
    pixel = decode_image(data, "x")[0, 0]
    assert pixel.dtype == np.uint16 and pixel.tolist() == [258, 255, 65280]
    assert decode_ppm(data, "x")[0, 0].tolist() != np.frombuffer(data[-6:], "<u2").tolist()  # control


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_a_file_and_its_bytes_read_back_what_was_written(tmp_path, dtype):
    rng = np.random.default_rng(4)
    image = rng.integers(0, np.iinfo(dtype).max, (5, 7, 3), endpoint=True).astype(dtype)
    data = encode_ppm(image)
    path = tmp_path / "frame.ppm"
    path.write_bytes(POVRAY_HEAD + data[3:])   # POV-Ray's comments between the magic and the size
    for read in (read_image(path), decode_image(data, "x")):
        assert read.dtype == dtype and read.shape == (5, 7, 3) and np.array_equal(read, image)
        assert read.flags.writeable and read.dtype.isnative
    assert not np.array_equal(read_image(path), image[::-1])   # the rows in order


def test_a_cut_or_damaged_ppm_is_an_error_naming_it(tmp_path):
    data = encode_ppm(np.zeros((2, 3, 3), np.uint8))
    for bad in (data[:-1], data + b"\0", b"P6\n3 2\n7\n" + bytes(18)):
        with pytest.raises(InputError, match=r"cannot read 'shot 3' .*render it again"):
            decode_image(bad, "shot 3")
    with pytest.raises(InputError, match="does not exist"):
        read_image(tmp_path / "missing.ppm")


def test_a_png_is_still_read_by_its_content(tmp_path):
    from povh3d.image.io import write_png

    image = np.arange(2 * 3 * 3, dtype=np.uint16).reshape(2, 3, 3) * 1000
    write_png(tmp_path / "a.ppm", image)   # the name does not decide: the content does
    assert np.array_equal(read_image(tmp_path / "a.ppm"), image)


@pytest.mark.povray
@pytest.mark.skipif(shutil.which("povray") is None, reason="POV-Ray is not installed")
@pytest.mark.parametrize("bits", [8, 16])
def test_povray_s_ppm_and_png_of_one_render_hold_the_same_pixels(tmp_path, bits):
    def render(kind: str, name: str, *extra: str) -> Path:
        subprocess.run(["povray", f"+I{SAMPLE}", f"+L{SAMPLE.parent}", f"+O{tmp_path / name}", "+W64", "+H48",
                        f"+F{kind}{bits}", "File_Gamma=sRGB", "-D", "-V", "+A0.3", "-J", *extra],
                       check=True, capture_output=True, cwd=tmp_path)
        return tmp_path / name

    ppm, png = read_image(render("P", "a.ppm")), read_png(render("N", "a.png"))
    assert ppm.dtype == png.dtype == (np.uint8 if bits == 8 else np.uint16)
    assert ppm.shape == png.shape == (48, 64, 3) and len(np.unique(ppm)) > 20
    assert np.array_equal(ppm, png)
    # negative control: another render of the scene (no antialiasing) differs from that PNG
    assert not np.array_equal(read_image(render("P", "b.ppm", "-A")), png)
