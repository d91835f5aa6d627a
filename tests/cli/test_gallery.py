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
# screen.inc's scene has fog over a ground plane the display's lower rays start below: POV-Ray's mesh
# camera (multi-ortho) would give them the outside state of its first ray and fog them, where each
# view's own orthographic render does not (15 dB); povh3d refuses it in one line where multi-ortho is
# chosen (app/ray_state.py), and by default renders it with an orthographic camera a view, right.
VIEWS = ("--grid", "square", "--lenses", "24x18", "--ppl", "3x3", "--pixel-pitch", "0.2", "--focal", "2")
CHOSEN = (*SQUARE, "--method", "multi-ortho")

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
    ("incdemo/screen.pov", "camera in an include (screen.inc); fog, rays starting below the ground", CHOSEN,
     "refused"),
    ("incdemo/screen.pov", "the same by default: an orthographic camera a view (9 views)", VIEWS, "ok"),
    # glass.inc's and textures.inc's glass (an ior) included, never applied: not the ray-state rule's
    ("templates/Basic_Scenes/Sea_blue_sky.pov", "included glass it does not apply, a chrome sea", SQUARE, "ok"),
    # fog; only the oblique views' rays start below the ground (8.6 dB before the origin pass)
    ("textures/finishes/metallicreflection.pov", "fog, oblique rays starting below the ground", VIEWS, "ok"),
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


@pytest.mark.parametrize("worst_db, realizations_db, verdict", [
    (36.0, math.nan, "ok"),            # 35 dB met: no second realization needed
    (31.0, 33.0, "stochastic"),        # within 3 dB of what POV-Ray's own two renders differ by
    (29.0, 33.0, "wrong"),             # further off than POV-Ray's own noise
    (30.0, math.inf, "wrong"),         # deterministic lighting: the 35 dB rule as is
    (30.0, math.nan, "wrong"),         # not measured
])
def test_the_stochastic_verdict(worst_db, realizations_db, verdict):
    from benchmarks.gallery import view_verdict

    assert view_verdict(worst_db, realizations_db) == verdict


def test_a_radiosity_view_is_judged_against_povrays_own_noise(cli, tmp_path):
    """Radiosity samples its lighting on each render's image grid: the views of radiosity3.pov fall under
    35 dB against their oblique orthographic renders, but no further than POV-Ray's own renders of the
    same rays with the grid shifted differ (tests/engine/test_radiosity_grid.py; 33 dB here).  Negative
    control: the view set against its neighbour's render (one view, 0.1 of a lens pitch off) falls well
    below the tolerance."""
    import json

    from benchmarks.gallery import STOCHASTIC_MARGIN_DB, oracle_view, realizations_psnr, view_verdict
    from povh3d.image.io import read_png
    from povh3d.image.metrics import psnr

    scene, out, views = EXAMPLES / "radiosity/radiosity3.pov", tmp_path / "r.png", tmp_path / "views"
    result = cli("render", str(scene), "-o", str(out), *SQUARE, "--quality", "draft", "-q", "--views-dir", str(views),
                 cwd=scene.parent)
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    view = read_png(views / "v_003_003.png")[..., :3]
    a = oracle_view(scene, record, (3, 3), view.shape[:2], 120)[..., :3]
    neighbour = oracle_view(scene, record, (3, 4), view.shape[:2], 120)[..., :3]
    realizations = realizations_psnr(scene, record, (3, 3), a, 120)
    assert realizations < 40, "radiosity3 no longer differs between realizations: pick another scene"
    assert view_verdict(psnr(view, a), realizations) in ("ok", "stochastic")
    assert psnr(view, neighbour) < realizations - STOCHASTIC_MARGIN_DB
