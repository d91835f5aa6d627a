"""Cropped renders (renderer/methods/cropped.py): POV-Ray gives identical pixels with and without the crop."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.renderer.shots.shots import ShotBatch, render_shots
from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.quality import Quality, RenderSettings
from povh3d.errors import InputError
from povh3d.geometry.crop import CropSettings
from povh3d.scene.scene import load_scene
from tests.support.arrays import lenticular_array, square_array
from tests.support.render import DRAFT

pytestmark = pytest.mark.povray  # every test here starts POV-Ray

SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.1, 0.2, 0.3> }
light_source { <-30, 40, -60> rgb 1 }
sphere { <0.4, 0.2, 0.6>, 0.9
  pigment { checker rgb <0.9, 0.3, 0.1> rgb <1, 0.9, 0.5> scale 0.37 translate 0.0123 }
  finish { specular 0.4 roughness 0.02 } }
box { <-1.3, -0.9, -0.8>, <-0.7, -0.3, -0.2> pigment { rgb <0.2, 0.8, 0.3> } }
"""
SCENE_BOX = ((-1.3, -0.9, -0.8), (1.3, 1.1, 1.5))


# Antialiasing: a sphere whose silhouette crosses POV-Ray's 32-pixel blocks (measured:
# 49 pixels change when the cuts ignore the blocks, 0 when they keep to them).
AA_SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.1, 0.2, 0.3> }
light_source { <-30, 40, -60> rgb 1 }
sphere { <1, 0.5, 1>, 2.5
  pigment { checker rgb <0.9,0.3,0.1> rgb <1,0.9,0.5> scale 0.37 }
  finish { specular 0.4 roughness 0.02 } }
"""
AA_BOX = ((-1.5, -2, -1.5), (3.5, 3, 3.5))
AA_ARRAY = square_array(lx=96, ly=64, nx=4, ny=4, s=0.1, f=2.0)


@pytest.fixture()
def aa_scene(tmp_path):
    path = tmp_path / "aa.pov"
    path.write_text(AA_SCENE)
    return load_scene(path)


@pytest.fixture()
def quarter_scene(tmp_path):
    path = tmp_path / "quarter.pov"
    path.write_text(SCENE)
    return load_scene(path)


ARRAYS = {"square": square_array(lx=40, ly=30, nx=4, ny=3, s=0.1, f=1.5),
          "lenticular": lenticular_array(lx=40, rows=60, nx=4, s=0.1, f=1.5)}


@pytest.mark.parametrize("grid", list(ARRAYS))
@pytest.mark.parametrize("mode", ["auto", "measure"])
def test_cropped_render_is_identical_point_sampled(quarter_scene, grid, mode):
    la = ARRAYS[grid]
    st_ = DRAFT
    full = run_method("multi-ortho", quarter_scene, la, st_)
    crop = run_method("multi-ortho", quarter_scene, la, st_, crop=CropSettings(mode, SCENE_BOX))
    assert crop.crop["applied"], crop.crop
    assert crop.crop["traced_fraction"] < 0.6
    assert np.array_equal(full.h3d, crop.h3d)
    # Negative control: the same crop without the paste's fill is not the full image.
    assert not np.array_equal(full.h3d, np.where(crop.h3d == full.h3d[0, 0], 0, crop.h3d))


@pytest.mark.parametrize("mode", ["auto", "measure"])
def test_cropped_render_is_identical_with_footprint_samples(quarter_scene, mode):
    # Footprint samples (quality high) trace one cropped bank per sample; the reach covers the
    # pixel's angular width too, so every sample that meets an object is traced.
    la = ARRAYS["square"]
    st_ = RenderSettings(quality=Quality(footprint=6, seed=3), use_cache=False)
    full = run_method("multi-ortho", quarter_scene, la, st_)
    crop = run_method("multi-ortho", quarter_scene, la, st_, crop=CropSettings(mode, SCENE_BOX))
    assert crop.crop["applied"] and crop.crop["traced_fraction"] < 0.7, crop.crop
    assert np.array_equal(full.h3d, crop.h3d)
    point = run_method("multi-ortho", quarter_scene, la, RenderSettings(quality="draft", use_cache=False))
    assert not np.array_equal(point.h3d, crop.h3d)   # the samples were traced, not the centre ray alone


def test_footprint_banks_split_over_frames_give_the_same_image(quarter_scene, monkeypatch):
    # Banks of footprint samples go to POV-Ray a few per frame (view_bank.bank_groups, the
    # template's #switch on frame_number); stacked back in order they are the one-frame render.
    import povh3d.geometry.view_bank as view_bank
    la = ARRAYS["square"]
    st_ = RenderSettings(quality=Quality(footprint=6, seed=3), use_cache=False)
    one = run_method("multi-ortho", quarter_scene, la, st_)
    monkeypatch.setattr(view_bank, "FRAME_SECONDS", 1e-12)     # frames cost nothing: one bank a frame
    three = run_method("multi-ortho", quarter_scene, la, st_)
    assert three.stats.shots == 6 and one.stats.shots == 1
    assert np.array_equal(one.h3d, three.h3d)


@pytest.mark.parametrize("quality", ["normal", Quality(antialias=0.3, aa_method=1, aa_depth=2)],
                         ids=["normal", "AM1"])
def test_cropped_render_is_identical_antialiased_without_jitter(aa_scene, quality):
    st_ = RenderSettings(quality=quality, use_cache=False)
    full = run_method("multi-ortho", aa_scene, AA_ARRAY, st_)
    crop = run_method("multi-ortho", aa_scene, AA_ARRAY, st_, crop=CropSettings("auto", AA_BOX))
    assert crop.crop["applied"] and crop.crop["traced_fraction"] < 0.3, crop.crop
    assert np.array_equal(full.h3d, crop.h3d)


def test_crop_refused_where_pixels_could_change(quarter_scene, tmp_path, monkeypatch):
    la = ARRAYS["square"]
    # POV-Ray's jitter depends on where a pixel sits in the image.
    jitter = Quality(antialias=0.3, jitter=True)
    jittered = run_method("multi-ortho", quarter_scene, la, RenderSettings(quality=jitter),
                          crop=CropSettings("auto", SCENE_BOX))
    assert not jittered.crop["applied"] and "jitter" in jittered.crop["reason"]
    # Fog: a ray that misses everything is not one colour.
    fog = tmp_path / "fog.pov"
    fog.write_text(SCENE + "fog { distance 5 rgb 0.5 }\n")
    r = run_method("multi-ortho", load_scene(fog), la, RenderSettings(quality="draft"),
                   crop=CropSettings("auto", SCENE_BOX))
    assert not r.crop["applied"] and "fog" in r.crop["reason"]
    # No box, auto: nothing to crop to.
    r = run_method("multi-ortho", quarter_scene, la, RenderSettings(quality="draft"), crop=CropSettings())
    assert not r.crop["applied"] and "bbox" in r.crop["reason"]


def test_too_small_bbox_is_refused(quarter_scene, tmp_path):
    out = tmp_path / "o.png"
    from tests.support.render import render
    with pytest.raises(InputError, match="outside bbox"):
        render(quarter_scene.path, ARRAYS["square"], out, settings=RenderSettings(quality="draft"),
               crop=CropSettings("auto", ((0.0, 0.0, 0.0), (0.3, 0.3, 0.3))))
    assert not out.exists()


def test_identical_frames_in_one_batch_are_traced_once(quarter_scene):
    la = square_array(lx=8, ly=6, nx=2, ny=2)
    from povh3d.geometry.cameras import ortho_view_shots
    common, frames = ortho_view_shots(la)
    w, h = common.pop("width"), common.pop("height")
    twice = [frames[0], frames[1], dict(frames[0])]
    batch = ShotBatch("multi_ortho_views.pov.j2", {**common, "front_clearance": 20.0}, twice, w, h)
    seen = []
    images, stats = render_shots(quarter_scene, batch, RenderSettings(quality="draft", use_cache=False),
                                  method="multi-ortho-views", header={"panel_size": (1, 1), "lens_pitch": 0.2,
                                                                      "focal": 1.5},
                                  progress=lambda d, t: seen.append((d, t)))
    assert len(images) == 3 and stats.jobs == 2
    assert np.array_equal(images[0], images[2]) and not np.array_equal(images[0], images[1])
    assert seen[-1] == (3, 3)


def test_without_block_alignment_antialiased_pixels_change(aa_scene, monkeypatch):
    """Negative control for the block rule of plan_crop: cuts off POV-Ray's block grid change pixels."""
    import povh3d.renderer.methods.cropped as crop_render
    monkeypatch.setattr(crop_render, "layout_independent", lambda options: (True, None))
    # Non-recursive antialiasing (+AM1) compares a pixel with its neighbours in the block.
    st_ = RenderSettings(quality=Quality(antialias=0.3, aa_method=1, aa_depth=2), use_cache=False)
    full = run_method("multi-ortho", aa_scene, AA_ARRAY, st_)
    crop = run_method("multi-ortho", aa_scene, AA_ARRAY, st_, crop=CropSettings("auto", AA_BOX))
    assert crop.crop["applied"]
    assert not np.array_equal(full.h3d, crop.h3d)
