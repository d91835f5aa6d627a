"""Replay through POV-Ray (renderer/replay.py): the chain's identity and the real lenslets against the
pinhole display (display/replay.py), each figure with a negative control."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from povh3d.display import presets
from povh3d.display.replay import coded_panel, lens_cells, psnr, replay, window_points
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.io import read_png
from povh3d.renderer.records import base_record, write_image
from povh3d.renderer.replay import render_replay

pytestmark = pytest.mark.povray


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_chain_identity_through_povray(dtype) -> None:
    """No sheet, the panel in the lens plane, the picture at the panel's size: the H3D byte for byte."""
    la = presets.lens_array("demo")
    img = np.random.default_rng(1).integers(0, np.iinfo(dtype).max + 1, (240, 320, 3), dtype=dtype)
    eye = (37.0, -21.0, -150.0)
    out, _ = render_replay(img, la, np.array([eye]), size=(320, 240), sheet=False)
    assert out[0].dtype == dtype and out[0].tobytes() == img.tobytes()
    # negative control: the same run one pixel narrower is not the image
    narrow, _ = render_replay(img, la, np.array([eye]), size=(319, 240), sheet=False)
    assert not np.array_equal(narrow[0][:, :319], img[:, :319])


def centre_agreement(seen: np.ndarray, la: LensArray, eye, size) -> float:
    """Share of picture pixels near a lens centre (within 0.2 pitch) that show the chief ray's pixel."""
    chief = replay(coded_panel(la), la, eye, size=size)
    x, y = window_points(la, size)
    _, _, inside, c = lens_cells(la, x, y)
    near = (np.hypot(x - c[..., 0], y - c[..., 1]) < 0.2 * la.pitch_x) & inside & (chief.pixel[..., 0] >= 0)
    same = np.all(seen[..., :2].astype(np.int64) - 1 == chief.pixel, axis=-1)
    return float(same[near].mean())


ARRAYS = {
    "square": lambda: presets.lens_array("demo"),
    "hex": lambda: LensArray("hex", 22, 21, 0.85, 0.85 * math.sqrt(3) / 2, 1.5, Panel(200, 160, 0.1, 0.1)),
    "lenticular": lambda: LensArray("lenticular", 40, 120, 0.6, 0.1, 1.25, Panel(240, 120, 0.1, 0.1)),
    "slanted": lambda: LensArray("lenticular", 48, 120, 0.6, 0.1, 1.25, Panel(240, 120, 0.1, 0.1), 9.46),
}


@pytest.mark.parametrize("name", sorted(ARRAYS))
def test_lenslets_show_the_chief_pixel_near_their_centres(name: str) -> None:
    """Near the vertex a lens is the pinhole: its picture shows the pixel the chief ray lands on
    (measured 99.7-99.95 %); from an eye 3 mm off, most of them do not."""
    la = ARRAYS[name]()
    size = (la.panel.width * 2, la.panel.height * 2)
    eye = (5.0, -3.0, -300.0)
    out, _ = render_replay(coded_panel(la), la, np.array([eye]), size=size)
    assert centre_agreement(out[0], la, eye, size) >= 0.99
    # negative control: the chief pixels of another eye (0.1 pixel of landing shift a mm of eye)
    assert centre_agreement(out[0], la, (eye[0] + 30.0, eye[1], eye[2]), size) < 0.5


def test_demo_lenslet_light_shares_and_psnr(tmp_path: Path, cli) -> None:
    """demo's spherical lenslet (n = 1.49) on axis and 60 mm off axis at 300 mm (the issue's prototype:
    0.74 / 0.58 chief pixel, 0 / 0.06 neighbouring lenses, 25 / 19 dB)."""
    la = presets.lens_array("demo")
    h3d = tmp_path / "h.png"
    rng = np.random.default_rng(5)  # a smooth-ish image: lens-sized blocks of noise
    img = np.repeat(np.repeat(rng.integers(0, 256, (60, 80, 3), dtype=np.uint8), 4, axis=0), 4, axis=1)
    write_image(h3d, img, base_record("h3d", la))
    figures = {}
    for x in (0, 60):
        r = cli("replay", str(h3d), "--optics", "lens", "--size", "400x300", "--eye", f"{x},0,-300",
                "-o", str(tmp_path / f"e{x}.png"), "--json", str(tmp_path / f"e{x}.json"))
        assert r.code == 0, r.err
        figures[x] = json.loads((tmp_path / f"e{x}.json").read_text())["eyes"][0]
    axis, off = figures[0]["light_shares"], figures[60]["light_shares"]
    assert 0.68 <= axis["chief_pixel"] <= 0.80 and axis["neighbouring_lenses"] < 0.001
    assert 0.50 <= off["chief_pixel"] <= 0.64 and 0.04 <= off["neighbouring_lenses"] <= 0.12
    assert off["chief_pixel"] < axis["chief_pixel"] - 0.08  # the off-axis eye sees more of the neighbours
    for share in (axis, off):
        assert sum(share[k] for k in ("chief_pixel", "neighbouring_views", "neighbouring_lenses", "dark")) \
            == pytest.approx(1.0)
    # the pictures against the pinhole display at the same size
    lens0, lens60 = read_png(tmp_path / "e0.png"), read_png(tmp_path / "e60.png")
    pin0 = replay(img, la, (0, 0, -300), size=(400, 300)).image
    pin60 = replay(img, la, (60, 0, -300), size=(400, 300)).image
    assert psnr(lens0, pin0) > psnr(lens60, pin60) > 12
    # negative control: the on-axis lens picture against the off-axis pinhole one is far worse
    assert psnr(lens0, pin60) < psnr(lens0, pin0) - 3


RAMP = """#version 3.7;
global_settings { assumed_gamma 1.0 }
plane { z, DEPTH pigment { gradient x color_map { [0 rgb 0] [1 rgb 1] } scale 40 translate <-20, 0, 0> }
        finish { emission 1 ambient 0 diffuse 0 } }
"""


@pytest.mark.parametrize("depth", [10.0, -8.0])
def test_parallax_of_a_rendered_surface(tmp_path: Path, cli, depth: float) -> None:
    """A plane at depth z rendered by povh3d (its brightness codes x: 0 at -20 mm, 1 at +20 mm, linear),
    replayed from eyes at x = -40 and +40 mm, 300 mm: it moves (E2 - E1) z / (|E_z| + z) on the screen
    (measured within 0.006 mm); the pseudoscopic image moves the wrong way."""
    from povh3d.image.colour import to_linear

    scene = tmp_path / "ramp.pov"
    scene.write_text(RAMP.replace("DEPTH", repr(depth)))
    out = tmp_path / "ramp.png"
    r = cli("render", str(scene), "--preset", "demo", "--quality", "draft", "--bit-depth", "16", "-o", str(out))
    assert r.code == 0, r.err
    la = presets.lens_array("demo")
    img = read_png(out)
    row = la.lenses_y // 2
    cx = (np.arange(la.lenses_x) + 0.5 - la.lenses_x / 2) * la.pitch_x  # geometry.md's lens centres

    def moved(image: np.ndarray) -> np.ndarray:
        x0 = np.linspace(-8, 8, 5)
        where = []
        for ex in (-40.0, 40.0):
            seen = to_linear(replay(image, la, (ex, 0.0, -300.0)).image)[row, :, 0] * 40 - 20
            a, b = np.polyfit(cx, seen, 1)  # x of the plane seen through each lens, a line along the row
            where.append((x0 - b) / a)
        return where[1] - where[0]

    want = 80.0 * depth / (300.0 + depth)
    tolerance = la.pitch_x + abs(depth) * la.panel.pitch_x / (2 * la.focal)
    got = moved(img)
    assert np.abs(got - want).max() <= min(tolerance, 0.05), (got, want)
    ny, nx = la.views
    pseudo = img.reshape(la.lenses_y, ny, la.lenses_x, nx, -1)[:, ::-1, :, ::-1].reshape(img.shape)
    bad = moved(pseudo)
    assert (np.sign(bad) == -np.sign(want)).all() and np.abs(bad - want).min() > tolerance


def test_pupil_blurs_by_its_landing_spread() -> None:
    """A pupil of diameter a spreads each lens's landing point over a f / D on the panel (4 mm at 300 mm:
    0.02 mm, a fifth of a pixel; 20 mm: a pixel) and its rays cross each lens off centre.  Measured against
    the pinhole eye on lens-sized noise: 25.4, 24.7, 20.6 dB at 1, 4, 20 mm; the wider, the blurrier."""
    la = presets.lens_array("demo")
    rng = np.random.default_rng(5)
    img = np.repeat(np.repeat(rng.integers(0, 256, (60, 80, 3), dtype=np.uint8), 4, axis=0), 4, axis=1)
    eye = np.array([(0.0, 0.0, -300.0)])
    base, _ = render_replay(img, la, eye, size=(400, 300))
    db = [psnr(render_replay(img, la, eye, size=(400, 300), pupil=a)[0][0], base[0]) for a in (1.0, 4.0, 20.0)]
    assert db[0] > db[1] > db[2] and db[2] < db[0] - 3 and db[0] > 22
