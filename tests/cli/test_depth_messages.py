"""What the command line says of a depth pass that cannot measure (issue 21 item 5): a pass blind
inside a solid names the cause and the fix, never "nothing hit"; an empty field still says so."""

from __future__ import annotations

import json

import pytest

pytestmark = pytest.mark.povray  # every test here renders with POV-Ray

ARRAY = ("--grid", "square", "--lenses", "24x18", "--ppl", "6x6", "--pixel-pitch", "0.2", "--focal", "2")
SCENE = """#version 3.7;
camera {{ location <0, 0, -20> look_at <0, 0, 0> angle 30 }}
light_source {{ <0, 9, -9> rgb 1 }}
{backdrop}
sphere {{ 0, 3 pigment {{ rgb 0.5 }} }}
"""


def test_info_inside_a_solid_measures_on_the_hollow_copy(cli, tmp_path):
    scene = tmp_path / "backdrop.pov"   # plane { z, 10 }: its inside (z < 10) holds the camera
    scene.write_text(SCENE.format(backdrop="plane { z, 10 pigment { rgb 1 } }"))
    report = json.loads(cli("info", str(scene), "--json", *ARRAY).out)["scene"]["depth"]
    assert "blind" not in report and report["empty"] is False and report["unmeasured_fraction"] == 0.0
    assert "hollow" in report["measured_on"]


def test_a_blind_pass_names_the_cause_and_the_fix(cli, tmp_path):
    """Negative control of the hollow copy: a backdrop from an include in another folder (``--include``;
    the copy rewrites only the scene's own folder, never the user's files) leaves the pass blind, and
    the command says why and the fix."""
    lib, folder = tmp_path / "lib", tmp_path / "scene"
    lib.mkdir()
    folder.mkdir()
    (lib / "backdrop.inc").write_text("plane { z, 10 pigment { rgb 1 } }\n")
    scene = folder / "backdrop.pov"
    scene.write_text(SCENE.format(backdrop='#include "backdrop.inc"'))
    rendered = cli("render", str(scene), "-o", str(tmp_path / "b.png"), "--quality", "draft", "--depth-report",
                   "--include", str(lib), *ARRAY)
    assert rendered.code == 0, rendered.err
    assert "inside a solid" in rendered.err and "'hollow'" in rendered.err and "nothing in the middle" not in rendered.err
    depth = json.loads((tmp_path / "b.json").read_text())["placement"]["depth"]
    assert depth["blind"] is True and depth["empty"] is False


def test_the_hollow_backdrop_is_measured_and_an_empty_field_is_still_empty(cli, tmp_path):
    """Negative controls: with the fix the message names, the depth is measured; a field with nothing
    in it is reported as such, not as blind."""
    hollow = tmp_path / "hollow.pov"
    hollow.write_text(SCENE.format(backdrop="plane { z, 10 pigment { rgb 1 } hollow }"))
    depth = json.loads(cli("info", str(hollow), "--json", *ARRAY).out)["scene"]["depth"]
    assert "blind" not in depth and depth["empty"] is False and depth["unmeasured_fraction"] == 0.0
    empty = tmp_path / "empty.pov"
    empty.write_text(SCENE.format(backdrop="").replace("sphere { 0, 3", "sphere { <500, 0, 0>, 3"))
    result = cli("info", str(empty), *ARRAY)
    assert result.code == 0 and "nothing hit in the middle" in result.out and "inside a solid" not in result.out
