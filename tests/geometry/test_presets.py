import math

import pytest

from povh3d.errors import ConfigError
from povh3d.display.presets import get_preset, lens_array_from_fields, load_presets, merge_overrides

THESIS_DISPLAYS = ["alioscopy-42", "philips-20", "ipad-retina", "hex-5.6", "parallax-barrier-22", "demo"]


#: Presets whose sheet is the unit's calibration (the Looking Glass 27"): no lens array without it.
UNIT_SHEET = [n for n, f in load_presets().items() if f.get("sheet_from") == "calibration"]


@pytest.mark.parametrize("name", [n for n in load_presets() if n not in UNIT_SHEET])
def test_every_preset_resolves(name):
    la = lens_array_from_fields(get_preset(name))
    assert la.lenses_x >= 1 and la.focal > 0


def test_thesis_displays_are_shipped():
    assert set(THESIS_DISPLAYS) <= set(load_presets())


def test_philips_matches_table_4_1_and_eq_4_2():
    fields = get_preset("philips-20")
    assert fields["lens_pitch"] == pytest.approx(0.255 / 3 * 4.5)  # Eq. 4.2: 0.3825 mm
    la = lens_array_from_fields(fields)
    assert la.lenses_x == 1066            # Table 4.1: 1066 lenses
    assert la.views == (1, 9)              # 9 pixels per lens
    assert la.h3d_size == (1200, 9594)     # 9 views of 1066 wide (section 4.6.1.3)
    assert fields["mapping"] == "philips"


def test_alioscopy_matches_table_4_2_and_eq_4_5():
    fields = get_preset("alioscopy-42")
    assert fields["lens_pitch"] == pytest.approx(0.4845 / 3 * 8)  # Eq. 4.5: 1.292 mm
    la = lens_array_from_fields(fields)
    assert la.lenses_x == 720              # Table 4.2: 720 lenses
    assert la.h3d_size[1] == 5760          # 8 views x 720 (section 4.6.2.3)
    assert math.degrees(math.atan(1 / 3)) == pytest.approx(fields["slant_deg"], abs=0.01)


def test_ipad_matches_table_5_11():
    la = lens_array_from_fields(get_preset("ipad-retina"))
    assert la.lenses_x == 341 and la.views == (1, 6)
    assert la.ppi_3d[1] == pytest.approx(264.6, abs=0.5)  # vertical 3D-PPI 264
    assert 25.4 / la.pitch_x == pytest.approx(44, abs=0.2)  # horizontal 3D-PPI 44


def test_hex_matches_table_3_2():
    la = lens_array_from_fields(get_preset("hex-5.6"))
    assert la.panel.size_mm == pytest.approx((120.96, 75.6))
    assert la.pitch_y == pytest.approx(0.85 * math.sqrt(3) / 2)
    assert la.views is None


def test_cli_style_overrides_rederive_the_panel():
    la = lens_array_from_fields(merge_overrides(get_preset("demo"), dict(grid="lenticular", lenses=240, ppl=8, rows=1080)))
    assert (la.panel.width, la.panel.height) == (1920, 1080)
    la = lens_array_from_fields(merge_overrides(get_preset("demo"), dict(lenses=(120, 68), ppl=(8, 8))))
    assert (la.panel.width, la.panel.height) == (960, 544) and la.views == (8, 8)


def test_unknown_preset_lists_the_names():
    with pytest.raises(ConfigError, match="demo"):
        get_preset("nope")


def test_lens_array_larger_than_given_panel():
    with pytest.raises(ConfigError, match="larger than the panel"):
        lens_array_from_fields(merge_overrides(get_preset("demo"), dict(lenses=(100, 10), panel=(320, 240))))
