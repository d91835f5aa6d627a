"""A dozen of POV-Ray's own sample scenes (Debian's ``povray-examples``, installed by ``make test``),
chosen for the constructs of issue 21, each a whole ``povh3d render`` command judged as
``make gallery`` judges it (benchmarks/gallery.py): the scene camera's frame, a finite depth
report, a non-empty image and views >= 35 dB against oblique orthographic renders placed by the
frame; or a refusal in one line.  A small display and ``--quality draft`` keep it quick."""

from __future__ import annotations

import math

import pytest

from benchmarks.gallery import EXAMPLES, MIN_DB, judge

pytestmark = pytest.mark.povray  # every test here renders with POV-Ray

SQUARE = ("--grid", "square", "--lenses", "24x18", "--ppl", "6x6", "--pixel-pitch", "0.2", "--focal", "2")
LENTICULAR = ("--grid", "lenticular", "--lenses", "32", "--rows", "96", "--ppl", "4", "--pixel-pitch", "0.25",
              "--focal", "1.5")
# The camera is found (frame camera, finite depth) but the views score 15 dB against the oblique
# orthographic renders: screen.inc places its objects in front of the camera, on the camera's own
# screen; why the views then differ is not yet known.
SCREEN = "screen.inc's on-screen objects: views 15 dB against the oblique orthographic renders (open)"

# scene, the construct it stands for, the display, the outcome expected ('ok' or 'refused')
CASES = [
    ("objects/ttf1.pov", "text", SQUARE, "ok"),
    ("objects/isosurfaces.pov", "isosurface, #declared camera location", SQUARE, "ok"),
    ("objects/csg/hfclip.pov", "height field", SQUARE, "ok"),
    ("interior/media/media3.pov", "media, image map", SQUARE, "ok"),
    ("radiosity/cornell.pov", "radiosity, mirrored right", SQUARE, "ok"),
    ("animations/clockd/clockd.pov", "animation (clock), no angle", SQUARE, "ok"),
    ("advanced/crater/crater.pov", "no angle, lenticular", LENTICULAR, "ok"),
    ("advanced/sunsethf.pov", "large units (camera 310 units away), height field", SQUARE, "ok"),
    ("templates/Basic_Scenes/Orthographic_scene.pov", "orthographic camera", SQUARE, "refused"),
    ("camera/cylinder1.pov", "cylinder camera", SQUARE, "refused"),
    pytest.param("objects/prism3a.pov", "camera in an include", SQUARE, "ok"),
    pytest.param("incdemo/screen.pov", "camera in an include (screen.inc)", SQUARE, "ok", marks=pytest.mark.xfail(
        strict=True, reason=SCREEN)),
]


@pytest.mark.parametrize("name, construct, display, expected", CASES)
def test_sample_scene_renders_framed_or_refuses_in_one_line(name, construct, display, expected):
    outcome = judge(EXAMPLES / name, "small", timeout=240.0, seconds_2d=math.nan, views=2, display=display)
    assert outcome.kind == expected, f"{construct}: {outcome}"
    if expected == "ok":
        assert outcome.frame == "camera" and outcome.worst_db >= MIN_DB
    else:
        assert outcome.note and "Traceback" not in outcome.note


def test_the_judge_rejects_a_silently_wrong_image(tmp_path):
    """Negative control of the outcome criteria: a scene whose only light is behind an opaque wall
    renders black; the judge calls it wrong (image not lit), not ok."""
    scene = tmp_path / "dark.pov"
    scene.write_text("#version 3.7;\ncamera { location <0, 0, -10> look_at 0 angle 40 }\n"
                     "sphere { 0, 2 pigment { rgb 1 } finish { ambient 0 diffuse 1 } }\n")
    outcome = judge(scene, "small", timeout=120.0, seconds_2d=math.nan, views=1, display=SQUARE)
    assert outcome.kind == "wrong" and "lit" in outcome.note
