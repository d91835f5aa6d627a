"""One photon map for every view of a still (``renderer.shots.lighting``, ``scene.rewrite.photon_map_hook``).

The oracle is POV-Ray itself, to the bit: a render that loads a photon map is the render that shot it
(measured on ``lights/phot_met_glass.pov``), and at one thread POV-Ray shoots the same map every time
(at two, the photons' order and count vary from run to run).  The saving run shoots at one thread, so
every view must equal its independent render at one thread; POV-Ray's statistics show that the loading
runs shot no photon.  Negative control: a coarser photon ``spacing`` changes the views, so the equality
is no accident of photons the image does not show.
"""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.renderer.methods.quality import RenderSettings
from povh3d.renderer.methods.registry import METHODS, display_header
from povh3d.renderer.shots.lighting import shared_lighting
from povh3d.renderer.shots.shots import render_shots
from povh3d.scene.rewrite import photon_map_hook
from povh3d.scene.scene import load_scene
from tests.support.arrays import square_array

# Two glass balls over a white floor, lit by two lights: the balls focus photons into caustics on the
# floor.  (With two lights POV-Ray's threads shoot another map than one thread does; with one, the same.)
GLASS = """#version 3.7;
global_settings {{ assumed_gamma 1 max_trace_level 8 photons {{ spacing {spacing} }} }}
plane {{ z, 6 pigment {{ rgb 1 }} finish {{ ambient 0 diffuse 0.8 }} }}
sphere {{ <-2, 0, 2>, 2 pigment {{ rgbf <0.9, 1, 0.9, 0.95> }} finish {{ ambient 0 diffuse 0 }}
  interior {{ ior 1.5 }} photons {{ target refraction on reflection off }} }}
sphere {{ <2.5, 1, 2>, 1.5 pigment {{ rgbf <1, 0.9, 0.9, 0.95> }} finish {{ ambient 0 diffuse 0 }}
  interior {{ ior 1.5 }} photons {{ target refraction on reflection off }} }}
light_source {{ <8, 10, -20> rgb 1 photons {{ refraction on }} }}
light_source {{ <-8, 6, -20> rgb 0.8 photons {{ refraction on }} }}
"""
LA = square_array(lx=24, ly=18, nx=4, ny=4)      # 16 views of 24 x 18 pixels
CLEARANCE = 30.0
CENTRE = 2 * 4 + 2


def _scene(folder, spacing: float, name: str):
    path = folder / name
    path.write_text(GLASS.format(spacing=spacing))
    return load_scene(path)


def _render(scene, **settings):
    plan = METHODS["multi-ortho-views"].plan(LA, CLEARANCE, np.zeros((1, 4)))
    return render_shots(scene, plan.batch, RenderSettings(quality="draft", **{"use_cache": False, **settings}),
                        method="multi-ortho-views", header=display_header(LA))


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    folder = tmp_path_factory.mktemp("glass")
    fine, coarse = _scene(folder, 0.02, "fine.pov"), _scene(folder, 0.3, "coarse.pov")
    shared, stats = _render(fine)
    independent, independent_stats = _render(fine, shared_lighting=False, threads=1)
    other_map, _ = _render(coarse, shared_lighting=False, threads=1)
    return dict(shared=shared, stats=stats, independent=independent, independent_stats=independent_stats,
                other_map=other_map)


@pytest.mark.povray
def test_every_view_is_its_independent_render(renders):
    """Each view equals its independent render to the bit, and the sidecar says the map was shot once,
    by the centre view's run."""
    assert all(np.array_equal(a, b) for a, b in zip(renders["shared"], renders["independent"]))
    lighting = renders["stats"].lighting
    assert lighting["photons"] == "shot once, loaded by the other shots" and "radiosity" not in lighting
    assert lighting["saving_shots"] == [CENTRE] and lighting["loading_shots"] == 15


@pytest.mark.povray
def test_the_loading_runs_load_rather_than_shoot(renders):
    """POV-Ray's statistics: the saving run shoots what an independent view does, the loading runs none."""
    lighting = renders["stats"].lighting
    assert lighting["photons_shot"] > 1000
    assert lighting["photons_shot_by_loading_shots"] == 0
    assert renders["independent_stats"].lighting is None


@pytest.mark.povray
def test_another_map_changes_the_views(renders):
    """Negative control: the coarser spacing's map shows (the caustics), so the equality above can fail."""
    worst = max(float(np.abs(a.astype(int) - b.astype(int)).max())
                for a, b in zip(renders["other_map"], renders["independent"]))
    assert worst > 10


def test_photon_statistics_are_read_from_the_log():
    from povh3d.povray.log import parse_photons
    shot = ("Number of photons shot:          101458\nSurface photons stored:          195007\n"
            "  Photon Time:      0 hours  0 minutes  0 seconds (0.070 seconds)\n")
    loaded = ("Photon Warning: Starting the load of photon file m.ph\n"
              "  Photon Time:      0 hours  0 minutes  0 seconds (0.023 seconds)\n")
    assert parse_photons(shot + loaded) == 101458 and parse_photons(loaded) == 0
    assert parse_photons("  Photon Time:      No photons\n") is None


def test_the_hook_goes_in_the_global_photons_block_only():
    text = ("global_settings { max_trace_level 5 photons { spacing 0.1 } }\n"
            "sphere { 0, 1 photons { target } }\n")
    hooked = photon_map_hook(text)
    assert hooked.count("Povh3d_Photon_Map") == 4      # #ifdef, file_exists, load_file, save_file
    assert hooked.index("Povh3d_Photon_Map") < hooked.index("spacing")
    assert hooked.endswith("sphere { 0, 1 photons { target } }\n")
    # under an #if, and in every global_settings block
    text = "global_settings { #if (1) photons { count 9 } #end }\nglobal_settings { photons { } }"
    assert photon_map_hook(text).count("#ifdef (Povh3d_Photon_Map)") == 2


def test_a_file_without_a_global_photons_block_is_not_tokenized(monkeypatch):
    """The scene's own mesh includes (often many MB) are passed over on their words alone."""
    import povh3d.scene.rewrite as rewrite

    def refuse(text):
        raise AssertionError("tokenized")

    monkeypatch.setattr(rewrite, "tokens", refuse)
    mesh = "mesh2 { vertex_vectors { 3, <0,0,0>, <1,0,0>, <0,1,0> } face_indices { 1, <0,1,2> } }\n"
    assert photon_map_hook(mesh) == mesh
    assert photon_map_hook("sphere { 0, 1 photons { target } }") == "sphere { 0, 1 photons { target } }"
    with pytest.raises(AssertionError, match="tokenized"):   # the control: a global block is read
        photon_map_hook("global_settings { photons { spacing 0.1 } }")


def test_a_scene_that_keeps_its_own_map_is_left_alone(tmp_path):
    for own in ('save_file "m.ph"', 'load_file "m.ph"'):
        text = f"global_settings {{ photons {{ spacing 0.1 {own} }} }}"
        assert photon_map_hook(text) == text
    assert photon_map_hook("global_settings { photons { spacing 0.1 }") == "global_settings { photons { spacing 0.1 }"
    # such a scene (or one with photons only on its objects) shares nothing unless it has radiosity
    from povh3d.renderer.shots.batch import ShotBatch
    batch = ShotBatch("x.pov.j2", {}, [{}, {}, {}], 4, 4, lighting_shots=(1, 0))
    kept = tmp_path / "kept.pov"
    kept.write_text('#version 3.7;\nglobal_settings { photons { spacing 0.1 save_file "m.ph" } }\n'
                    "sphere { 0, 1 pigment { rgb 1 } }\n")
    assert shared_lighting(load_scene(kept), batch, RenderSettings(quality="draft"), True) is None
    hooked = tmp_path / "hooked.pov"
    hooked.write_text(kept.read_text().replace(' save_file "m.ph"', ""))
    lighting = shared_lighting(load_scene(hooked), batch, RenderSettings(quality="draft"), True)
    assert lighting is not None and lighting.photons and not lighting.radiosity and lighting.savers == (1,)


@pytest.mark.povray
def test_an_error_names_the_users_file(tmp_path):
    """The runs render a copy of the scene; POV-Ray's error still names the user's file and folder."""
    from povh3d.errors import PovrayError

    scene = _scene(tmp_path, 0.02, "broken.pov")
    scene.path.write_text(scene.path.read_text() + 'sphere { 0, 1 pigment { rgb 1 } #error "broken on purpose" }\n')
    with pytest.raises(PovrayError) as caught:
        _render(load_scene(scene.path))
    assert "broken on purpose" in str(caught.value)
    assert str(tmp_path / "broken.pov") in str(caught.value) + caught.value.log_tail
    assert "lighting-" not in str(caught.value) + caught.value.log_tail


@pytest.mark.povray
def test_photons_and_radiosity_share_one_saving_run(tmp_path):
    """With radiosity too, the saving run (the centre and corner views) shoots the map in its first frame
    and loads it in the others, and the loading runs load both."""
    _, alone = _render(_scene(tmp_path, 0.02, "photons.pov"))   # a single frame shoots the map
    scene = _scene(tmp_path, 0.02, "lit.pov")
    scene.path.write_text(scene.path.read_text().replace(
        "max_trace_level 8", "max_trace_level 8 radiosity { count 20 pretrace_start 0.08 pretrace_end 0.04 }"))
    _, stats = _render(load_scene(scene.path))
    lighting = stats.lighting
    assert lighting["radiosity"] and lighting["photons"] and len(lighting["saving_shots"]) == 5
    assert lighting["photons_shot_by_loading_shots"] == 0
    # five frames, one map shot (at two threads POV-Ray's count varies a little from run to run)
    assert 0.8 < lighting["photons_shot"] / alone.lighting["photons_shot"] < 1.2
