"""Fog and media on rays that start inside a solid (renderer/placement/ray_state.py).

POV-Ray 3.7's mesh camera gives every ray the inside/outside state of the first ray a render
thread traces; its orthographic camera tests each ray.  The premise is checked on POV-Ray itself
(a 4x4 render), then povh3d's rule: a mesh-camera method refuses a frame whose rays start partly
inside a solid when the scene has fog or media, and renders the same frame otherwise."""

from __future__ import annotations

import json

import numpy as np
import pytest

from povh3d.renderer.placement.ray_state import check_ray_state, state_features
from povh3d.errors import ConfigError, param
from povh3d.image.io import read_image, read_png
from povh3d.povray.process import PovrayJob, run_jobs
from povh3d.scene.features import Features

FOG = Features(frozenset({"fog"}))


@pytest.mark.parametrize("inside", [0.05, 0.5, 1.0])   # 1.0: or the scene's own fog hid the pass's
@pytest.mark.parametrize("feature", ["fog", "media", "ior"])
def test_a_mesh_camera_refuses_rays_partly_inside_a_solid_with_fog(inside, feature):
    with pytest.raises(ConfigError, match=rf"inside a solid.*{feature}.*hollow.*method multi-ortho-views") as error:
        check_ray_state("multi-ortho", True, Features(frozenset({feature})), inside)
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("method, shares, features, inside", [
    ("multi-ortho", True, FOG, 0.0),                          # every ray outside: one state is right
    ("multi-ortho", True, Features(frozenset({"reflection"})), 0.3),   # nothing that depends on it
    ("multi-ortho-views", False, FOG, 0.3),                   # an orthographic camera tests each ray
])
def test_what_one_shared_state_renders_right_passes(method, shares, features, inside):
    check_ray_state(method, shares, features, inside)
    check_ray_state(method, shares, features, None)           # not measured: nothing to go by


def test_the_refusal_and_the_fallback_note_say_the_same_cause(tmp_path):
    """Each problem's refusal is its cause and its fix in one line; the fallback's note is that cause, after
    the method it falls back to (the fix is what it did), and the summary's few words."""
    from povh3d.renderer.placement.ray_state import hollow_problem, image_size_problem, ray_state_problem
    from povh3d.scene.scene import load_scene

    scene = tmp_path / "size.pov"
    scene.write_text("#declare N = image_width;\nsphere { 0, 1 }\n")
    problems = [(ray_state_problem("multi-ortho", True, FOG, 0.25), "hollow", "inside an object"),
                (hollow_problem("multi-ortho", ["media"], 0.5), param("method") + " multi-ortho-views", "inside an object"),
                (image_size_problem(load_scene(scene), "multi-ortho", (4, 4)), "#declare", "image_width")]
    for problem, fix, short in problems:
        line = problem.line()
        assert "\n" not in line and line == f"{problem.cause}: {problem.fix}" and fix in problem.fix
        note = problem.note("multi-ortho")
        assert note.startswith("multi-ortho-views, not the default multi-ortho") and note.endswith(": " + problem.cause)
        assert problem.fix not in note and short in problem.short
    assert ray_state_problem("multi-ortho", True, FOG, 0.0) is None and hollow_problem("multi-ortho", ["ior"], 0.0) is None


def test_an_ior_counts_only_in_the_scenes_own_files(tmp_path):
    """textures.inc declares glass with an ior that a scene including it need not apply (sunsethf.pov):
    only the scene's own ior counts; fog counts wherever it is written."""
    from povh3d.scene.scene import load_scene

    scene = tmp_path / "s.pov"
    scene.write_text('#version 3.7;\n#include "textures.inc"\nsphere { 0, 1 pigment { rgb 1 } }\n')
    assert "ior" in load_scene(scene).features and not state_features(load_scene(scene)).used
    scene.write_text('#version 3.7;\nsphere { 0, 1 pigment { rgbf 1 } interior { ior 1.33 } }\nfog { distance 9 }\n')
    assert state_features(load_scene(scene)).used == {"ior", "fog"}
    # An included interior the scene applies counts (lights/glassthing.pov: interior { I_Glass_Exp(2) ... }).
    scene.write_text('#version 3.7;\n#include "glass.inc"\nsphere { 0, 1 pigment { rgbf 1 } interior { I_Glass1 } }\n')
    assert state_features(load_scene(scene)).used == {"ior"}
    scene.write_text('#version 3.7;\n#include "glass.inc"\nsphere { 0, 1 pigment { rgbf 1 } }\n// interior { I_Glass1 }\n')
    assert not state_features(load_scene(scene)).used   # a comment applies nothing


# A fog of colour green over a background of blue; a ground plane y < H holds the lower rays' origins.
PREMISE = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
background {{ rgb <0, 0, 1> }}
fog {{ rgb <0, 1, 0> distance 5 }}
plane {{ y, {height} pigment {{ rgb <1, 0, 0> }} {hollow} }}
#declare M = mesh2 {{ vertex_vectors {{4, <-2, -2, -1>, <2, -2, -1>, <2, 2, -1>, <-2, 2, -1>}}
  normal_vectors {{4, z, z, z, z}} uv_vectors {{4, <0, 0>, <1, 0>, <1, 1>, <0, 1>}}
  face_indices {{2, <0, 1, 2>, <0, 2, 3>}} }}
{camera}
"""
MESH = "camera { mesh_camera { 1 3 mesh { M } smooth } }"
ORTHO = "camera { orthographic location <0, 0, -1> direction z right 4 * x up 4 * y }"


def _fogged_rows(tmp_path, camera: str, height: float, hollow: str = "") -> list[bool]:
    """Which of the 4 rows (top first; ray origins at y = 1.5, 0.5, -0.5, -1.5) show the fog."""
    images = []
    run_jobs([PovrayJob(name="state", script=PREMISE.format(height=height, hollow=hollow, camera=camera),
                        width=4, height=4, options=("-A",), threads=1)],
             processes=1, workdir=tmp_path, on_result=lambda r: images.append(read_image(r.images[0])))
    return [bool(px[1] > 128) for px in images[0][:, 1, :3]]


@pytest.mark.povray
def test_povray_mesh_camera_shares_the_first_rays_state(tmp_path):
    """The ground y < 0.2 holds the two lower rows' origins: the orthographic camera leaves their fog out,
    the mesh camera fogs all four (its first ray, row 0, starts outside); the ground y < 1.6 holds the
    first ray too, and the mesh camera fogs none.  Negative control: a hollow ground takes fog inside, and
    both cameras agree."""
    assert _fogged_rows(tmp_path, ORTHO, 0.2) == [True, True, False, False]
    assert _fogged_rows(tmp_path, MESH, 0.2) == [True, True, True, True]
    assert _fogged_rows(tmp_path, MESH, 1.6) == [False, False, False, False]
    assert _fogged_rows(tmp_path, ORTHO, 0.2, "hollow") == _fogged_rows(tmp_path, MESH, 0.2, "hollow") == [True] * 4


# A camera frame whose lower rays start below a solid ground plane, under fog.
GROUND = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
camera {{ location <0, 2, -10> angle 50 right x * image_width / image_height look_at <0, 2, 0> }}
light_source {{ <5, 10, -20> rgb 1 }}
background {{ rgb <0.3, 0.5, 1> }}
{fog}
plane {{ y, 0 pigment {{ checker rgb 1 rgb 0.2 }} {hollow} }}
sphere {{ <0, 2, 0>, 1.5 pigment {{ rgb <1, 0.2, 0.1> }} }}
"""
SMALL = ("--grid", "square", "--lenses", "16x12", "--ppl", "4x4", "--pixel-pitch", "0.25", "--focal", "2",
         "--quality", "draft", "-q")


@pytest.mark.povray
@pytest.mark.parametrize("fog, hollow, method, refused", [
    ("fog { rgb 0.8 distance 20 }", "", "multi-ortho", True),
    ("fog { rgb 0.8 distance 20 }", "", "multi-ortho-views", False),   # each ray its own state
    ("fog { rgb 0.8 distance 20 }", "hollow", "multi-ortho", False),   # fog inside the ground too
    ("", "", "multi-ortho", False),                                    # nothing depends on the state
])
def test_a_fogged_ground_below_the_rays_is_refused_or_rendered(cli, tmp_path, fog, hollow, method, refused):
    scene = tmp_path / "ground.pov"
    scene.write_text(GROUND.format(fog=fog, hollow=hollow))
    out = tmp_path / "g.png"
    result = cli("render", str(scene), "-o", str(out), *SMALL, "--method", method, "--depth-report")
    if refused:
        assert result.code != 0 and not out.exists()
        lines = [line for line in result.err.splitlines() if line.strip()]
        assert len(lines) == 1 and "inside a solid" in lines[0] and "hollow" in lines[0], result.err
    else:
        assert result.code == 0, result.err
        depth = json.loads(out.with_suffix(".json").read_text())["placement"]["depth"]
        assert np.isfinite(depth["near_mm"])


@pytest.mark.povray
@pytest.mark.parametrize("hollow, wrong", [("", True), ("hollow", False)])
def test_the_refused_frame_would_be_wrong(cli, tmp_path, monkeypatch, hollow, wrong):
    """Past the rule, multi-ortho's view of the fogged ground differs from POV-Ray's own orthographic
    render of that view (the gallery's oracle) where the ground is solid, and equals it where hollow."""
    from benchmarks.gallery import oracle_view
    from povh3d.image.metrics import psnr

    monkeypatch.setattr("povh3d.renderer.render.settle_method", lambda request, scene, *_: (request, None))
    scene = tmp_path / "ground.pov"
    scene.write_text(GROUND.format(fog="fog { rgb 0.8 distance 20 }", hollow=hollow))
    out, views = tmp_path / "g.png", tmp_path / "views"
    result = cli("render", str(scene), "-o", str(out), *SMALL, "--views-dir", str(views))
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    view = read_png(views / "v_003_000.png")[..., :3]     # the bottom-left view
    oracle = oracle_view(scene, record, (3, 0), view.shape[:2], timeout=120)[..., :3]
    assert (psnr(view, oracle) < 35) == wrong


# A grey wall whose face stands {gap} mm in front of the plane of the rays' origins (z = -1000 mm), and a
# slab that holds the origins of the field's left half.
NEAR_WALL = """#version 3.7;
global_settings {{ assumed_gamma 1 }}
light_source {{ <0, 0, -2000> rgb 1 }}
box {{ <-1000, -1000, {face}>, <1000, 1000, 0> pigment {{ rgb 0.5 }} }}
{slab}
"""


@pytest.mark.povray
@pytest.mark.parametrize("slab, share", [("", 0.0),
                                         ("box { <-1000, -1000, -1001>, <0, 1000, -999> pigment { rgb 0.5 } }", 0.5)])
def test_the_origins_pass_sees_where_a_ray_starts_only(tmp_path, slab, share):
    """The origins pass stops its rays at a black slab just in front of their plane, under a fog of that
    distance: a surface 1e-3 mm before the origins (which, under a fog as deep as the clearance, changed
    a pixel by less than a 16-bit level, so that the old pass counted every origin inside) leaves every
    origin outside; a solid that holds the left half's origins is measured as half (the control)."""
    from povh3d.renderer.methods.quality import RenderSettings
    from povh3d.renderer.passes.depth import origins_inside
    from povh3d.scene.scene import load_scene
    from tests.support.arrays import square_array

    scene = tmp_path / "wall.pov"
    scene.write_text(NEAR_WALL.format(face=-1000 + 1e-3, slab=slab))
    inside = origins_inside(load_scene(scene), square_array(lx=20, ly=16, nx=2, ny=2),
                            RenderSettings(quality="draft", use_cache=False), 1000.0, 1.0)
    assert inside == pytest.approx(share, abs=0.02)
