"""Lenticular calibration (issue 16, item 3) on synthetic white images.

The white images are made in NumPy with known pitch, slant and phase
(``synth.render_lenticular_white``), with noise, cos^4 vignetting and Brown
barrel distortion; the oracle is that truth: pitch within 0.01 %, slant within
0.01 deg, phase within 0.02 px.  The Looking Glass fields the calibration writes
are checked against the Looking Glass shader's own formula (a lenticule axis is
its central view), and ``map --calibration`` accepts the file.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from povh3d.calibration.lenticular import calibrate_lenticular
from povh3d.errors import ConfigError, InputError
from povh3d.image.colour import encode
from povh3d.image.io import read_png, write_png
from povh3d.display.mappings.slanted import looking_glass

from tests.support.cli import one_error_line
from tests.support.synth import render_lenticular_white

CASES = [  # pitch px, slant deg, phase px, k1, vignetting, noise
    (9.37, 9.46, 0.31, 0.0, 0.0, 0.0),
    (7.71, 18.43, -1.7, 0.02, 0.3, 0.02),
    (12.3, 6.34, 2.2, -0.03, 0.3, 0.02),
    (8.6, -12.0, 0.0, 0.02, 0.3, 0.02),
]


@pytest.mark.slow
@pytest.mark.parametrize("pitch,slant,phase,k1,vignetting,noise", CASES)
def test_pitch_slant_and_phase_are_found(pitch, slant, phase, k1, vignetting, noise):
    img = render_lenticular_white((800, 600), pitch, slant, phase, k1=k1, vignetting=vignetting, noise=noise)
    fit = calibrate_lenticular(img)
    assert abs(fit.pitch_px / pitch - 1) < 1e-4
    assert abs(fit.slant_deg - slant) < 0.01
    assert abs(fit.phase_px - phase) < 0.02
    assert abs(fit.k1 - k1) < 2e-3
    # Negative control: a fit that ignores the barrel distortion misses the pitch or the phase.
    if k1:
        straight = calibrate_lenticular(img, distortion=False)
        assert abs(straight.pitch_px / pitch - 1) > 1e-4 or abs(straight.phase_px - phase) > 0.02


def test_looking_glass_fields_put_the_central_view_on_every_axis():
    pitch, slant, phase = 9.37, 9.46, 0.8
    w, h = 480, 320
    fit = calibrate_lenticular(render_lenticular_white((w, h), pitch, slant, phase, noise=0.01))
    cal = fit.as_record(dpi=254.0)
    # Points on true axes, in image pixels: n . (q - c) = phase + m pitch, n = (cos t, -sin t).
    t = math.radians(slant)
    n, along = np.array([math.cos(t), -math.sin(t)]), np.array([math.sin(t), math.cos(t)])
    centre = np.array([(w - 1) / 2, (h - 1) / 2])
    pts = centre + np.array([(phase + m * pitch) * n + s * along for m in range(-5, 6) for s in (-50.0, 0.0, 70.0)])
    # The Looking Glass shader's lenticule coordinate (display.mappings.slanted.looking_glass doc), x from the
    # left edge, y up: a = (x + y / slope) * pitch' / W - center, pitch' = pitch W / DPI cos(atan(1/slope)).
    # Half a pixel right of the axis (LenticularFit.looking_glass: the shader reads a subpixel's phase there).
    x, y = pts[:, 0] + 0.5 + 0.5, h - pts[:, 1] - 0.5
    lenses = cal["pitch"] * w / cal["DPI"] * math.cos(math.atan(1 / cal["slope"]))
    a = (x + y / cal["slope"]) * lenses / w - cal["center"]
    np.testing.assert_allclose((a - np.floor(a)), 0.5, atol=0.02 / pitch)
    assert looking_glass(cal, 9).per_lens == pytest.approx(3 * pitch / math.cos(t), rel=1e-4)
    with pytest.raises(ConfigError, match="contradicts itself: pitch_px"):
        looking_glass({**cal, "pitch_px": pitch * 1.01}, 9)
    with pytest.raises(ConfigError, match="contradicts itself: slant_deg"):
        looking_glass({**cal, "slant_deg": -slant}, 9)


def test_no_periodic_structure_is_refused():
    rng = np.random.default_rng(3)
    for img in (np.full((200, 300), 0.7), rng.random((200, 300))):
        with pytest.raises(InputError, match="no periodic structure"):
            calibrate_lenticular(img)


def _png(path, img):
    write_png(path, encode(np.clip(np.repeat(img[..., None], 3, 2), 0, 1), np.uint16))
    return path


def test_cli_calibrates_and_map_accepts_it(tmp_path, cli):
    white = _png(tmp_path / "white.png", render_lenticular_white((240, 160), 9.37, 9.46, 0.4, noise=0.01))
    cal = tmp_path / "cal.json"
    result = cli("calibrate", white, "-o", cal, "--lattice", "lenticular", "--dpi", "254")
    assert result.code == 0, result.err
    record = json.loads(cal.read_text())
    assert record["kind"] == "lenticular" and abs(record["slant_deg"] - 9.46) < 0.01
    h3d = tmp_path / "h3d.png"
    write_png(h3d, np.zeros((160, 9 * 25, 3), np.uint8))  # what the file's 240 x 160 screen reads
    out = tmp_path / "mapped.png"
    assert cli("map", h3d, "--mapping", "slanted", "--views", "9", "--calibration", cal,
               "--grid", "lenticular", "--lenses", "25", "--ppl", "9", "--rows", "160", "-o", out).code == 0
    assert read_png(out).shape[:2] == (160, 240)  # the calibration's screen, not a size inferred from the image
    # Contradictory fields: one line, non-zero, nothing written.
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**record, "pitch_px": record["pitch_px"] * 1.5}))
    out2 = tmp_path / "mapped2.png"
    line = one_error_line(cli("map", h3d, "--mapping", "slanted", "--views", "9", "--calibration", bad,
                              "--grid", "lenticular", "--lenses", "25", "--ppl", "9", "--rows", "160", "-o", out2))
    assert "contradicts itself" in line and not out2.exists()
    missing = tmp_path / "missing.json"
    missing.write_text(json.dumps({k: v for k, v in record.items() if k != "center"}))
    line = one_error_line(cli("map", h3d, "--mapping", "slanted", "--views", "9", "--calibration", missing,
                              "--grid", "lenticular", "--lenses", "25", "--ppl", "9", "--rows", "160", "-o", out2))
    assert "lacks 'center'" in line and not out2.exists()


def test_cli_refuses_a_white_image_without_structure(tmp_path, cli):
    flat = _png(tmp_path / "flat.png", np.full((120, 160), 0.8))
    out = tmp_path / "cal.json"
    line = one_error_line(cli("calibrate", flat, "-o", out, "--lattice", "lenticular"))
    assert "no periodic structure" in line and not out.exists()
    line = one_error_line(cli("calibrate", flat, "-o", out, "--dpi", "100"))
    assert "--dpi only applies" in line and not out.exists()
