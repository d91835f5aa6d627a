"""A Looking Glass ``visual.json`` through the commands: ``map --calibration`` (the file's screen is
the panel), ``render --method subpixel --calibration`` (panel, device and view cone checked),
``calibrate --dpi`` (the vendor's ``{"value": x}``)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from povh3d.display.looking_glass import DEVICES, visual_json
from povh3d.image.io import read_png, write_png
from povh3d.display.mappings.looking_glass_shader import view_fractions
from tests.support.cli import one_error_line

PORTRAIT = DEVICES["looking-glass-portrait"].calibration


def _visual(path, cal=PORTRAIT, **extra):
    data = json.loads(visual_json(cal))
    data.update(extra)
    path.write_text(json.dumps(data))
    return path


def test_map_with_a_portrait_calibration_fills_its_screen_as_the_shader_does(tmp_path, cli):
    """The view-space image whose every view is its own index, mapped with the unit's file: the
    panel is the file's 1536 x 2048 screen (not a size inferred from the image) and its subpixels
    show the view the vendor's shader (view_fractions, an independent form) picks."""
    cal = _visual(tmp_path / "visual.json")
    lenses = 244                                    # the view-space image the mapping reads
    image = np.broadcast_to((np.arange(lenses * 48) % 48).astype(np.uint8)[None, :, None], (2048, lenses * 48, 3))
    write_png(tmp_path / "views.png", np.ascontiguousarray(image))
    out = tmp_path / "panel.png"
    result = cli("map", tmp_path / "views.png", "--mapping", "slanted", "--views", "48", "--calibration", cal,
                 "-o", out)
    assert result.code == 0, result.err
    mapped = read_png(out)
    assert mapped.shape == (2048, 1536, 3)
    shader = np.minimum((view_fractions(PORTRAIT) * 48).astype(np.int64), 47)
    assert np.mean(mapped == shader) >= 0.999
    flipped = np.minimum((view_fractions(replace(PORTRAIT, slope=-PORTRAIT.slope)) * 48).astype(np.int64), 47)
    assert np.mean(mapped == flipped) < 0.999                       # negative control


@pytest.mark.parametrize("args, words", [
    (["--preset", "looking-glass-go"], "Looking Glass Go is 1440x2560"),     # another device's file
    (["--panel-size", "1500x2048"], "drop --panel-size"),
    (["--offset", "3"], "drop --offset"),
])
def test_map_refuses_a_calibration_that_contradicts_the_display(tmp_path, cli, args, words):
    cal = _visual(tmp_path / "visual.json")
    write_png(tmp_path / "views.png", np.zeros((2048, 244 * 48, 3), np.uint8))
    out = tmp_path / "panel.png"
    line = one_error_line(cli("map", tmp_path / "views.png", "--mapping", "slanted", "--views", "48",
                              "--calibration", cal, *args, "-o", out))
    assert words in line and not out.exists()


def test_subpixel_render_refuses_a_cone_the_sheet_does_not_span(tmp_path):
    """alioscopy-42's sheet spans 35.8 deg: a file of its sheet that says 40 is of another display.
    The same file without viewCone, or with the sheet's own cone, is taken."""
    from povh3d.display.display import build_display
    from povh3d.display.looking_glass import Calibration
    from povh3d.display.calibrated_sheet import view_cone_deg
    from povh3d.errors import ConfigError

    nominal = build_display("alioscopy-42", method="subpixel").lens_array
    cone = view_cone_deg(nominal)
    assert cone == pytest.approx(35.80, abs=0.01)
    pitch_lpi = 25.4 / nominal.pitch_x
    cal = Calibration(pitch_lpi, 1 / np.tan(np.radians(nominal.rotation)), 0.3, 25.4 / 0.4845, 1920, 1080, 40.0,
                      False)
    with pytest.raises(ConfigError, match="viewCone is 40 deg but the views span 35.8"):
        build_display("alioscopy-42", method="subpixel", calibration=_visual(tmp_path / "a.json", cal))
    plain = json.loads(visual_json(cal))
    del plain["viewCone"]
    (tmp_path / "b.json").write_text(json.dumps(plain))
    build_display("alioscopy-42", method="subpixel", calibration=tmp_path / "b.json")
    own = build_display("alioscopy-42", method="subpixel",
                        calibration=_visual(tmp_path / "c.json", replace(cal, view_cone=round(cone, 2))))
    assert view_cone_deg(own.lens_array) == pytest.approx(cone, abs=0.01)


def test_subpixel_render_on_the_portrait_uses_its_cone_and_screen(tmp_path):
    from povh3d.display.display import build_display
    from povh3d.display.calibrated_sheet import view_cone_deg
    from povh3d.errors import ConfigError

    display = build_display("looking-glass-portrait", method="subpixel", calibration=_visual(tmp_path / "v.json"))
    assert view_cone_deg(display.lens_array) == pytest.approx(40.0, abs=1e-6)
    assert (display.lens_array.panel.width, display.lens_array.panel.height) == (1536, 2048)
    go = DEVICES["looking-glass-go"].calibration
    with pytest.raises(ConfigError, match="1440x2560 pixel screen but the panel is 1536x2048"):
        build_display("looking-glass-portrait", method="subpixel", calibration=_visual(tmp_path / "g.json", go))


def test_a_cone_decides_the_focal_length_where_the_display_names_no_sheet(tmp_path):
    """A square preset has no sheet of its own: the file gives it, and its viewCone the focal length."""
    from povh3d.display.calibrated_sheet import calibrated_sheet, view_cone_deg
    from povh3d.geometry.lens_array import Panel

    data = json.loads(visual_json(replace(PORTRAIT, view_cone=30.0)))
    sheet, _, _ = calibrated_sheet(data, Panel(1536, 2048, 25.4 / 324, 25.4 / 324), 5.0)
    assert view_cone_deg(sheet) == pytest.approx(30.0, abs=1e-9)
    del data["viewCone"]
    sheet, _, _ = calibrated_sheet(data, Panel(1536, 2048, 25.4 / 324, 25.4 / 324), 5.0)
    assert sheet.focal == 5.0                                        # control: no cone, the given focal


def test_calibrate_dpi_writes_the_vendors_value_objects(tmp_path):
    from povh3d.commands.calibration import calibrate_lenticular_file
    from povh3d.display.looking_glass import read_visual
    from povh3d.image.colour import encode
    from tests.support.synth import render_lenticular_white

    white = render_lenticular_white((240, 160), 9.37, 9.46, 0.4, noise=0.01)
    write_png(tmp_path / "w.png", encode(np.clip(np.repeat(white[..., None], 3, 2), 0, 1), np.uint16))
    record = calibrate_lenticular_file(tmp_path / "w.png", tmp_path / "lg.json", dpi=254.0)
    for key in ("pitch", "slope", "center", "DPI", "screenW", "screenH", "invView"):
        assert set(record[key]) == {"value"}, key
    assert "viewCone" not in record                     # a white image measures no cone
    cal = read_visual(tmp_path / "lg.json")
    assert (cal.screen_w, cal.screen_h, cal.dpi) == (240, 160, 254.0)
    assert cal.slant_deg == pytest.approx(9.46, abs=0.01)
