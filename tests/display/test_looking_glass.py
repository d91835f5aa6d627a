"""visual.json reading and writing, and the Looking Glass device table."""

from __future__ import annotations

import json
import math
import warnings

import pytest

from povh3d.display.looking_glass import (DEVICES, device, device_of, parse_visual, read_visual,
                                          visual_fields, visual_json)
from povh3d.errors import ConfigError, InputError, Povh3dWarning

# A Portrait's file as the unit ships it (numbers as {"value": x}; values of a real unit's shape).
PORTRAIT = {"configVersion": "3.0", "serial": "LKG-PORT-01234", "pitch": {"value": 52.59267},
            "slope": {"value": -7.08354}, "center": {"value": 0.81679}, "viewCone": {"value": 40.0},
            "invView": {"value": 1.0}, "verticalAngle": {"value": 0.0}, "DPI": {"value": 324.0},
            "screenW": {"value": 1536.0}, "screenH": {"value": 2048.0}, "flipImageX": {"value": 0.0},
            "flipImageY": {"value": 0.0}, "flipSubp": {"value": 0.0}, "fringe": {"value": 0.0}}


#: The models with a public factory calibration (the 27" has none: its entries hold the quilt).
FACTORY = {name: d for name, d in DEVICES.items() if d.calibration is not None}


def quiet(data):
    with warnings.catch_warnings():
        warnings.simplefilter("error", Povh3dWarning)
        return parse_visual(data)


def test_value_objects_and_bare_numbers_read_alike():
    bare = {k: (v["value"] if isinstance(v, dict) else v) for k, v in PORTRAIT.items()}
    a, b = quiet(PORTRAIT), quiet(bare)
    assert a == b
    assert (a.screen_w, a.screen_h, a.view_cone, a.inv_view, a.flip_x) == (1536, 2048, 40.0, True, False)
    assert a.pitch == pytest.approx(52.59267)


def test_written_the_vendors_way_and_read_back():
    for d in FACTORY.values():
        fields = visual_fields(d.calibration)
        assert all(isinstance(fields[k], dict) and set(fields[k]) == {"value"}
                   for k in ("pitch", "slope", "center", "DPI", "screenW", "screenH", "viewCone", "invView"))
        assert quiet(json.loads(visual_json(d.calibration))) == d.calibration


def test_gen3_cells_read_with_either_spelling():
    d = DEVICES["looking-glass-16-portrait"]
    fields = visual_fields(d.calibration)
    assert quiet(fields).subpixel_cells == d.calibration.subpixel_cells
    fields["cellPatternMode"] = fields.pop("CellPatternMode")
    assert quiet(fields).cell_pattern == 4


def test_unused_fields_warn_in_one_line():
    data = dict(PORTRAIT, fringe={"value": 2.0}, shaderTweak=1)
    with pytest.warns(Povh3dWarning) as record:
        parse_visual(data)
    assert len(record) == 1
    msg = str(record[0].message)
    assert "\n" not in msg and "fringe" in msg and "shaderTweak" in msg


def test_povh3d_calibrate_fields_do_not_warn():
    # the keys 'povh3d calibrate --lattice lenticular --dpi' writes (calibration.lenticular.to_dict, commands.calibration)
    quiet(dict(PORTRAIT, kind="lenticular", pitch_px=6.1, slant_deg=8.0, phase_px=0.1, k1=0.0,
               image_size=[1536, 2048], residual_rad=0.01, tiles=4, seconds=1.0, white_image="w.png"))


@pytest.mark.parametrize("bad", [{"pitch": {"value": "x"}}, {"slope": 0}, {"screenW": 0}, {"viewCone": 200},
                                 {"screenW": 1536.5}, {"CellPatternMode": 7},
                                 {"subpixelCells": [{"ROffsetX": 0}]}])
def test_malformed_fields_are_one_line_errors(bad):
    with pytest.raises(ConfigError) as err:
        parse_visual(dict(PORTRAIT, **bad))
    assert "\n" not in str(err.value)


def test_missing_field_names_it():
    data = dict(PORTRAIT)
    del data["screenH"]
    with pytest.raises(ConfigError, match="screenH"):
        parse_visual(data)


def test_file_errors(tmp_path):
    with pytest.raises(InputError):
        read_visual(tmp_path / "none.json")
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(InputError, match="not JSON"):
        read_visual(tmp_path / "bad.json")
    (tmp_path / "visual.json").write_text(json.dumps(PORTRAIT))
    assert read_visual(tmp_path / "visual.json").serial == "LKG-PORT-01234"


def test_contradictions_with_the_device_are_errors():
    portrait = device("looking-glass-portrait")
    cal = quiet(PORTRAIT)
    portrait.check(cal)                                 # a real unit's file passes
    for change, word in (({"screenW": {"value": 262}}, "panel"), ({"viewCone": {"value": 13.8}}, "viewCone"),
                         ({"DPI": {"value": 283}}, "DPI")):
        with pytest.raises(ConfigError, match=word):
            portrait.check(quiet(dict(PORTRAIT, **change)))
    assert device_of(cal) is portrait
    assert device_of(DEVICES["looking-glass-go"].calibration).name == "looking-glass-go"


def test_device_table_is_self_consistent():
    for d in DEVICES.values():
        w, h = d.tile_size
        assert 0 <= d.quilt_size[0] - d.grid[0] * w < d.grid[0] and 0 <= d.quilt_size[1] - d.grid[1] * h < d.grid[1]
        width, height = d.nominal_size_mm
        assert d.aspect == pytest.approx(width / height, rel=1e-4)               # views have the panel's shape
        cal = d.calibration
        if cal is None:   # the 27": the quilt alone, for the nominal diagonal and the family's cone
            assert math.hypot(width, height) == pytest.approx(d.diagonal_in * 25.4) and d.default_cone == 50
            continue
        assert d.aspect == pytest.approx(cal.screen_w / cal.screen_h, abs=1e-4)
        assert 5 < abs(cal.slant_deg) < 12                                       # slanted sheets, a few degrees
        assert 0.2 < cal.lens_pitch_mm < 1.0


def test_portrait_figures():
    d = device("looking-glass-portrait")
    assert (d.quilt_size, d.grid, d.aspect, d.tile_size) == ((3360, 3360), (8, 6), 0.75, (420, 560))
    assert d.calibration.size_mm == pytest.approx((1536 * 25.4 / 324, 2048 * 25.4 / 324))
    # 52 lenticules per inch across the sheet, slanted atan(1/7): 0.4934 mm along a row
    assert d.calibration.lens_pitch_mm == pytest.approx(25.4 / 52 / math.cos(math.atan(1 / 7)))


def test_cone_and_panel_checks():
    from povh3d.display.looking_glass import check_panel, check_view_cone
    from povh3d.display.presets import lens_array

    cal = quiet(PORTRAIT)
    a = lens_array("looking-glass-portrait")
    check_view_cone(cal, a.viewing_angle_deg)              # the preset's focal spans the vendor's cone
    with pytest.raises(ConfigError, match="viewCone"):
        check_view_cone(cal, 13.8)
    check_panel(cal, (1536, 2048), 25.4 / 324)
    with pytest.raises(ConfigError, match="262x56"):
        check_panel(cal, (262, 56))
    with pytest.raises(ConfigError, match="DPI"):
        check_panel(cal, (1536, 2048), 0.1)


def test_portrait_quilt_is_named_the_vendors_way():
    from povh3d.image.quilt import quilt_name, view_aspect

    d = device("looking-glass-portrait")
    assert quilt_name("sample", *d.grid, d.aspect) == "sample_qs8x6a0.75.png"
    # the physical panel gives the same aspect (the views cover the whole screen)
    assert quilt_name("sample", *d.grid, view_aspect(*d.calibration.size_mm)) == "sample_qs8x6a0.75.png"
