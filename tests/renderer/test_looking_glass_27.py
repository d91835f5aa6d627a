"""The Looking Glass 27" presets: the quilt from the public layout (VTK's vtkLookingGlassInterface),
the sheet from the unit's own ``visual.json``; what needs the sheet refused without it."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from povh3d.display.looking_glass import DEVICES, parse_visual
from povh3d.display.presets import calibrated_fields, get_preset, lens_array_from_fields
from povh3d.errors import ConfigError
from povh3d.image.interleave import extract
from povh3d.image.io import read_png, read_sidecar
from povh3d.image.quilt import quilt_to_views
from tests.conftest import SAMPLES
from tests.display.mappings.test_looking_glass_shader import agreement
from tests.support.cli import one_error_line

LANDSCAPE, PORTRAIT = DEVICES["looking-glass-27-landscape"], DEVICES["looking-glass-27-portrait"]

# A small scene whose views differ (a sphere before a checkered wall), cheap at 33 million view pixels.
SCENE = """#version 3.7;
camera { location <0, 0, -10> look_at <0, 0, 0> angle 30 }
light_source { <5, 5, -10> rgb 1 }
sphere { <0, 0, 0>, 1 pigment { rgb <1, 0.2, 0.2> } }
plane { z, 2 pigment { checker rgb 1 rgb 0.2 scale 0.5 } }
"""

#: A made-up landscape unit (docs/displays.md's example): a 2560 x 1440 panel 27 in across (108.8
#: DPI), a sheet of the Gen3 kind (46.1 lenticules per inch, slope -7.1) and a cone of 45 deg, not
#: the family's 50.  (Its pixel centres fall on no quilt texel's edge, where the oracle's scalar
#: rounding and the vectorised one may differ: a 1920 x 1080 panel has a third of its rows there.)
EXAMPLE = SAMPLES / "looking_glass_27_example.json"
UNIT = json.loads(EXAMPLE.read_text())


def test_the_public_quilt_layouts():
    assert (LANDSCAPE.quilt_size, LANDSCAPE.grid, LANDSCAPE.tile_size) == ((7680, 4320), (8, 6), (960, 720))
    assert (PORTRAIT.quilt_size, PORTRAIT.grid, PORTRAIT.tile_size) == ((7680, 4320), (12, 4), (640, 1080))
    assert LANDSCAPE.aspect == pytest.approx(16 / 9, abs=1e-4) and PORTRAIT.aspect == 0.5625
    assert LANDSCAPE.views == PORTRAIT.views == 48 == get_preset("looking-glass-27-portrait")["views"]
    assert LANDSCAPE.calibration is None and PORTRAIT.calibration is None   # none is public


def test_the_preset_has_no_sheet_without_the_units_calibration():
    with pytest.raises(ConfigError) as err:
        lens_array_from_fields(get_preset("looking-glass-27-landscape"))
    message = str(err.value)
    assert "\n" not in message and "no public factory calibration" in message and "calibration" in message


def test_the_units_calibration_gives_the_sheet_as_the_factory_ones_give_the_others():
    cal = parse_visual(UNIT)
    la = lens_array_from_fields(calibrated_fields(get_preset("looking-glass-27-landscape"), cal))
    # presets.toml's recipe: lens pitch along a row 25.4 / pitch / cos(atan(1 / slope)), focal spanning the cone
    row_pitch = 25.4 / 46.1 / math.cos(math.atan(1 / 7.1))
    assert la.pitch_x == pytest.approx(row_pitch, rel=1e-12) and la.views == (1, 48)
    fields = calibrated_fields(get_preset("looking-glass-27-landscape"), cal)
    assert fields["lens_pitch"] == pytest.approx(row_pitch, rel=1e-12)
    assert math.degrees(2 * math.atan(fields["lens_pitch"] / (2 * fields["focal"]))) == pytest.approx(45.0)
    assert fields["panel"] == [2560, 1440] and fields["pixel_pitch"] == pytest.approx(25.4 / 108.8)
    assert fields["slant_deg"] == pytest.approx(-math.degrees(math.atan(1 / 7.1)))
    assert la.lenses_x == math.floor(2560 * 25.4 / 108.8 / row_pitch)
    # control: another unit's pitch is another sheet
    other = calibrated_fields(get_preset("looking-glass-27-landscape"), parse_visual(dict(UNIT, pitch={"value": 50.0})))
    assert other["lens_pitch"] != pytest.approx(row_pitch, rel=1e-3)


def test_a_calibration_of_another_shape_is_refused():
    LANDSCAPE.check(parse_visual(UNIT))
    with pytest.raises(ConfigError, match="aspect"):
        PORTRAIT.check(parse_visual(UNIT))   # a 16:9 panel is not the portrait's 9:16


def _bank(out, views=48):
    return extract(read_png(out), (1, views))[0]


@pytest.mark.povray
@pytest.mark.parametrize("name, grid, tile", [("looking-glass-27-landscape", (8, 6), (960, 720)),
                                              ("looking-glass-27-portrait", (12, 4), (640, 1080))])
def test_a_quilt_renders_from_the_layout_alone(tmp_path, cli, name, grid, tile):
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE)
    out = tmp_path / "s.png"
    result = cli("render", scene, "--preset", name, "--quality", "draft", "-o", out)
    assert result.code == 0, result.err
    assert "no public factory calibration" in result.err and "--calibration" in result.err   # the warning
    quilts = sorted(tmp_path.glob("s_qs*.png"))
    assert [q.name for q in quilts] == [f"s_qs{grid[0]}x{grid[1]}a{'1.7778' if grid[0] == 8 else '0.5625'}.png"]
    quilt = read_png(quilts[0])
    assert quilt.shape[:2] == (4320, 7680)
    tiles = quilt_to_views(quilt, *grid)
    bank = _bank(out)
    assert tiles.shape == (48, tile[1], tile[0], 3)
    assert np.array_equal(tiles, bank[::-1])              # quilt view q = bank view 47 - q
    assert not np.array_equal(tiles, bank)                # control: the views differ, the order tells
    record = read_sidecar(out)
    cone = record["quilt"]
    assert cone["view_cone_deg"] == 50.0 and "default" in cone["view_cone_from"] and "native" not in cone
    camera = record["camera_model"]
    d = camera["viewer_distance_mm"]
    assert camera["camera_offsets_mm"][1] == pytest.approx(d * math.tan(math.radians(25)), abs=1e-3)
    assert not list(tmp_path.glob("*_native.png"))


@pytest.mark.povray
def test_a_native_image_from_the_units_calibration(tmp_path, cli):
    scene, visual = tmp_path / "s.pov", EXAMPLE
    scene.write_text(SCENE)
    out = tmp_path / "s.png"
    result = cli("render", scene, "--preset", "looking-glass-27-landscape", "--quality", "draft",
                 "--calibration", visual, "-o", out)
    assert result.code == 0, result.err
    assert "no public factory calibration" not in result.err
    quilt = read_png(tmp_path / "s_qs8x6a1.7778.png")
    native = read_png(tmp_path / "s_native.png")
    cal = parse_visual(UNIT)
    assert native.shape == (1440, 2560, 3)                 # the calibration's panel
    assert agreement(native, quilt, (8, 6), cal, samples=20_000) >= 0.999
    assert agreement(native, quilt, (8, 6), cal, samples=20_000, slope_sign=-1.0) < 0.999   # control
    record = read_sidecar(out)
    assert record["quilt"]["view_cone_deg"] == 45.0 and record["quilt"]["view_cone_from"] == "the unit's calibration"
    camera = record["camera_model"]
    assert camera["camera_offsets_mm"][1] == pytest.approx(camera["viewer_distance_mm"] * math.tan(math.radians(22.5)),
                                                           abs=1e-3)
    assert camera["screen_mm"] == pytest.approx([2560 * 25.4 / 108.8, 1440 * 25.4 / 108.8])
    assert read_sidecar(tmp_path / "s_native.png")["device"] == "looking-glass-27-landscape"


@pytest.mark.parametrize("extra", [["--method", "subpixel"], ["--mapping", "slanted"], ["--ppl", "8"]])
def test_what_needs_the_sheet_is_refused_without_the_calibration(tmp_path, cli, extra):
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE)
    line = one_error_line(cli("render", scene, "--preset", "looking-glass-27-portrait", *extra,
                              "-o", tmp_path / "s.png"))
    assert "no public factory calibration" in line and "--calibration" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.pov"]


def test_a_quilt_without_the_calibration_is_not_replayed(tmp_path, cli):
    """A quilt rendered without the unit's calibration has no sheet to replay through: refused in one
    line naming the fix, nothing written (its sidecars stand in for a render's)."""
    from povh3d.renderer.records import base_record, write_image

    source, quilt = tmp_path / "s.png", tmp_path / "s_qs8x6a1.7778.png"
    write_image(source, np.zeros((720, 960 * 48, 3), np.uint8), base_record("h3d", display={"quilt": {
        "device": "looking-glass-27-landscape", "calibration": None, "camera_model": "perspective"}}))
    write_image(quilt, np.zeros((4320, 7680, 3), np.uint8), base_record("quilt", grid=[8, 6], source=str(source)))
    before = sorted(p.name for p in tmp_path.iterdir())
    line = one_error_line(cli("replay", quilt, "-o", tmp_path / "r.png"))
    assert "no public factory calibration" in line and "--calibration" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == before
