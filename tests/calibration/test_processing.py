"""Distortion, undistortion, viewpoints, equaliser and border correction against known captures."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from povh3d.calibration.borders import correct_borders
from povh3d.calibration.distortion import Brown, undistort_image
from povh3d.calibration.equalise import default_size, equalise
from povh3d.calibration.lattice import calibrate
from tests.support.synth import WhiteSpec, render_white
from povh3d.calibration.viewpoints import viewpoints
from povh3d.errors import ConfigError


@settings(max_examples=60, deadline=None)
@given(k1=st.floats(-0.08, 0.08), k2=st.floats(-0.03, 0.03), x=st.floats(-50, 690), y=st.floats(-50, 530))
def test_brown_undistort_inverts_distort(k1, k2, x, y):
    model = Brown.for_image(640, 480, k1, k2)
    p = np.array([x, y])
    # Strong barrel distortion folds back past some radius: a recorded point beyond the largest radius
    # the model reaches (outside the image: k1 = -0.0625, k2 = -0.03 at x = 690) has no ideal point.
    rho = np.linspace(0.0, 3.0, 30001)
    reached = rho * (1 + k1 * rho**2 + k2 * rho**4)
    fold = np.argmax(np.diff(reached) <= 0) or len(rho) - 1
    recorded = np.hypot(*(p - model.centre)) / model.scale
    assume(recorded < 0.999 * reached[fold])
    np.testing.assert_allclose(model.distort(model.undistort(p)), p, atol=1e-6)


def test_every_recorded_pixel_of_the_image_has_an_ideal_point():
    """The inverse above holds on the whole image for every coefficient the calibration accepts: the
    corners (rho = 1) are reached before the fold of the strongest barrel distortion."""
    rho = np.linspace(0.0, 3.0, 30001)
    reached = rho * (1 - 0.08 * rho**2 - 0.03 * rho**4)
    assert reached[np.argmax(np.diff(reached) <= 0)] > 1.0
    model = Brown.for_image(640, 480, -0.08, -0.03)
    corners = np.array([[0.0, 0.0], [639.0, 479.0], [0.0, 479.0], [639.0, 0.0]])
    np.testing.assert_allclose(model.distort(model.undistort(corners)), corners, atol=1e-6)
    # control: past the fold (the failing case hypothesis found) the round trip is far off
    outside = np.array([690.0, 530.0])
    assert np.abs(model.distort(model.undistort(outside)) - outside).max() > 1.0


@pytest.mark.slow
def test_undistort_makes_lattice_rows_straight():
    spec = WhiteSpec((320, 240), pitch_px=6.37, rotation_deg=0.3, k1=-0.05, vignetting=0.2, noise=0.005)
    white = render_white(spec)
    grid = calibrate(white)
    straight_before = calibrate(white, distortion=False)
    assert straight_before.residual_px > 0.2, "negative control: the distorted lattice is not straight"
    fixed = undistort_image(white, grid.distortion)
    after = calibrate(fixed[8:-8, 8:-8], distortion=False)  # corners lose their image
    assert after.residual_px < 0.2
    assert after.pitch_px == pytest.approx(spec.pitch_px, rel=1e-3)


def wave(centre, uv):
    """Scene seen by lens ``centre`` at in-lens position ``uv``: varies along both."""
    return 0.6 + 0.3 * np.sin(2 * np.pi * uv[..., 0]) * np.cos(2 * np.pi * uv[..., 1]) \
        + 0.05 * np.sin(centre[..., 0] / 17.0)


@pytest.mark.slow
@pytest.mark.parametrize("rotation, k1", [(0.0, 0.0), (9.46, 0.0), (6.34, -0.03)])
def test_viewpoints_sample_the_known_scene(rotation, k1):
    spec = WhiteSpec((300, 220), pitch_px=10.6, rotation_deg=rotation, k1=k1, profile="flat", level=1.0)
    grid = calibrate(render_white(spec))
    # The same lattice with borderless micro-images, so every sample sees the scene.
    capture = render_white(dataclasses.replace(spec, border_px=0.0, edge_px=0.0), content=wave)
    n = 8
    views = viewpoints(capture, grid, n)[..., 0]  # (N, N, rows, cols)
    t = (np.arange(n) + 0.5) / n - 0.5
    ideal = grid.ideal_centres()
    expect = wave(ideal[None, None], np.stack(np.broadcast_arrays(t[None, :, None, None], t[:, None, None, None]), -1))
    ok = grid.complete
    err = np.abs(views - expect)[:, :, ok]
    # bilinear sampling of a wave one micro-image long: a few percent at most
    assert np.percentile(err, 99) < 0.03
    # negative control: pixel (a, b) of the neighbouring view is clearly different
    assert np.percentile(np.abs(views[:, ::-1] - expect)[:, :, ok], 90) > 0.1


@pytest.mark.slow
def test_equaliser_default_size_follows_distortion():
    plain = calibrate(render_white(WhiteSpec((300, 220), pitch_px=10.6)))
    assert default_size(plain) == pytest.approx((10.6, 10.6), abs=0.01)
    barrel = calibrate(render_white(WhiteSpec((300, 220), pitch_px=10.6, k1=-0.05)))
    w, h = default_size(barrel)
    assert 10.0 < w < 10.55 and 10.0 < h < 10.55  # barrel shrinks micro-images away from the centre
    out, size = equalise(render_white(WhiteSpec((300, 220), pitch_px=10.6, k1=-0.05)), barrel)
    assert size == 10 or size == 11
    assert out.shape == (barrel.table[0] * size, barrel.table[1] * size)


def test_border_correction_recovers_the_scene():
    spec = WhiteSpec((300, 220), pitch_px=10.6, rotation_deg=6.34, profile="rounded", vignetting=0.3,
                     aperture=0.9, cos_power=4, focal_px=10)
    white = render_white(spec)
    grid = calibrate(white)
    capture = render_white(spec, content=wave)
    fixed, border = correct_borders(capture, grid, threshold=0.5)
    # The truth: the scene itself wherever the lens passes at least half its peak.
    yy, xx = np.mgrid[0:220, 0:300]
    i, j, centre = grid.lens_of_pixels(np.stack([xx, yy], -1).astype(float))
    d = np.stack([xx, yy], -1) - centre
    e1 = grid.a1 / np.linalg.norm(grid.a1)
    uv = np.stack([d @ e1, d @ np.array([-e1[1], e1[0]])], -1) / grid.pitch_px
    truth = wave(grid.distortion.undistort(centre), uv)
    inner = ~border
    inner[:12], inner[-12:], inner[:, :12], inner[:, -12:] = False, False, False, False
    err = np.abs(fixed - truth)[inner]
    # Pixels on the steep aperture edge mix response and scene within the pixel.
    assert np.median(err) < 0.01 and np.percentile(err, 90) < 0.04, np.percentile(err, [50, 90])
    assert np.abs(capture - truth)[inner].mean() > 0.1, "negative control: uncorrected is far off"
    assert 0.1 < border.mean() < 0.6
    assert not fixed[border].any()
    white_fixed, _ = correct_borders(white, grid)
    assert np.median(white_fixed[inner]) == pytest.approx(1.0, abs=0.02)


def test_bad_options():
    grid = calibrate(render_white(WhiteSpec((160, 120), pitch_px=8.0)))
    img = np.zeros((120, 160), np.float32)
    with pytest.raises(ConfigError):
        correct_borders(img, grid, threshold=1.5)
    with pytest.raises(ConfigError):
        viewpoints(img, grid, 0)


@pytest.mark.parametrize("scale, centre", [(1e308, (1.0, 1.0)), (float("inf"), (1.0, 1.0)), (0.0, (1.0, 1.0)),
                                           (60.0, (float("nan"), 1.0))])
def test_a_damaged_distortion_is_refused_on_construction(scale, centre):
    # Issue 25's fuzz: a grid file's scale_px of 1e308 overflowed scale**2 in undistort (an internal error).
    with pytest.raises(ConfigError, match="distortion (scale|centre)"):
        Brown(0.01, 0.0, centre, scale)
    image = np.ones((4, 4), np.float32)
    assert undistort_image(image, Brown(0.01, 0.0, (1.5, 1.5), 1e9)).shape == image.shape  # the largest accepted
