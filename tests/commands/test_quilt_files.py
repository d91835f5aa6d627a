"""``povh3d quilt`` on every grid: the view's physical aspect, ``--quilt auto``, ``--rows``, and
whole-view images that ``extract`` takes (ipad-retina's 341 lenses of 6 px on 2048 px)."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.display.display import build_display
from povh3d.renderer.records import base_record, write_image
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.interleave import extract, interleave
from povh3d.image.io import read_png, read_sidecar
from povh3d.image.quilt import parse_quilt_name, quilt_to_views
from tests.support.cli import one_error_line


def _noise(shape, seed=0):
    return np.random.default_rng(seed).integers(0, 256, shape, dtype=np.uint8)


def _one(folder):
    (path,) = folder.glob("*.png")
    return path


def test_aspect_is_the_physical_panel_of_a_mapped_preset(tmp_path, cli):
    """alioscopy-42's view-space image (720 lenses x 8 views, 360 rows: tiles 720 x 360 px, 2.0)
    shows on a 930 x 523 mm panel: the name says 1.7778."""
    display = build_display("alioscopy-42")
    la = display.render_array
    record = {**base_record("h3d"), **display.as_record()}
    write_image(tmp_path / "a.png", _noise((la.panel.height, la.panel.width, 3)), record)
    result = cli("quilt", tmp_path / "a.png", "--quilt", "auto", "-o", tmp_path / "q")
    assert result.code == 0, result.err
    cols, rows, aspect = parse_quilt_name(_one(tmp_path / "q").name)
    assert (cols, rows) == (4, 2) and aspect == pytest.approx(1920 / 1080, abs=1e-4)
    tile_shape = la.lenses_x / la.panel.height
    assert abs(aspect - tile_shape) > 0.1                     # control: the tile's pixel shape differs


def test_lenticular_aspect_is_the_sheet_not_the_tile(tmp_path, cli):
    """The issue's 32 x 30 mm sheet of 40 lenses, 8 views, 300 rows: a1.0667 (the tile is 40 x 300)."""
    la = LensArray("lenticular", 40, 300, 0.8, 0.1, 1.5, Panel(320, 300, 0.1, 0.1))
    write_image(tmp_path / "s.png", _noise((300, 320, 3)), base_record("h3d", la))
    assert cli("quilt", tmp_path / "s.png", "--quilt", "4x2", "-o", tmp_path / "q").code == 0
    assert parse_quilt_name(_one(tmp_path / "q").name)[2] == pytest.approx(32 / 30, abs=1e-4)


def test_ipad_retina_render_is_taken_by_every_command_extract_takes(tmp_path, cli):
    """2048 px of 6 px lenses: 341 whole lenses and 1 px either side.  The quilt's tiles are the
    views ``extract`` writes, and refocus / preview / resample accept the image."""
    display = build_display("ipad-retina")
    la = display.lens_array
    image = _noise((la.panel.height, la.panel.width, 3), 3)
    write_image(tmp_path / "r.png", image, {**base_record("h3d"), **display.as_record()})
    with pytest.raises(ValueError, match="whole lenses"):
        extract(image, (1, 6))                                  # control: the whole image holds none
    result = cli("quilt", tmp_path / "r.png", "--quilt", "auto", "-o", tmp_path / "q")
    assert result.code == 0, result.err
    quilt_path = _one(tmp_path / "q")
    cols, rows, aspect = parse_quilt_name(quilt_path.name)
    # 6 tiles of 341 x 1536 px: 6 x 1 is the most nearly square quilt
    assert (cols, rows) == (6, 1) and aspect == pytest.approx(2048 / 1536, abs=1e-4)
    tiles = quilt_to_views(read_png(quilt_path), cols, rows)
    bank = extract(image[:, 1:2047], (1, 6))
    assert np.array_equal(tiles, bank[0, ::-1])                 # quilt view q = bank view 5 - q
    assert not np.array_equal(tiles, bank[0])                   # control: the other order
    for args in (["refocus", "--depth", "2"], ["resample", "--ppl-out", "3"]):
        out = tmp_path / f"{args[0]}.png"
        result = cli(args[0], tmp_path / "r.png", *args[1:], "-o", out)
        assert result.code == 0, result.err
    assert read_png(tmp_path / "resample.png").shape[1] == 341 * 3
    result = cli("preview", tmp_path / "r.png", "--frames", "2", "-o", tmp_path / "p.gif")
    assert result.code == 0, result.err


def _square(tmp_path, ny=4, nx=4):
    """A square array whose view (l, k) is painted 10 l + k."""
    lenses = (5, 3)
    views = np.zeros((ny, nx, lenses[1], lenses[0], 3), np.uint8)
    views += (10 * np.arange(ny)[:, None] + np.arange(nx)[None, :]).astype(np.uint8)[:, :, None, None, None]
    la = LensArray("square", lenses[0], lenses[1], 0.4, 0.4, 1.0, Panel(lenses[0] * nx, lenses[1] * ny, 0.1, 0.1))
    write_image(tmp_path / "sq.png", interleave(views), base_record("h3d", la))
    return tmp_path / "sq.png"


def test_square_image_needs_rows_and_gives_the_centre_row_or_all(tmp_path, cli):
    path = _square(tmp_path)
    line = one_error_line(cli("quilt", path, "--quilt", "auto", "-o", tmp_path / "n"))
    assert "--rows centre" in line and not list((tmp_path / "n").glob("*.png"))
    assert cli("quilt", path, "--quilt", "auto", "--rows", "centre", "-o", tmp_path / "c").code == 0
    tiles = quilt_to_views(read_png(_one(tmp_path / "c")), 2, 2)
    assert [int(t[0, 0, 0]) for t in tiles] == [23, 22, 21, 20]          # row l = 2, leftmost camera first
    assert cli("quilt", path, "--quilt", "8x2", "--rows", "all", "-o", tmp_path / "a").code == 0
    tiles = quilt_to_views(read_png(_one(tmp_path / "a")), 8, 2)
    assert [int(t[0, 0, 0]) for t in tiles] == [10 * (t // 4) + 3 - t % 4 for t in range(16)]
    assert read_sidecar(_one(tmp_path / "a"))["rows"] == "all"


def test_hex_image_quilts_its_resampled_views(tmp_path, cli):
    from povh3d.image.elemental import extract_views, view_grid

    la = LensArray("hex", 6, 5, 0.8, 0.8 * np.sqrt(3) / 2, 1.0, Panel(56, 40, 0.1, 0.1))
    image = _noise((40, 56, 3), 4)
    write_image(tmp_path / "h.png", image, base_record("h3d", la))
    result = cli("quilt", tmp_path / "h.png", "--quilt", "auto", "--rows", "all", "-o", tmp_path / "q")
    assert result.code == 0, result.err
    ny, nx = view_grid(la)
    cols, rows, _ = parse_quilt_name(_one(tmp_path / "q").name)
    tiles = quilt_to_views(read_png(_one(tmp_path / "q")), cols, rows)
    bank = extract_views(image, la, (ny, nx))
    assert np.array_equal(tiles, bank[:, ::-1].reshape(-1, *bank.shape[2:]))
    # refocus and preview take the same views (tests/renderer/test_hex_views.py checks what they make)
    assert cli("refocus", tmp_path / "h.png", "--depth", "2", "-o", tmp_path / "r.png").code == 0
    assert cli("preview", tmp_path / "h.png", "--frames", "3", "-o", tmp_path / "p.gif").code == 0


@pytest.mark.parametrize("make, args, words", [
    (lambda p: write_image(p, _noise((6, 5, 3)), base_record("h3d")), ["--ppl", "8", "--quilt", "auto"],
     "whole lenses"),
    (lambda p: write_image(p.with_name("x_qs4x2a1.png"), _noise((10, 30, 3)), base_record("quilt")),
     ["--import"], "equal views"),
])
def test_bad_quilt_input_is_one_line_and_nothing_written(tmp_path, cli, make, args, words):
    src = tmp_path / "in.png"
    make(src)
    src = src if src.exists() else tmp_path / "x_qs4x2a1.png"
    out = tmp_path / ("back.png" if "--import" in args else "q")
    line = one_error_line(cli("quilt", src, *args, "-o", out))
    assert words in line
    assert not out.exists() or not list(out.glob("*.png"))
