"""Crop: what each view can reach, the plan, the paste, and identical pixels from POV-Ray."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.geometry.cameras import cropped_view_bank_mesh, default_back_off, view_bank_mesh
from povh3d.geometry.crop import (CropPlan, CropSettings, bbox_hits, cut_mask, fill_colour, full_plan,
    layout_independent, mask_hits, parse_bbox, paste, plan_crop)
from povh3d.errors import ConfigError, InputError
from povh3d.geometry.footprint import latin_hypercube
from povh3d.geometry.lens_array import pixel_rays
from povh3d.image.interleave import extract, interleave, untile_views
from povh3d.engine.methods import run_method
from povh3d.engine.frames import FrameBatch, render_frames
from povh3d.engine.quality import Quality, RenderSettings
from povh3d.scene.scene import load_scene

from .conftest import lenticular_array, square_array

BOX = ((-1.2, -0.7, -1.0), (0.9, 0.8, 2.0))


def brute_force_hits(la, box, samples=9, angular=0):
    """Per view and lens: does any ray in the pixel's footprint (a grid over the lens, and with
    ``angular`` > 0 a grid of that many directions across the pixel's angular width) meet the box?"""
    lo, hi = np.asarray(box)
    centres, dirs, _ = pixel_rays(la)                 # (H, W, 2), (H, W, 3) per panel pixel
    views = extract(np.concatenate([centres, dirs], axis=-1), la.views)   # (Ny, Nx, Ly, Lx, 5)
    hit = np.zeros(views.shape[:4], bool)
    offs = np.linspace(-0.5, 0.5, samples)
    turns = np.linspace(-0.5, 0.5, angular) if angular else np.zeros(1)
    for ox, oy, du, dv in itertools.product(offs * la.pitch_x, offs * la.pitch_y, turns, turns):
        if True:  # keeps the slab test's indentation
            c = views[..., :2] + [ox, oy]
            # The footprint sample's direction (u + du*s, v + dv*s, f) (povh3d.footprint).
            d = views[..., 2:] / views[..., 4:5] * la.focal + [du * la.panel.pitch_x, dv * la.panel.pitch_y, 0.0]
            # slab test along z: t = z / d_z, point = c + d_xy * z / d_z
            z0 = np.maximum(lo[2], -1e9)
            t_lo = np.full(hit.shape, z0)
            t_hi = np.full(hit.shape, hi[2])
            for a in range(2):
                slope = d[..., a] / d[..., 2]
                with np.errstate(divide="ignore", invalid="ignore"):
                    z1 = np.where(slope != 0, (lo[a] - c[..., a]) / slope, -np.inf)
                    z2 = np.where(slope != 0, (hi[a] - c[..., a]) / slope, np.inf)
                inside = (c[..., a] >= lo[a]) & (c[..., a] <= hi[a])
                zmin = np.where(slope != 0, np.minimum(z1, z2), np.where(inside, -np.inf, np.inf))
                zmax = np.where(slope != 0, np.maximum(z1, z2), np.where(inside, np.inf, -np.inf))
                t_lo, t_hi = np.maximum(t_lo, zmin), np.minimum(t_hi, zmax)
            hit |= t_lo <= t_hi
    return hit


@pytest.mark.parametrize("la", [square_array(lx=20, ly=14, nx=4, ny=3), lenticular_array(lx=20, rows=30, nx=5)],
                         ids=["square", "lenticular"])
def test_bbox_hits_contain_every_ray_that_meets_the_box(la):
    col, row = bbox_hits(la, BOX)
    truth = brute_force_hits(la, BOX)                     # (Ny, Nx, Ly, Lx)
    predicted = row[:, None, :, None] & col[None, :, None, :]
    assert truth.any() and not truth.all()
    assert not np.any(truth & ~predicted), "a lens that meets the box was cropped"
    # ... and it is tight: every predicted lens column/row is within one lens of a true hit.
    true_col = truth.any(axis=(0, 2))
    true_row = truth.any(axis=(1, 3))
    for pred, true in ((col, true_col), (row, true_row)):
        grown = true | np.roll(true, 1, axis=1) | np.roll(true, -1, axis=1)
        assert not np.any(pred & ~grown)


@pytest.mark.parametrize("la", [square_array(lx=20, ly=14, nx=4, ny=3, s=0.1, f=0.5),
                                lenticular_array(lx=20, rows=30, nx=5, s=0.1, f=0.5)],
                         ids=["square", "lenticular"])
def test_angular_bbox_hits_contain_every_footprint_ray(la):
    # Footprint samples also turn the ray across the pixel's angular width; with a short focal
    # length that reaches lenses the aperture-only reach misses, which the angular reach keeps.
    box = ((-1.17, -0.713, -1.0), (0.93, 0.787, 2.03))   # off round numbers: no ray grazes an edge
    truth = brute_force_hits(la, box, samples=5, angular=5)
    col, row = bbox_hits(la, box, angular=True)
    assert not np.any(truth & ~(row[:, None, :, None] & col[None, :, None, :]))
    col0, row0 = bbox_hits(la, box)
    assert np.any(truth & ~(row0[:, None, :, None] & col0[None, :, None, :])), "negative control"


def test_bbox_hits_shift_with_view_direction_like_parallax():
    la = square_array(lx=40, ly=10, nx=6, ny=2)
    col, _ = bbox_hits(la, ((-0.1, -0.1, 3.0), (0.1, 0.1, 3.0)))   # a point 3 mm behind the screen
    centre = np.array([np.flatnonzero(c).mean() for c in col])
    # Behind the screen, a view looking to the right (u > 0) reaches it through lenses on the left.
    u, _ = la.view_offsets()
    expected = -3.0 * u / la.focal / la.pitch_x
    assert np.allclose(centre - centre.mean(), expected - expected.mean(), atol=0.5)


def test_infinite_and_bad_boxes():
    la = square_array()
    col, row = bbox_hits(la, ((-np.inf, -np.inf, 5.0), (np.inf, np.inf, np.inf)))  # a back wall
    assert col.all() and row.all()
    with pytest.raises(ConfigError, match="xmin <= xmax"):
        bbox_hits(la, ((1, 0, 0), (0, 1, 1)))
    with pytest.raises(ConfigError, match="6 numbers"):
        parse_bbox("1,2,3")
    assert parse_bbox("-1,-2,-3,1,2,inf") == ((-1.0, -2.0, -3.0), (1.0, 2.0, float("inf")))
    with pytest.raises(ConfigError, match="--crop"):
        CropSettings("sometimes")


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 5), st.integers(3, 30), st.integers(0, 2**32 - 1), st.sampled_from([None, 4, 8]))
def test_plan_keeps_hits_with_margin_and_block_aligned_cuts(views, lenses, seed, block):
    rng = np.random.default_rng(seed)
    hits = rng.random((views, lenses)) < rng.choice([0.0, 0.02, 0.1, 0.5])
    plan = plan_crop(hits, hits, margin=2, block=block)
    keep = plan.keep_cols
    flat = hits.reshape(-1)
    if flat.any():
        # every hit and its 2 neighbours each side (across view borders) is kept
        for d in range(-2, 3):
            idx = np.flatnonzero(flat) + d
            idx = idx[(idx >= 0) & (idx < len(flat))]
            assert keep[idx].all()
    # next to every cut, 2 kept lenses without a hit
    beside = np.flatnonzero(cut_mask(plan)[0])
    kept_index = np.flatnonzero(keep)
    for c in kept_index[beside]:
        left, right = c - 1 >= 0 and not keep[c - 1], c + 1 < len(keep) and not keep[c + 1]
        inward = c + 1 if left else c - 1
        assert not flat[c] and (not (0 <= inward < len(flat)) or not flat[inward] or (left and right))
    if block:
        removed = np.diff(np.concatenate([[0], (~keep).astype(int), [0]]))
        starts, stops = np.flatnonzero(removed == 1), np.flatnonzero(removed == -1)
        assert np.all((stops - starts) % block == 0)


def test_plan_of_nothing_keeps_a_corner_for_the_colour():
    plan = plan_crop(np.zeros((3, 10), bool), np.zeros((2, 8), bool))
    assert plan.size == (3, 3) and not plan.is_full
    assert cut_mask(plan)[0].any()


def test_paste_is_the_inverse_of_cropping():
    rng = np.random.default_rng(1)
    plan = plan_crop(rng.random((3, 12)) < 0.1, rng.random((2, 9)) < 0.1)
    fill = np.array([7, 8, 9], np.uint8)
    full = np.broadcast_to(fill, (18, 36, 3)).copy()
    keep = np.ix_(plan.keep_rows, plan.keep_cols)
    full[keep] = rng.integers(0, 255, full[keep].shape, dtype=np.uint8)
    cropped = full[keep]
    cropped[cut_mask(plan)[1], :] = fill          # cut pixels are background
    cropped[:, cut_mask(plan)[0]] = fill
    full[keep] = cropped
    assert np.array_equal(paste(cropped, plan, fill_colour(cropped, plan)), full)
    cropped[0, np.flatnonzero(cut_mask(plan)[0])[0]] = [1, 2, 3]  # an object at a cut: no fill colour
    assert fill_colour(cropped, plan) is None


@pytest.mark.parametrize("samples", [None, latin_hypercube(3, seed=4)], ids=["centre", "footprint"])
def test_cropped_mesh_rays_match_the_uncropped_mesh(samples):
    """Every kept pixel of the cropped mesh interpolates the same ray as the uncropped mesh, in every bank."""
    la = square_array(lx=12, ly=9, nx=3, ny=2)
    back = default_back_off(la)
    plan = plan_crop(*bbox_hits(la, ((-0.3, -0.3, -0.5), (0.2, 0.4, 0.5)), angular=samples is not None))
    full, crop = view_bank_mesh(la, back, samples), cropped_view_bank_mesh(la, back, plan, samples)
    banks = 1 if samples is None else len(samples)
    assert len(crop.faces) < len(full.faces) * 4
    assert crop.image_size == (plan.size[0] + 1, banks * plan.size[1] + 1)

    def rays(mesh, cols, rows):
        # Barycentric interpolation at each pixel centre's UV, the lookup rule of cameras.CameraMesh.
        w, h = mesh.image_size
        uv = np.stack([(cols + 0.0) / w, 1.0 - (rows + 1.0) / h], -1)
        out = np.full((len(uv), 6), np.nan)
        for a, b, c in mesh.faces:
            t = np.linalg.solve(np.array([mesh.uvs[b] - mesh.uvs[a], mesh.uvs[c] - mesh.uvs[a]]).T,
                                (uv - mesh.uvs[a]).T).T
            inside = (t >= -1e-12).all(1) & (t.sum(1) <= 1 + 1e-12)
            wts = np.column_stack([1 - t.sum(1), t])
            p = wts @ np.array([mesh.vertices[a], mesh.vertices[b], mesh.vertices[c]])
            n = wts @ np.array([mesh.normals[a], mesh.normals[b], mesh.normals[c]])
            out[inside] = np.column_stack([p, n])[inside]
        return out

    for b in range(banks):
        r, c = np.meshgrid(np.flatnonzero(plan.keep_rows), np.flatnonzero(plan.keep_cols), indexing="ij")
        rc, cc = np.meshgrid(np.arange(plan.size[1]), np.arange(plan.size[0]), indexing="ij")
        got = rays(crop, cc.ravel(), rc.ravel() + b * plan.size[1])
        want = rays(full, c.ravel(), r.ravel() + b * plan.full_size[1])
        assert not np.isnan(want).any() and np.allclose(got, want, atol=1e-9), b


def test_layout_independence_of_switches():
    assert layout_independent(("-A",)) == (True, None)
    assert layout_independent(("+A0.3", "+AM1", "+R2")) == (False, 32)      # POV-Ray jitters by default
    assert layout_independent(("+A0.3", "+AM2", "+R3", "-J")) == (True, 32)
    assert layout_independent(("+A0.3", "-J", "+BS16")) == (True, 16)
    assert layout_independent(("+A0.3", "-A")) == (True, None)


# -- POV-Ray: identical pixels ----------------------------------------------------------------

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
    st_ = RenderSettings(quality="draft", use_cache=False)
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
    # Banks of footprint samples go to POV-Ray a few per frame (cameras.bank_groups, the
    # template's #switch on frame_number); stacked back in order they are the one-frame render.
    import povh3d.geometry.cameras as cameras
    la = ARRAYS["square"]
    st_ = RenderSettings(quality=Quality(footprint=6, seed=3), use_cache=False)
    one = run_method("multi-ortho", quarter_scene, la, st_)
    monkeypatch.setattr(cameras, "FRAME_SECONDS", 1e-12)     # frames cost nothing: one bank a frame
    three = run_method("multi-ortho", quarter_scene, la, st_)
    assert three.stats.frames == 6 and one.stats.frames == 1
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
    assert not r.crop["applied"] and "--bbox" in r.crop["reason"]


def test_too_small_bbox_is_refused(quarter_scene, tmp_path):
    out = tmp_path / "o.png"
    from tests.support.render import render
    with pytest.raises(InputError, match="outside --bbox"):
        render(quarter_scene.path, ARRAYS["square"], out, settings=RenderSettings(quality="draft"),
               crop=CropSettings("auto", ((0.0, 0.0, 0.0), (0.3, 0.3, 0.3))))
    assert not out.exists()


def test_lenticular_bank_has_one_view_row():
    la = lenticular_array(lx=10, rows=24, nx=6)
    mesh = view_bank_mesh(la, default_back_off(la))
    assert la.views == (1, 6)
    assert mesh.image_size == (10 * 6 + 1, 24 + 1)   # one view row: panel rows, not rows x views
    assert np.all(mesh.normals[:, 1] == 0)            # no vertical view direction


def test_identical_frames_in_one_batch_are_traced_once(quarter_scene):
    la = square_array(lx=8, ly=6, nx=2, ny=2)
    from povh3d.geometry.cameras import ortho_view_frames
    common, frames = ortho_view_frames(la)
    w, h = common.pop("width"), common.pop("height")
    twice = [frames[0], frames[1], dict(frames[0])]
    batch = FrameBatch("multi_ortho_views.pov.j2", {**common, "back_off": 20.0}, twice, w, h)
    seen = []
    images, stats = render_frames(quarter_scene, batch, RenderSettings(quality="draft", use_cache=False),
                                  method="multi-ortho-views", header={"panel_size": (1, 1), "lens_pitch": 0.2,
                                                                      "focal": 1.5},
                                  progress=lambda d, t: seen.append((d, t)))
    assert len(images) == 3 and stats.jobs == 2
    assert np.array_equal(images[0], images[2]) and not np.array_equal(images[0], images[1])
    assert seen[-1] == (3, 3)


def test_without_block_alignment_antialiased_pixels_change(aa_scene, monkeypatch):
    """Negative control for the block rule of plan_crop: cuts off POV-Ray's block grid change pixels."""
    import povh3d.engine.cropped as crop_render
    monkeypatch.setattr(crop_render, "layout_independent", lambda options: (True, None))
    # Non-recursive antialiasing (+AM1) compares a pixel with its neighbours in the block.
    st_ = RenderSettings(quality=Quality(antialias=0.3, aa_method=1, aa_depth=2), use_cache=False)
    full = run_method("multi-ortho", aa_scene, AA_ARRAY, st_)
    crop = run_method("multi-ortho", aa_scene, AA_ARRAY, st_, crop=CropSettings("auto", AA_BOX))
    assert crop.crop["applied"]
    assert not np.array_equal(full.h3d, crop.h3d)
