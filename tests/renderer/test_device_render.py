"""``povh3d render SCENE --preset looking-glass-portrait``: the device's views over its panel, its
quilt named the vendor's way at its quilt size, the native image through the vendor's shader; and
what the oblique orthographic views differ by from the vendor's off-axis perspective cameras."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from povh3d.display.quilt import quilt_array, quilt_views
from povh3d.display.looking_glass import DEVICES, visual_json
from povh3d.image.interleave import extract
from povh3d.image.io import read_png, read_sidecar
from povh3d.image.quilt import quilt_to_views
from tests.conftest import SAMPLES
from tests.display.mappings.test_looking_glass_shader import agreement
from tests.support.cli import one_error_line

PORTRAIT = DEVICES["looking-glass-portrait"]


@pytest.mark.parametrize("name", sorted(DEVICES))
def test_quilt_array_spans_the_cone_at_the_tile_size(name):
    d = DEVICES[name]
    views = quilt_views(d, None)   # the factory calibration's cone; the 27": the family's default
    cone = d.calibration.view_cone if d.calibration is not None else d.default_cone
    la = quilt_array(d, views)
    assert (la.lenses_x, la.lenses_y) == d.tile_size and la.views == (1, d.views)
    assert la.panel.size_mm == pytest.approx(d.nominal_size_mm, rel=1e-12)
    # the outermost view directions: u = +-(n - 1)/2 pixels of p/n mm, over f
    n, s = d.views, la.panel.pitch_x
    edge = math.degrees(math.atan((n - 1) / 2 * s / la.focal))
    assert 2 * edge == pytest.approx(cone * (n - 1) / n, rel=0.03)
    assert math.degrees(2 * math.atan(la.pitch_x / (2 * la.focal))) == pytest.approx(cone)


@pytest.mark.povray  # main registers the marker (make test-fast leaves it out)
def test_portrait_render_writes_the_quilt_and_the_native_image(tmp_path, cli):
    cal = tmp_path / "visual.json"
    cal.write_text(visual_json(PORTRAIT.calibration))
    out = tmp_path / "sample.png"
    result = cli("render", SAMPLES / "sample.pov", "--preset", "looking-glass-portrait", "--quality", "draft",
                 "--calibration", cal, "-o", out)
    assert result.code == 0, result.err
    quilt_path = tmp_path / "sample_qs8x6a0.75.png"
    quilt = read_png(quilt_path)
    assert quilt.shape[:2] == (3360, 3360)
    h3d = read_png(out)
    tiles = quilt_to_views(quilt, 8, 6)
    bank = extract(h3d, (1, 48))[0]
    assert tiles.shape == (48, 560, 420, 3)
    assert np.array_equal(tiles, bank[::-1])                     # quilt view q = bank view 47 - q
    assert not np.array_equal(tiles, bank)                       # control: the other order
    native = read_png(tmp_path / "sample_native.png")
    assert native.shape == (2048, 1536, 3)
    share = agreement(native, quilt, (8, 6), PORTRAIT.calibration, samples=20_000)
    assert share >= 0.999
    assert agreement(native, quilt, (8, 6), PORTRAIT.calibration, samples=20_000, slope_sign=-1.0) < 0.999
    again = cli("quilt", out, "--quilt", "auto", "-o", tmp_path / "again")   # the device's grid and aspect
    assert again.code == 0, again.err
    assert np.array_equal(read_png(tmp_path / "again" / quilt_path.name), quilt)
    record = read_sidecar(out)
    assert record["quilt"]["file"] == quilt_path.name and record["quilt"]["view_cone_deg"] == 40.0
    assert record["display"]["quilt"]["device"] == "looking-glass-portrait"


def test_a_calibration_of_another_device_is_one_line_and_nothing_written(tmp_path, cli):
    cal = tmp_path / "visual.json"
    cal.write_text(visual_json(DEVICES["looking-glass-go"].calibration))
    out = tmp_path / "s.png"
    line = one_error_line(cli("render", SAMPLES / "sample.pov", "--preset", "looking-glass-portrait",
                              "--calibration", cal, "-o", out))
    assert "Looking Glass Portrait is 1536x2048" in line and not list(tmp_path.glob("*.png"))
    cone = tmp_path / "cone.json"
    cone.write_text(json.dumps({**json.loads(visual_json(PORTRAIT.calibration)), "viewCone": {"value": 30.0}}))
    line = one_error_line(cli("render", SAMPLES / "sample.pov", "--preset", "looking-glass-portrait",
                              "--calibration", cone, "-o", out))
    assert "viewCone 30 deg" in line and not list(tmp_path.glob("*.png"))


# -- the camera model -------------------------------------------------------------------------------
def camera_model_mismatch(width, height, cone_deg, views, distance, depth, samples=41):
    """Angle (deg) between the oblique orthographic ray of view i through panel point P and the ray
    of the vendor's off-axis perspective camera i (at ``(D tan t_i, 0, -D)``, aimed through the
    panel), and where a point ``depth`` mm behind P along each ray lands (mm apart), over the
    panel and every view.  Rays by intersection, not by the closed form the doc states."""
    tan = np.tan(np.radians(cone_deg / 2)) * (np.arange(views) + 0.5 - views / 2) / (views / 2)
    x, y = np.meshgrid(np.linspace(-width / 2, width / 2, samples), np.linspace(-height / 2, height / 2, samples))
    p = np.stack([x, y, np.zeros_like(x)], -1)[None]                         # (1, S, S, 3) panel points
    cam = np.stack([distance * tan, np.zeros(views), -distance * np.ones(views)], -1)[:, None, None]
    persp = p - cam
    ortho = np.broadcast_to(np.stack([-distance * tan, np.zeros(views), distance * np.ones(views)], -1)[:, None, None],
                            persp.shape)
    cos = (persp * ortho).sum(-1) / np.linalg.norm(persp, axis=-1) / np.linalg.norm(ortho, axis=-1)
    angle = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    at = lambda d: p + d * depth / d[..., 2:3]                                # noqa: E731  the point z = depth
    shift = np.linalg.norm(at(persp) - at(ortho), axis=-1)
    # parallax per view step (horizontal), both models
    step_p = np.diff(at(persp)[..., 0], axis=0)
    step_o = np.diff(at(ortho)[..., 0], axis=0)
    return float(angle.max()), float(shift.max()), float(np.abs(step_p - step_o).max())


def test_orthographic_views_differ_from_perspective_cameras_by_a_magnification():
    """On the Portrait (120.4 x 160.5 mm, 40 deg, 48 views) seen from D = 500 mm: the ray angles differ
    by up to atan(r / D) at the corner, a point z behind the panel lands z r / D apart (the same in
    every view: a magnification 1 + z / D), and the parallax per view step is identical."""
    w, h = PORTRAIT.calibration.size_mm
    d, z = 500.0, 20.0
    angle, shift, step = camera_model_mismatch(w, h, 40.0, 48, d, z)
    r = math.hypot(w / 2, h / 2)
    assert shift == pytest.approx(z * r / d, rel=1e-9)                         # 4.01 mm at z = 20 mm
    assert step < 1e-9
    assert angle == pytest.approx(math.degrees(math.atan(r / d)), rel=0.02)   # 11.4 deg at the corner
    assert shift != pytest.approx(z * (w / 2) / d, rel=0.1)                  # control: not the width alone
    far = camera_model_mismatch(w, h, 40.0, 48, 4 * d, z)
    assert far[1] == pytest.approx(shift / 4, rel=1e-9)                      # and it falls as 1 / D
