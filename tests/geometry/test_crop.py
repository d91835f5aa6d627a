"""Crop planning without POV-Ray: what each view can reach, the plan, the paste, the cropped mesh."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.geometry.camera_mesh import default_front_clearance
from povh3d.geometry.crop import (CropSettings, bbox_hits, cut_mask, fill_colour, layout_independent,
    parse_bbox, paste, plan_crop)
from povh3d.geometry.footprint import latin_hypercube
from povh3d.geometry.rays import pixel_rays
from povh3d.image.interleave import extract
from tests.support.arrays import lenticular_array, square_array
from tests.support.oracles import cropped_view_bank_mesh, mesh_rays, view_bank_mesh

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
    with pytest.raises(ConfigError, match="crop"):
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
    back = default_front_clearance(la)
    plan = plan_crop(*bbox_hits(la, ((-0.3, -0.3, -0.5), (0.2, 0.4, 0.5)), angular=samples is not None))
    full, crop = view_bank_mesh(la, back, samples), cropped_view_bank_mesh(la, back, plan, samples)
    banks = 1 if samples is None else len(samples)
    assert len(crop.faces) < len(full.faces) * 4
    assert crop.image_size == (plan.size[0] + 1, banks * plan.size[1] + 1)

    for b in range(banks):
        r, c = np.meshgrid(np.flatnonzero(plan.keep_rows), np.flatnonzero(plan.keep_cols), indexing="ij")
        rc, cc = np.meshgrid(np.arange(plan.size[1]), np.arange(plan.size[0]), indexing="ij")
        got = mesh_rays(crop, cc.ravel(), rc.ravel() + b * plan.size[1])
        want = mesh_rays(full, c.ravel(), r.ravel() + b * plan.full_size[1])
        assert not np.isnan(want).any() and np.allclose(got, want, atol=1e-9), b


def test_layout_independence_of_switches():
    assert layout_independent(("-A",)) == (True, None)
    assert layout_independent(("+A0.3", "+AM1", "+R2")) == (False, 32)      # POV-Ray jitters by default
    assert layout_independent(("+A0.3", "+AM2", "+R3", "-J")) == (True, 32)
    assert layout_independent(("+A0.3", "-J", "+BS16")) == (True, 16)
    assert layout_independent(("+A0.3", "-A")) == (True, None)


def test_lenticular_bank_has_one_view_row():
    la = lenticular_array(lx=10, rows=24, nx=6)
    mesh = view_bank_mesh(la, default_front_clearance(la))
    assert la.views == (1, 6)
    assert mesh.image_size == (10 * 6 + 1, 24 + 1)   # one view row: panel rows, not rows x views
    assert np.all(mesh.normals[:, 1] == 0)            # no vertical view direction
