"""Exact subpixel rendering of slanted lenticular panels (``--method subpixel``).

- Without POV-Ray: POV-Ray's mesh-camera lookup simulated in NumPy traces, for
  every R, G and B subpixel, the ray docs/geometry.md gives it under the turned
  sheet (through its lenticule's axis, square to it), to 1e-9.
- With POV-Ray: an emissive plane whose red and green code x and y; the position
  every subpixel's ray hits, decoded from a linear 16-bit render, lies within
  0.002 mm of the oracle's.  The view-then-map assignment (the nearest of N
  directions) misses it by far more: the control.
- The panel image takes channel c of subpixel c.
- Both cameras: a sheet of no short period (one strip per lenticule) and the
  Philips sheet, rational (one quad per phase coset, ``geometry.phase_tiles``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from povh3d.renderer.methods.registry import METHODS, run_method
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.display.subpixel import subpixel_array, subpixel_image, subpixels_to_panel
from povh3d.errors import ConfigError, Povh3dWarning
from povh3d.geometry.footprint import latin_hypercube
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.phase_tiles import phase_tiles
from povh3d.geometry.rays import pixel_rays
from povh3d.image.colour import decode
from povh3d.scene.scene import load_scene

from tests.geometry.test_rotated_lattice import simulate_lookup
from tests.renderer.test_single_stage import decode_positions, render_linear16, write_position_plane
from tests.support.scenes import write_checker_plane

# A slanted sheet: 4.5 px (13.5 subpixels) per lenticule at 9.46 deg, like the Philips panel.
SHEET = LensArray("lenticular", 30, 48, 0.45, 0.1, 1.2, Panel(120, 48, 0.1, 0.1), 9.46)
# The Philips sheet exactly: 4.5 subpixels along a row, tan a = 1/6 (9 x 9 phase cosets).
_TURN = math.atan(1 / 6)
PHILIPS = LensArray("lenticular", 101, 48, 0.15 * math.cos(_TURN), 0.1, 1.2, Panel(120, 48, 0.1, 0.1),
                    math.degrees(_TURN))
SHEETS = pytest.mark.parametrize("sheet", [SHEET, PHILIPS], ids=["strips", "tiles"])


def test_subpixel_array_is_the_sheet_over_subpixels():
    sub = subpixel_array(SHEET)
    assert (sub.panel.width, sub.panel.height) == (360, 48)
    assert sub.panel.pitch_x == pytest.approx(0.1 / 3) and sub.rotation == 9.46
    X, _ = sub.panel.pixel_centres()
    Xp, _ = SHEET.panel.pixel_centres()
    # Subpixel c of pixel col sits (c - 1) s/3 from the pixel centre: R, G, B left to right.
    np.testing.assert_allclose(X.reshape(-1, 3) - Xp[:, None], np.broadcast_to(np.array([-1, 0, 1]) * 0.1 / 3, (120, 3)), atol=1e-12)
    with pytest.raises(ConfigError, match="lenticular"):
        subpixel_array(LensArray("square", 10, 8, 0.6, 0.6, 1.5, Panel(60, 48, 0.1, 0.1)))


def test_panel_takes_channel_c_of_subpixel_c():
    rng = np.random.default_rng(0)
    image = rng.integers(0, 255, (4, 15, 3), dtype=np.uint8)
    panel = subpixels_to_panel(image)
    assert panel.shape == (4, 5, 3)
    for c in range(3):
        np.testing.assert_array_equal(panel[..., c], image[:, c::3, c])


def _camera(sheet: LensArray, front_clearance: float):
    """The method's own mesh camera and its phase tiles (None: strips)."""
    plan = METHODS["subpixel"].plan(sheet, front_clearance, np.zeros((1, 4)))
    return plan.batch.context["mesh"], phase_tiles(subpixel_array(sheet))


@SHEETS
def test_every_subpixel_ray_in_numpy(sheet):
    sub = subpixel_array(sheet)
    mesh, tiles = _camera(sheet, 10.0)
    assert (tiles is None) == (sheet is SHEET)
    origin, normal, found = (subpixel_image(mesh, tiles, [a]) for a in simulate_lookup(mesh))
    centres, dirs, inside = pixel_rays(sub)
    assert inside.all() and np.all(found > -1e-9)
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    np.testing.assert_allclose(d, dirs, atol=1e-9)
    t = -origin[..., 2] / d[..., 2]
    np.testing.assert_allclose(origin[..., :2] + t[..., None] * d[..., :2], centres, atol=1e-9)
    # Each subpixel has its own direction: R, G and B of a pixel differ (not one view per pixel).
    assert np.all(np.abs(np.diff(dirs[..., 0].reshape(48, 120, 3), axis=-1)) > 1e-3)


def _subpixel_hits(tmp_path, la: LensArray, z0: float, half: float) -> np.ndarray:
    """Render the raw subpixel image of a position-coded plane (linear, 16 bit): hit (x, y) mm."""
    plan = METHODS["subpixel"].plan(la, 10.0, np.zeros((1, 4)))
    mesh, tiles = _camera(la, 10.0)
    scene = write_position_plane(tmp_path, z0, half)
    out = render_linear16(plan.batch, "subpixel", scene, la)
    return decode_positions(subpixel_image(mesh, tiles, out), half)


@pytest.mark.povray
@SHEETS
@pytest.mark.parametrize("z0", [4.0, -4.0], ids=["behind", "in-front"])
def test_every_subpixel_ray_in_povray(tmp_path, z0, sheet):
    half = 12.0  # code +-12 mm: 16-bit steps of 3.7e-4 mm
    hits = _subpixel_hits(tmp_path, sheet, z0, half)
    centres, dirs, inside = pixel_rays(subpixel_array(sheet))
    expected = centres + dirs[..., :2] * (z0 / dirs[..., 2])[..., None]
    err = np.abs(hits - expected).max()
    assert err < 0.002, f"worst subpixel hit {err:.4f} mm off"
    # Control: one ray per pixel (R and B take the green subpixel's) misses by far more.
    h, w3 = expected.shape[:2]
    per_pixel = np.repeat(expected.reshape(h, w3 // 3, 3, 2)[:, :, 1:2], 3, axis=2).reshape(h, w3, 2)
    assert np.abs(hits - per_pixel).max() > 20 * err
    if sheet is PHILIPS:
        return  # its 9 phases are the 9 view directions: only the view positions differ
    # Control: the view-then-map route gives every subpixel the nearest of 9 view directions.
    views = 9
    u = _across(sheet, subpixel_array(sheet))
    step = sheet.pitch_x / views
    snapped = (np.floor(u / step) + 0.5) * step
    t = math.radians(sheet.rotation)
    shift = (snapped - u) * z0 / sheet.focal
    mapped = expected + np.stack([shift * math.cos(t), shift * math.sin(t)], axis=-1)
    assert np.abs(hits - mapped).max() > 20 * err


def _across(sheet: LensArray, sub: LensArray) -> np.ndarray:
    """Every subpixel's offset across its lenticule (mm)."""
    centres, _, _ = pixel_rays(sub)
    X, Y = np.meshgrid(*sub.panel.pixel_centres())
    t = math.radians(sheet.rotation)
    return (X - centres[..., 0]) * math.cos(t) + (Y - centres[..., 1]) * math.sin(t)


@pytest.mark.povray
def test_subpixel_render_writes_the_panel(tmp_path):
    scene = load_scene(write_checker_plane(tmp_path, 5.0, 2.0))
    result = run_method("subpixel", scene, SHEET, RenderSettings(quality="draft", use_cache=False))
    assert result.h3d.shape == (48, 120, 3)
    assert result.record["subpixel_panel_px"] == [360, 48]


@pytest.mark.povray
def test_antialiased_render_averages_footprint_samples(tmp_path):
    """``--quality normal`` on a rational sheet: 3 x 3 footprint samples a subpixel (aperture and
    area), one frame each, averaged in linear light.  On a plane coding x and y linearly the
    average shows the mean of the samples' hits, each from the footprint's definition."""
    z0, half = 4.0, 12.0
    scene = load_scene(write_position_plane(tmp_path, z0, half))
    result = run_method("subpixel", scene, PHILIPS, RenderSettings(quality="normal", use_cache=False, bit_depth=16))
    assert result.record["footprint_samples"] == 9 and result.stats.shots == 9
    coded = decode(result.h3d) * 2 * half - half                        # (H, W, 3): R codes x, G codes y
    sub = subpixel_array(PHILIPS)
    X, Y = np.meshgrid(*sub.panel.pixel_centres())
    hits = np.zeros(X.shape + (2,))
    for ax, ay, du, dv in latin_hypercube(9):
        qx, qy = sub.to_lattice(X + du * sub.panel.pitch_x, Y + dv * sub.panel.pitch_y)
        _, yc = sub.to_lattice(X, Y)
        c = (np.floor(qx / sub.pitch_x + sub.lenses_x / 2 + 1e-9) + 0.5 - sub.lenses_x / 2) * sub.pitch_x
        px, py = sub.from_lattice(c + ax * sub.pitch_x, yc + ay * sub.pitch_y)   # the aperture point
        dx, dy = sub.from_lattice(qx - c, qy - yc)                              # the direction, over f
        hits += np.stack([px + dx * z0 / sub.focal, py + dy * z0 / sub.focal], axis=-1) / 9
    err = max(np.abs(coded[..., 0] - hits[:, 0::3, 0]).max(), np.abs(coded[..., 1] - hits[:, 1::3, 1]).max())
    assert err < 0.01, f"worst subpixel {err:.4f} mm off"
    # Control: the point-sampled rays (the footprint's centre) miss the average.
    centres, dirs, _ = pixel_rays(sub)
    point = centres + dirs[..., :2] * (z0 / dirs[..., 2])[..., None]
    assert np.abs(coded[..., 0] - point[:, 0::3, 0]).max() > 5 * err


@pytest.mark.povray
def test_strips_cannot_antialias_and_say_so(tmp_path):
    scene = load_scene(write_checker_plane(tmp_path, 5.0, 2.0))
    with pytest.warns(Povh3dWarning, match="point-sampled"):
        result = run_method("subpixel", scene, SHEET, RenderSettings(quality="normal", use_cache=False))
    assert result.record["footprint_samples"] == 1 and result.record["camera"] == "one strip per lenticule"
