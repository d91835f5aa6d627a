"""``Display``: one value built by one function for the command line and the Python API,
written to the sidecar and read back by one pair of functions.

Oracles: the command line's request carries the display ``build_display`` makes from the
same values; every display's record reads back into a display whose record is the same
and whose lens array is the array rendered.  Controls: a changed record reads back as
another display; a record without its focal length is refused in one line.
"""

from __future__ import annotations

import pytest

from povh3d.display.display import Display, build_display
from povh3d.cli.main import build_parser
from povh3d.cli.render import request_from_args
from povh3d.errors import ConfigError

DISPLAYS = {
    "demo": ({}, {}),
    "demo, 6 ppl": ({"ppl": 6}, {}),
    "lenticular, turned": ({"grid": "lenticular", "ppl": 5, "lens_rotation": 11.3}, {}),
    "lattice": ({"lattice": "0.6,0;0.1,0.6", "panel": [120, 90]}, {}),
    "alioscopy, mapped": ({"panel": [60, 30]}, {"mapping": "alioscopy"}),
    "philips, subpixel sheet": ({"panel": [60, 30]}, {"method": "subpixel"}),
}
PRESET = {"alioscopy, mapped": "alioscopy-42", "philips, subpixel sheet": "philips-20"}
CLI = {
    "demo": (), "demo, 6 ppl": ("--ppl", "6"),
    "lenticular, turned": ("--grid", "lenticular", "--ppl", "5", "--lens-rotation", "11.3"),
    "lattice": ("--lattice", "0.6,0;0.1,0.6", "--panel", "120x90"),
    "alioscopy, mapped": ("--preset", "alioscopy-42", "--panel", "60x30", "--mapping", "alioscopy"),
    "philips, subpixel sheet": ("--preset", "philips-20", "--panel", "60x30", "--method", "subpixel"),
}


def _display(name: str) -> Display:
    overrides, options = DISPLAYS[name]
    return build_display(PRESET.get(name, "demo"), overrides, **options)


@pytest.mark.parametrize("name", DISPLAYS)
def test_the_command_line_builds_the_same_display(name, tmp_path):
    args = build_parser().parse_args(["render", str(tmp_path / "s.pov"), *CLI[name]])
    assert request_from_args(args).display.as_record() == _display(name).as_record()


@pytest.mark.parametrize("name", DISPLAYS)
def test_the_record_reads_back_into_the_display(name):
    display = _display(name)
    back = Display.from_record(display.as_record())
    assert back.lens_array == display.render_array
    assert back.as_record() == display.as_record()
    assert (back.sheet is not None) == (name == "philips, subpixel sheet")


def test_a_changed_record_is_another_display():
    record = _display("demo, 6 ppl").as_record()
    record["lens_array"]["focal_mm"] *= 2
    assert Display.from_record(record).lens_array != _display("demo, 6 ppl").lens_array
    del record["lens_array"]["focal_mm"]
    with pytest.raises(ConfigError, match="incomplete"):
        Display.from_record(record)


def test_a_lens_array_of_your_own_takes_no_overrides():
    with pytest.raises(ConfigError, match="overrides"):
        build_display(lens_array=_display("demo").lens_array, overrides={"ppl": 4})
