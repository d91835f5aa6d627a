"""Every view's ray origins, not the display normal's alone (renderer/placement/ray_state.py, renderer/passes/depth.py).

An oblique view's rays start ``front_clearance * slope`` further out than the centre view's: below a
ground plane the normal's rays clear (textures/finishes/metallicreflection.pov, lights/circular.pov).
The origin pass covers the plane that holds them all; a default method whose mesh camera would share
one ray state falls back to ``multi-ortho-views``, a chosen one is refused in one line.  The same for a
scene that builds something from ``image_width`` (language/image_size.pov).  Oracle: each view against
POV-Ray's own oblique orthographic render of it (the gallery's ``oracle_view``), with negative controls."""

from __future__ import annotations

import json

import pytest

from benchmarks.gallery import oracle_view
from povh3d.image.io import read_png
from povh3d.image.metrics import psnr

# No camera: the native frame, mm around the screen z = 0.  The display is 16 x 12 mm; its rays start
# 64 mm out (four panel widths) with slopes up to 0.5 / 2 = 1/4: the centre view's origins span
# y = -6 .. 6 mm, every view's y = -22 .. 22 mm.  A ground at y = -12 holds the lower views' only.
OBLIQUE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
light_source {{ <20, 40, -80> rgb 1 }}
background {{ rgb <0.2, 0.3, 0.9> }}
{fog}
plane {{ y, {ground} pigment {{ checker rgb 1 rgb 0.3 scale 4 }} {hollow} }}
sphere {{ 0, 4 pigment {{ rgb <1, 0.3, 0.1> }} }}
{around}
"""
FOG = "fog { rgb 0.8 distance 40 }"
SMALL = ("--grid", "square", "--lenses", "16x12", "--ppl", "4x4", "--pixel-pitch", "0.25", "--focal", "2",
         "--quality", "draft", "-q")


def _scene(tmp_path, ground=-12, hollow="", fog=FOG, around=""):
    scene = tmp_path / "oblique.pov"
    scene.write_text(OBLIQUE.format(fog=fog, ground=ground, hollow=hollow, around=around))
    return scene


def test_the_origin_field_widens_the_lens_field_by_the_clearance_times_the_slope():
    from povh3d.renderer.passes.depth import origin_field
    from povh3d.geometry.lens_array import LensArray, Panel

    panel = Panel(64, 48, 0.25, 0.25)
    square = LensArray("square", 16, 12, 1.0, 1.0, 2.0, panel)
    assert origin_field(square, 64.0) == pytest.approx((16 + 2 * 64 * 0.25, 12 + 2 * 64 * 0.25))
    lenticular = LensArray("lenticular", 16, 48, 1.0, 0.25, 2.0, panel)   # rays keep their row
    assert origin_field(lenticular, 64.0) == pytest.approx((48.0, 12.0))


@pytest.mark.povray
@pytest.mark.parametrize("ground, expected", [(-12, 10 / 44), (-30, 0.0)])   # control: below every origin
def test_the_origin_pass_measures_every_views_origins_inside_the_ground(tmp_path, ground, expected):
    """The share of y = -22 .. 22 below the ground: 10/44; the normal's own field (y = -6 .. 6) has none."""
    from povh3d.renderer.passes.depth import origins_inside
    from povh3d.renderer.methods.quality import RenderSettings
    from povh3d.geometry.lens_array import LensArray, Panel
    from povh3d.scene.scene import load_scene

    scene = load_scene(_scene(tmp_path, ground))
    array = LensArray("square", 16, 12, 1.0, 1.0, 2.0, Panel(64, 48, 0.25, 0.25))
    settings = RenderSettings(cache_dir=tmp_path / "cache")
    assert origins_inside(scene, array, settings, 64.0, 1.0) == pytest.approx(expected, abs=0.02)
    # The centre view's origins alone (a focal length of a metre: no widening to speak of) are all above it.
    flat = LensArray("square", 16, 12, 1.0, 1.0, 1000.0, Panel(64, 48, 0.25, 0.25))
    assert origins_inside(scene, flat, settings, 64.0, 1.0) == 0.0


def _render(cli, tmp_path, scene, *options):
    out, views = tmp_path / "o.png", tmp_path / "views"
    result = cli("render", str(scene), "-o", str(out), *SMALL, "--views-dir", str(views), *options)
    record = json.loads(out.with_suffix(".json").read_text()) if result.code == 0 else None
    return result, out, views, record


def _worst_db(scene, record, views, picks=((3, 0), (0, 3), (3, 3))):
    """The worst of the picked views (the lower corners start below the ground) against POV-Ray's own."""
    worst = float("inf")
    for l, k in picks:
        view = read_png(views / f"v_{l:03d}_{k:03d}.png")[..., :3]
        worst = min(worst, psnr(view, oracle_view(scene, record, (l, k), view.shape[:2], timeout=120)[..., :3]))
    return worst


@pytest.mark.povray
def test_a_default_render_whose_oblique_rays_start_below_the_ground_falls_back_and_is_right(cli, tmp_path):
    scene = _scene(tmp_path)
    result, out, views, record = _render(cli, tmp_path, scene)
    assert result.code == 0, result.err
    assert record["method"] == "multi-ortho-views" and record["method_chosen"] is False
    assert "inside a solid" in record["method_note"] and "fog" in record["method_note"]
    assert "not the default multi-ortho" in result.out
    assert record["placement"]["ray_state"]["origins_inside_fraction"] == pytest.approx(10 / 44, abs=0.02)
    assert _worst_db(scene, record, views) >= 35


@pytest.mark.povray
def test_a_chosen_mesh_camera_method_is_refused_in_one_line(cli, tmp_path):
    result, out, _, _ = _render(cli, tmp_path, _scene(tmp_path), "--method", "multi-ortho")
    lines = [line for line in result.err.splitlines() if line.strip()]
    assert result.code != 0 and not out.exists()
    assert len(lines) == 1 and "every view's" in lines[0] and "multi-ortho-views" in lines[0], result.err


@pytest.mark.povray
def test_past_the_rule_the_mesh_camera_is_wrong_there(cli, tmp_path, monkeypatch):
    """Negative control of the oracle: multi-ortho's lower views, the rule skipped, miss POV-Ray's own."""
    monkeypatch.setattr("povh3d.renderer.render.settle_method", lambda request, scene, *_: (request, None))
    scene = _scene(tmp_path)
    result, _, views, record = _render(cli, tmp_path, scene)
    assert result.code == 0 and record["method"] == "multi-ortho", result.err
    assert _worst_db(scene, record, views) < 35


@pytest.mark.povray
@pytest.mark.parametrize("case, kept", [
    ({"hollow": "hollow"}, True),                                  # fog inside the ground too: one state is right
    ({"ground": -30}, True),                                       # below every origin
    # A solid sky around every origin is one state too, but the pass cannot tell it from a scene whose
    # own fog hides the pass's (Desert_blue_sky's ground fog): the default falls back, still right.
    ({"around": "sphere { 0, 5000 pigment { rgb 0.5 } }"}, False),
])
def test_one_state_for_every_ray_keeps_the_default_and_is_right(cli, tmp_path, case, kept):
    scene = _scene(tmp_path, **case)
    result, _, views, record = _render(cli, tmp_path, scene)
    assert result.code == 0, result.err
    assert record["method"] == ("multi-ortho" if kept else "multi-ortho-views")
    assert ("method_note" not in record) == kept
    state = record["placement"]["ray_state"]
    assert state["origins_inside_fraction"] == (0.0 if kept else 1.0)
    # The pass looked from where the render's rays start (renderer/placement/clearance.py: the same rule).
    if kept:
        assert state["front_clearance_mm"] == record["quality"]["front_clearance_mm"]
    assert _worst_db(scene, record, views) >= 35


# language/image_size.pov prints image_width * image_height: here a bar as wide as image_width says.
IMAGE_SIZE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
light_source {{ <20, 40, -80> rgb 1 }}
background {{ rgb 0.1 }}
box {{ <-8, -2, 0>, <-8 + {width}, 2, 1> pigment {{ rgb <1, 0.8, 0.2> }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize("width, method, outcome", [
    ("image_width / 10", None, "fallback"),           # each view a run of its own size: right
    ("image_width / 10", "multi-ortho", "refused"),   # many views in one run: the bar too long
    ("image_width / image_height * 9", None, "kept"),  # the ratio: the panel's, whatever the run
])
def test_a_scene_built_from_image_width_renders_each_view_at_its_own_size(cli, tmp_path, width, method, outcome):
    scene = tmp_path / "size.pov"
    scene.write_text(IMAGE_SIZE.format(width=width))
    result, out, views, record = _render(cli, tmp_path, scene, *(("--method", method) if method else ()))
    if outcome == "refused":
        lines = [line for line in result.err.splitlines() if line.strip()]
        assert result.code != 0 and not out.exists() and len(lines) == 1, result.err
        assert "image_width" in lines[0] and "--method multi-ortho-views" in lines[0]
        return
    assert result.code == 0, result.err
    assert record["method"] == ("multi-ortho-views" if outcome == "fallback" else "multi-ortho")
    assert ("image_width" in record.get("method_note", "")) == (outcome == "fallback")
    assert _worst_db(scene, record, views, picks=((0, 0), (2, 2))) >= 35


# A hollow box of glowing media that the lower half of the origins (y < 0) starts in (a room the frame
# cuts): fog would fill it, but its own media and an ior depend on which objects a ray starts in.
ROOM = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
light_source {{ <20, 40, -80> rgb 1 }}
background {{ rgb <0.1, 0.1, 0.3> }}
sphere {{ <0, 0, 10>, 4 pigment {{ rgb <1, 0.3, 0.1> }} }}
box {{ <-200, -200, -200>, <200, {top}, 200> hollow pigment {{ rgbt 1 }}
      interior {{ media {{ emission <0.02, 0.2, 0.02> }} }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize("top, method, outcome", [
    (0, None, "fallback"),            # half the origins inside the hollow room: right, one camera a view
    (0, "multi-ortho", "refused"),
    (200, None, "fallback"),          # every origin inside it: one state, but see test_one_state_...
])
def test_origins_partly_inside_a_hollow_room_of_media(cli, tmp_path, top, method, outcome):
    scene = tmp_path / "room.pov"
    scene.write_text(ROOM.format(top=top))
    result, out, views, record = _render(cli, tmp_path, scene, *(("--method", method) if method else ()))
    if outcome == "refused":
        lines = [line for line in result.err.splitlines() if line.strip()]
        assert result.code != 0 and not out.exists() and len(lines) == 1, result.err
        assert "hollow ones counted" in lines[0] and "media" in lines[0] and "multi-ortho-views" in lines[0]
        return
    assert result.code == 0, result.err
    state = record["placement"]["ray_state"]
    assert state["origins_inside_fraction"] == 0.0   # fog would pass: the hollow room holds no solid
    assert state["origins_inside_hollow_or_solid_fraction"] == pytest.approx(0.5 if top == 0 else 1.0, abs=0.03)
    assert record["method"] == "multi-ortho-views"
    assert _worst_db(scene, record, views) >= 35


@pytest.mark.povray
def test_past_the_rule_the_mesh_camera_misses_the_hollow_rooms_media(cli, tmp_path, monkeypatch):
    """Negative control: the rule skipped, multi-ortho's lower views miss POV-Ray's own renders."""
    monkeypatch.setattr("povh3d.renderer.render.settle_method", lambda request, scene, *_: (request, None))
    scene = tmp_path / "room.pov"
    scene.write_text(ROOM.format(top=0))
    result, _, views, record = _render(cli, tmp_path, scene)
    assert result.code == 0 and record["method"] == "multi-ortho", result.err
    assert _worst_db(scene, record, views) < 35


@pytest.mark.parametrize("method, limit, expected", [
    ("multi-ortho", None, 64.0),          # four panel widths, a whole number of view-bank steps (f lcm = 8)
    ("multi-ortho", 30.0, 24.0),          # under a scene camera's limit: rounded down to a step
    ("multi-ortho", 5.0, 5.0),            # under one step: the lens mesh, from the limit itself
    ("multi-ortho-views", 30.0, 30.0),    # its views start anywhere
])
def test_the_origin_pass_looks_from_where_the_method_will_trace(method, limit, expected):
    """renderer/placement/clearance.py works the clearance out as run_method does (test_one_state_... checks a render)."""
    from povh3d.renderer.placement.clearance import planned_front_clearance
    from povh3d.renderer.methods.registry import get_method
    from povh3d.renderer.methods.quality import RenderSettings
    from povh3d.geometry.lens_array import LensArray, Panel

    array = LensArray("square", 16, 12, 1.0, 1.0, 2.0, Panel(64, 48, 0.25, 0.25))
    settings = RenderSettings(front_clearance_limit=limit)
    assert planned_front_clearance(get_method(method), array, settings) == pytest.approx(expected)
