"""Lens-grid calibration against synthetic white images with exactly known lens centres.

Targets (issue 6): lens-centre RMS error <= 0.02 px, rotation within 0.01 deg,
pitch within 0.01 %, for square and hex lattices, rotations 0 to 9.46 deg,
rounded and flat-topped micro-images, vignetting, noise, with and without
barrel distortion.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from povh3d.calibration.gridfile import Grid, read_grid, write_grid
from povh3d.calibration.lattice import calibrate
from tests.support.synth import WhiteSpec, render_white, to_uint, true_centres
from povh3d.errors import InputError

ROTATIONS = [0.0, 0.1, 0.3, 6.34, 9.46]


def centre_errors(grid: Grid, spec: WhiteSpec) -> np.ndarray:
    """Distance of every reported lens centre to the true one; every true lens must be reported.

    Lenses within 0.05 px of the image edge may fall either side of it.
    """
    got = grid.centres[grid.inside]
    dist, _ = cKDTree(true_centres(spec, margin=-1.0)).query(got)
    back, _ = cKDTree(got).query(true_centres(spec, margin=0.05))
    assert back.max() < 0.5, "a lens is missing"
    assert dist.max() < 0.5, "a lens is invented"
    return dist


def wrapped(angle: float, period: float) -> float:
    return (angle + period / 2) % period - period / 2


def check(grid: Grid, spec: WhiteSpec) -> None:
    rms = float(np.sqrt(np.mean(centre_errors(grid, spec) ** 2)))
    assert grid.lattice == spec.lattice
    assert rms <= 0.02, f"lens-centre RMS error {rms:.4f} px"
    period = 90.0 if spec.lattice == "square" else 60.0
    assert abs(wrapped(grid.rotation_deg - spec.rotation_deg, period)) <= 0.01
    assert abs(grid.pitch_px / spec.pitch_px - 1) <= 1e-4
    assert grid.residual_px < 0.1 and grid.confidence > 0.8


@pytest.mark.slow
@pytest.mark.parametrize("barrel", [0.0, -0.03], ids=["straight", "barrel"])
@pytest.mark.parametrize("profile", ["rounded", "flat"])
@pytest.mark.parametrize("rotation", ROTATIONS)
@pytest.mark.parametrize("lattice", ["square", "hex"])
def test_lens_centres_pitch_rotation(lattice, rotation, profile, barrel):
    spec = WhiteSpec((320, 240), lattice=lattice, pitch_px=6.37, rotation_deg=rotation, profile=profile,
                     k1=barrel, vignetting=0.3, noise=0.01, border_px=1.0, seed=7)
    grid = calibrate(render_white(spec))
    check(grid, spec)
    if barrel:
        assert grid.distortion.k1 == pytest.approx(barrel, abs=1e-3)


def test_metric_catches_a_small_offset():
    """Negative control: the same check fails for a grid 0.05 px off."""
    spec = WhiteSpec((360, 270), pitch_px=7.37, rotation_deg=0.3)
    grid = calibrate(render_white(spec))
    check(grid, spec)
    moved = Grid(grid.lattice, grid.image_size, grid.basis, grid.origin + [0.05, 0.0], grid.table, grid.distortion)
    with pytest.raises(AssertionError):
        check(moved, spec)


@pytest.mark.slow
def test_large_pitch_and_sixteen_bit_camera_file():
    spec = WhiteSpec((640, 480), pitch_px=23.7, rotation_deg=-2.0, profile="flat", vignetting=0.4, noise=0.02)
    check(calibrate(to_uint(render_white(spec), 16)), spec)


def test_grid_file_round_trip(tmp_path):
    spec = WhiteSpec((240, 180), lattice="hex", pitch_px=8.3, rotation_deg=6.34, k1=-0.02)
    grid = calibrate(render_white(spec))
    write_grid(tmp_path / "grid.json", grid)
    again = read_grid(tmp_path / "grid.json")
    np.testing.assert_allclose(again.centres, grid.centres, atol=1e-9)
    record = grid.as_record()
    for key in ("lattice", "pitch_px", "rotation_deg", "centers_px", "residual_px", "confidence"):
        assert key in record
    assert np.asarray(record["centers_px"]).shape == (int(grid.inside.sum()), 2)


def test_hex_table_follows_conventions():
    """Odd rows sit half a pitch right of even rows; lens (i, j) has 6 neighbours at one pitch."""
    spec = WhiteSpec((240, 180), lattice="hex", pitch_px=9.0)
    grid = calibrate(render_white(spec))
    c = grid.centres
    np.testing.assert_allclose(c[1, 0, 0] - c[0, 0, 0], 4.5, atol=0.01)
    np.testing.assert_allclose(c[0, 1] - c[0, 0], [9.0, 0.0], atol=0.01)


@pytest.mark.parametrize("image, message", [
    (np.full((200, 300), 0.8, np.float32) + np.random.default_rng(1).normal(0, 0.02, (200, 300)).astype(np.float32),
     "no lens lattice"),
    (np.full((10, 10), 0.8, np.float32), "too small"),
    (np.tile((np.arange(300) % 9 < 6).astype(np.float32), (200, 1)), "one direction"),
])
def test_bad_white_images(image, message):
    with pytest.raises(InputError, match=message):
        calibrate(image)


def test_image_too_small_for_two_lenses():
    spec = WhiteSpec((30, 30), pitch_px=20.0)
    with pytest.raises(InputError, match="too small|no lens lattice"):
        calibrate(render_white(spec))


def test_grid_that_does_not_match_the_image():
    spec = WhiteSpec((240, 180), pitch_px=8.3)
    grid = calibrate(render_white(spec))
    with pytest.raises(InputError, match="240x180"):
        grid.check_image((100, 100, 3))
