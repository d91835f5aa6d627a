"""Issue 38, items 5 and 8: every number bounded, every input read as its maker meant, and every
refusal one line: a scene with a UTF-8 byte-order mark, floats at the edge of the range, JSON
nested past any use, a PNG bomb, a full TMPDIR."""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
import warnings
import zlib
from pathlib import Path

import numpy as np
import pytest

from povh3d import jsontext
from povh3d.image.io import decode_png, read_png
from povh3d.povray.version_memo import remembered_version
from povh3d.scene.scene import BOM, load_scene, source_text
from tests.conftest import SAMPLE
from tests.support.cli import one_error_line, run_subprocess

TINY = ["--preset", "demo", "--lenses", "6x4", "--ppl", "4", "--quality", "draft", "-q"]


# -- a UTF-8 byte-order mark ------------------------------------------------------------------------
def test_source_text_drops_a_leading_bom_only():
    assert source_text(BOM + b"sphere") == "sphere"
    assert source_text(b"a" + BOM) == "a" + BOM.decode("latin-1")   # a BOM inside the text is text
    assert source_text(b"sphere") == "sphere"


def test_a_bom_scene_is_walked_as_the_plain_one(tmp_path):
    text = SAMPLE.read_bytes()
    (tmp_path / "bom.pov").write_bytes(BOM + text)
    (tmp_path / "plain.pov").write_bytes(text)
    bom, plain = load_scene(tmp_path / "bom.pov"), load_scene(tmp_path / "plain.pov")
    assert bom.features == plain.features and bom.lit == plain.lit


SMALL_SCENE = (b"camera { location <0, 0, -5> look_at 0 }\nlight_source { <2, 3, -5> rgb 1 }\n"
               b"sphere { 0, 1 pigment { rgb <1, 0.5, 0.2> } }\n")


@pytest.mark.povray
def test_povray_itself_takes_a_bom_in_the_file_it_is_given_but_not_in_an_include(tmp_path):
    """The facts the fix stands on (and the negative control of the test below): POV-Ray 3.7 renders
    a main file with a BOM and refuses the same file included, which is how povh3d reads a scene."""
    (tmp_path / "bom.pov").write_bytes(BOM + SMALL_SCENE)
    (tmp_path / "main.pov").write_text('#include "bom.pov"\n')
    run = [shutil.which("povray") or "povray", "-D", "+W16", "+H16"]
    direct = subprocess.run([*run, "+Odirect.png", "bom.pov"], cwd=tmp_path, capture_output=True, text=True, check=False)
    included = subprocess.run([*run, "+Oinc.png", "main.pov"], cwd=tmp_path, capture_output=True, text=True, check=False)
    assert direct.returncode == 0 and (tmp_path / "direct.png").is_file()
    assert included.returncode != 0 and "Illegal character" in included.stderr + included.stdout


@pytest.mark.povray
def test_a_scene_with_a_bom_renders_as_without(tmp_path, cli):
    (tmp_path / "bom.pov").write_bytes(BOM + SAMPLE.read_bytes())
    (tmp_path / "plain.pov").write_bytes(SAMPLE.read_bytes())
    for name in ("bom", "plain"):
        result = cli("render", tmp_path / f"{name}.pov", *TINY, "-o", tmp_path / f"{name}.png")
        assert result.code == 0, result.err
    assert np.array_equal(read_png(tmp_path / "bom.png"), read_png(tmp_path / "plain.png"))
    assert (tmp_path / "bom.pov").read_bytes().startswith(BOM)   # the user's file is left as it is


# -- floats at the edge of the range ----------------------------------------------------------------
@pytest.mark.parametrize("args, expected", [
    (["--ppl=1e-308"], "pixels per lens (--ppl) must be between 1e-06 and 1e+06 pixels"),
    (["--pixel-pitch", "1e306"], "pixel pitch (--pixel-pitch) must be between 1e-09 and 1e+09 mm"),
    (["--bbox=inf,inf,inf,inf,inf,inf"], "--bbox holds nothing"),
    (["--bbox=-inf,-inf,-inf,-inf,1,1"], "--bbox holds nothing"),
])
def test_numbers_past_any_display_are_one_line(tmp_path, cli, args, expected):
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # and no NumPy warning before it
        line = one_error_line(cli("render", SAMPLE, "--preset", "demo", "-o", tmp_path / "a.png", *args), 2)
    assert expected in line
    assert not list(tmp_path.iterdir())


def test_an_unbounded_bbox_side_is_still_taken():   # negative control: -inf / inf mean "no bound"
    from povh3d.geometry.crop import parse_bbox

    assert parse_bbox("-inf,-1,-1,inf,1,1") == ((-np.inf, -1, -1), (np.inf, 1, 1))


def test_a_timeout_past_polls_reach_waits(monkeypatch):
    """``--timeout 1e9`` was an OverflowError in poll(): the wait is capped, the limit kept."""
    import select

    from povh3d.povray import watch

    asked = []

    class Poll:
        def register(self, *a): pass
        def poll(self, ms): asked.append(ms)

    monkeypatch.setattr(select, "poll", Poll)
    proc = subprocess.Popen(["sleep", "0"])
    try:
        watch.sleep_until_exit([proc.pid], 1e9)
        watch.sleep_until_exit([proc.pid], 2.0)
    finally:
        proc.wait()
    assert asked == [2**31 - 1, 2000]


@pytest.mark.povray
def test_a_huge_timeout_renders(tmp_path, cli):
    result = cli("render", SAMPLE, *TINY, "--timeout", "1e9", "-o", tmp_path / "a.png")
    assert result.code == 0, result.err


# -- JSON nested deep -------------------------------------------------------------------------------
DEEP = "[" * 100_000 + "]" * 100_000


def test_one_json_reader_with_a_depth_limit():
    assert jsontext.loads('{"a": [1, {"b": 2}]}') == {"a": [1, {"b": 2}]}
    assert jsontext.depth({"a": [1, {"b": 2}]}) == 3 and jsontext.depth(5) == 0
    nested = "[" * 64 + "]" * 64
    assert jsontext.depth(jsontext.loads(nested)) == 64
    for text in (DEEP, "[" * 65 + "]" * 65):
        with pytest.raises(ValueError, match="nested deeper"):
            jsontext.loads(text)
    with pytest.raises(RecursionError):   # negative control: what every caller met before
        json.loads(DEEP)


def test_a_damaged_version_memo_is_a_miss(tmp_path):
    (tmp_path / "povray-version.json").write_text(DEEP)
    assert remembered_version("/bin/povray", tmp_path, lambda binary: "3.7.0.10") == "3.7.0.10"


def test_a_deep_sidecar_is_one_line(tmp_path, cli):
    from povh3d.image.io import write_png

    write_png(tmp_path / "a.png", np.zeros((8, 8, 3), np.uint8))
    (tmp_path / "a.json").write_text(DEEP)
    line = one_error_line(cli("preview", tmp_path / "a.png", "-o", tmp_path / "p.png"))
    assert "a.json" in line and "nested deeper" in line


def test_a_deep_calibration_is_one_line(tmp_path, cli):
    from povh3d.image.io import write_png

    write_png(tmp_path / "a.png", np.zeros((8, 8, 3), np.uint8))
    (tmp_path / "visual.json").write_text(DEEP)
    line = one_error_line(cli("map", tmp_path / "a.png", "--mapping", "slanted", "--calibration", tmp_path / "visual.json", "-o", tmp_path / "m.png"))
    assert "visual.json" in line


# -- a PNG bomb -------------------------------------------------------------------------------------
def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bomb(path: Path, width: int, height: int) -> Path:
    """A grey PNG of zeros: a few hundred KB that decode to ``width * height`` pixels."""
    packer, row, parts = zlib.compressobj(9), b"\0" * (1 + width), []
    parts = [packer.compress(row) for _ in range(height)] + [packer.flush()]
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
                     + _chunk(b"IDAT", b"".join(parts)) + _chunk(b"IEND", b""))
    return path


def test_a_png_bomb_is_refused_from_its_header(tmp_path, cli):
    import resource

    bomb = png_bomb(tmp_path / "bomb.png", 12000, 10000)
    assert bomb.stat().st_size < 1 << 20
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    line = one_error_line(cli("map", bomb, "--mapping", "alioscopy", "-o", tmp_path / "m.png", "--max-memory", "500M"), 3)
    assert "12000x10000" in line and "--max-memory" in line
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before   # KiB
    assert grown < 200_000   # refused before the decoder ran (it would take 480 MB)


def test_a_large_png_within_the_budget_reads_without_pillows_warning(tmp_path):
    """Past 89 Mpixels Pillow warns in two lines (and refuses past twice that); the budget is ours."""
    bomb = png_bomb(tmp_path / "big.png", 9500, 9500)   # 90.25 Mpixels, 90 MB decoded
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        image = decode_png(bomb, "big.png")
    assert image.shape == (9500, 9500, 1)


# -- a full TMPDIR ----------------------------------------------------------------------------------
def test_a_full_disk_is_named(tmp_path, monkeypatch):
    from povh3d.povray import process

    Usage = type("Usage", (), {})
    full, roomy = Usage(), Usage()
    full.free, roomy.free = 4096, 10 << 30
    monkeypatch.setattr(process.shutil, "disk_usage", lambda folder: full)
    error = process.full_disk(tmp_path / "job", 1000, "multi-ortho camera 1")
    assert error is not None and "is full" in str(error) and str(tmp_path) in str(error) and "TMPDIR" in str(error)
    monkeypatch.setattr(process.shutil, "disk_usage", lambda folder: roomy)
    assert process.full_disk(tmp_path / "job", 1000, "multi-ortho camera 1") is None   # negative control


@pytest.mark.povray
def test_a_render_into_a_full_tmpdir_names_the_disk(tmp_path, cli):
    full = tmp_path / "full"
    full.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(full)],
                             capture_output=True, check=False)
    if mounted.returncode != 0:
        pytest.skip("cannot mount a small tmpfs here (not root)")
    try:
        fd = os.open(full / "filler", os.O_WRONLY | os.O_CREAT)   # the disk full to its last block
        try:
            while os.write(fd, b"\0" * 4096):
                pass
        except OSError:
            pass
        finally:   # two pages left: Python's tempfile takes TMPDIR only where it can write a test file
            os.ftruncate(fd, max(0, os.fstat(fd).st_size - 8192))
            os.close(fd)
        # a process of its own: tempfile keeps the TMPDIR it saw first
        line = one_error_line(run_subprocess("render", SAMPLE, *TINY, "--no-cache", "-o", tmp_path / "a.png",
                                             env={"TMPDIR": str(full)}, timeout=120), 4)
        assert "is full" in line and str(full) in line
    finally:
        subprocess.run(["umount", str(full)], check=False)


# -- work bounded before it starts ------------------------------------------------------------------
def test_threads_are_bounded_by_the_cores(tmp_path, cli):
    from povh3d.system import cpu_count

    line = one_error_line(cli("render", SAMPLE, *TINY, "--threads", "1000000", "-o", tmp_path / "a.png"), 2)
    assert f"at most {cpu_count()}" in line and not list(tmp_path.iterdir())


def test_threads_within_the_cores_are_taken():   # negative control
    from povh3d.renderer.methods.quality import RenderSettings
    from povh3d.system import MAX_REMOTE_THREADS, cpu_count

    assert RenderSettings(threads=cpu_count()).threads == cpu_count()
    assert RenderSettings(threads=cpu_count() + 1, scheduler="tcp://h:8786").threads == cpu_count() + 1
    with pytest.raises(Exception, match="at most"):
        RenderSettings(threads=MAX_REMOTE_THREADS + 1, scheduler="tcp://h:8786")


def test_a_frame_count_past_any_animation_is_one_line(tmp_path, cli):
    import time

    start = time.perf_counter()
    line = one_error_line(cli("render", SAMPLE, *TINY, "--frames", "0:100000000", "-o", tmp_path / "a.png"), 2)
    assert "100000001 frames, over 100000" in line and "--frames 0:9999" in line
    assert time.perf_counter() - start < 5 and not list(tmp_path.iterdir())
    from povh3d.renderer.animation import parse_frames
    assert parse_frames("0:99999") == (0, 99999)   # negative control: the limit itself is taken


def _one_expression_scene(path: Path, terms: int) -> Path:
    path.write_text("#declare X = " + "+".join(["1"] * terms) + ";\n" + SAMPLE.read_text())
    return path


def test_the_cameras_reading_is_estimated_before_it_starts(tmp_path, cli):
    import resource

    scene = _one_expression_scene(tmp_path / "expr.pov", 1_500_000)   # 3 MB of text, 0.6 GB to read
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    line = one_error_line(cli("render", scene, *TINY, "-o", tmp_path / "a.png", "--max-memory", "300M"), 2)
    assert "reading the camera of expr.pov" in line and "--max-memory" in line
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000   # KiB


@pytest.mark.povray
def test_a_small_scene_is_read_under_a_small_limit(tmp_path, cli):   # negative control
    result = cli("info", SAMPLE, "--preset", "demo", "--max-memory", "300M")
    assert result.code == 0, result.err
