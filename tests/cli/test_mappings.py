"""The mapping commands end to end: map, info --mapping, render --mapping, bad input."""

import json

import numpy as np
import pytest

from povh3d.renderer.outputs.views import read_views
from povh3d.image.io import read_png, write_png
from povh3d.image.interleave import interleave
from povh3d.display.mappings import MappingOptions, build_mapping
from tests.conftest import SAMPLE
from tests.support.cli import one_error_line


def test_map_writes_the_mapped_panel_and_infers_its_size(tmp_path, cli):
    m = build_mapping("philips")
    src = m.source((60, 36))
    img = np.random.default_rng(0).integers(0, 256, src.shape, dtype=np.uint8)
    write_png(tmp_path / "in.png", img)
    assert cli("map", tmp_path / "in.png", "--mapping", "philips", "-o", tmp_path / "out.png").code == 0
    assert np.array_equal(read_png(tmp_path / "out.png"), m.apply(img, (60, 36)))
    assert json.loads((tmp_path / "out.json").read_text())["mapping"] == "philips"


@pytest.mark.parametrize("args, message", [
    (["--mapping", "nope"], "choose one of: alioscopy"),
    (["--mapping", "smart:9", "--ppl", "4"], "from 2 to 7"),
    (["--mapping", "alioscopy", "--panel-size", "64x40"], "view-space image"),
    (["--mapping", "smart:2"], "whole pixels per lens"),
])
def test_bad_map_input_one_line_nothing_written(tmp_path, args, message, cli):
    write_png(tmp_path / "in.png", np.zeros((12, 77, 3), np.uint8))
    out = tmp_path / "out.png"
    result = cli("map", tmp_path / "in.png", "-o", out, "--preset", "ipad-retina", *args)
    if "--ppl" not in args and "smart" in args[1]:
        result = cli("map", tmp_path / "in.png", "-o", out, "--grid", "lenticular", "--lenses", "7", "--ppl", "2.5",
                   "--rows", "12", "--pixel-pitch", "0.1", "--focal", "1", *args)
    assert message in one_error_line(result)
    assert list(tmp_path.iterdir()) == [tmp_path / "in.png"]


def test_info_reports_mapping_figures(cli):
    info = json.loads(cli("info", "--preset", "ipad-retina", "--ppl", "22", "--mapping", "smart:5", "--json").out)
    assert info["resolution_3d"] == [465, 307] and info["pixel_distance_3d_mm"] == pytest.approx(0.0192)
    info = json.loads(cli("info", "--preset", "alioscopy-42", "--mapping", "slanted", "--json").out)
    assert info["resolution_3d"] == [720, 360] and info["mapping_lens_pitch_mm"] == pytest.approx(1.292)


def test_info_reads_a_calibration_without_mapping(tmp_path, cli):
    """``info --calibration`` reads the file as render does, with or without ``--mapping``: a Looking Glass
    preset's quilt names it (it was silently dropped); a preset that cannot take one says so in one line."""
    from povh3d.display.looking_glass import device, visual_json

    visual = tmp_path / "visual.json"
    visual.write_text(visual_json(device("looking-glass-portrait").calibration))
    plain = json.loads(cli("info", "--preset", "looking-glass-portrait", "--json").out)
    calibrated = json.loads(cli("info", "--preset", "looking-glass-portrait", "--calibration", visual, "--json").out)
    assert plain["quilt"]["calibration"] is None
    assert calibrated["quilt"]["calibration"] == str(visual)
    assert "--calibration" in one_error_line(cli("info", "--preset", "demo", "--calibration", visual))


@pytest.mark.povray
def test_render_with_mapping_renders_only_the_views_it_needs(tmp_path, cli):
    out, views = tmp_path / "panel.png", tmp_path / "views"
    result = cli("render", SAMPLE, "-o", out, "--views-dir", views, "--grid", "lenticular", "--lenses", "10",
               "--ppl", "4", "--rows", "12", "--mapping", "smart:3", "--quality", "draft", "-q")
    assert result.code == 0, result.err
    panel = read_png(out)
    assert panel.shape == (12, 40, 3)
    stack = read_views(views)
    assert stack.shape[:4] == (1, 12, 4, 10)  # 3 x 4 views of 10 lenses x 12/3 rows: nothing thrown away
    m = build_mapping("smart:3", MappingOptions(ppl=4))
    assert np.array_equal(panel, m.apply(interleave(stack), (40, 12)))
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["kind"] == "panel" and record["mapping"] == "smart:3"
