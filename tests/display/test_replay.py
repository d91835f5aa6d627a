"""Replay (display/replay.py): the H3D image on its display, seen from an eye.

Oracles from docs/geometry.md written out here (lens centres from their indices, the pixel of a
point), never from the module's own helpers; each figure with a negative control that fails it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import povh3d
from povh3d.display import presets
from povh3d.display.replay import coded_panel, light_shares, replay
from povh3d.errors import ConfigError
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays
from povh3d.image.io import read_png
from povh3d.renderer.records import base_record, write_image

EYE = (13.7, -6.2, -250.0)


def coded(lens_array: LensArray) -> np.ndarray:
    """An H3D image whose pixel ``(col, row)`` holds ``(col + 1, row + 1, 7)`` (16 bit): 0 is black."""
    p = lens_array.panel
    rows, cols = np.mgrid[0:p.height, 0:p.width]
    return np.stack([cols + 1, rows + 1, np.full_like(cols, 7)], axis=-1).astype(np.uint16)


def oracle_centres(la: LensArray) -> np.ndarray:
    """docs/geometry.md's lens centres, from the indices: (Ly, Lx, 2) mm."""
    i, j = np.mgrid[0:la.lenses_y, 0:la.lenses_x].astype(float)
    cx = (j + 0.5 - la.lenses_x / 2) * la.pitch_x
    if la.grid == "hex":
        cx = cx + (i % 2) * la.pitch_x / 2
    cy = (la.lenses_y / 2 - i - 0.5) * la.pitch_y
    t = math.radians(la.rotation)
    return np.stack([math.cos(t) * cx - math.sin(t) * cy, math.sin(t) * cx + math.cos(t) * cy], axis=-1)


def oracle_pixels(la: LensArray, eye, sign: float = 1.0) -> np.ndarray:
    """The coded value ``(col + 1, row + 1)`` of the pixel holding ``c + (c - E_xy) f / |E_z|`` (0 off the panel)."""
    c = oracle_centres(la)
    land = c + sign * (c - np.array(eye[:2])) * la.focal / abs(eye[2])
    p = la.panel
    col = np.floor(land[..., 0] / p.pitch_x + p.width / 2)
    row = np.floor(p.height / 2 - land[..., 1] / p.pitch_y)
    on = (col >= 0) & (col < p.width) & (row >= 0) & (row < p.height)
    return np.stack([np.where(on, col + 1, 0), np.where(on, row + 1, 0)], axis=-1).astype(np.uint16)


ARRAYS = {
    "square": lambda: presets.lens_array("demo"),
    "hex": lambda: LensArray("hex", 22, 21, 0.85, 0.85 * math.sqrt(3) / 2, 1.0, Panel(200, 160, 0.1, 0.1)),
    "lenticular": lambda: LensArray("lenticular", 40, 120, 0.6, 0.1, 1.25, Panel(240, 120, 0.1, 0.1)),
    "slanted": lambda: LensArray("lenticular", 48, 120, 0.6, 0.1, 1.25, Panel(240, 120, 0.1, 0.1), 9.46),
    "rotated-square": lambda: LensArray("square", 44, 34, 0.8, 0.8, 1.5, Panel(320, 240, 0.1, 0.1), 6.34),
}


@pytest.mark.parametrize("name", sorted(ARRAYS))
def test_pinhole_lens_shows_the_pixel_its_ray_lands_on(name: str) -> None:
    la = ARRAYS[name]()
    got = replay(coded(la), la, EYE, size="lenses").image[..., :2]
    want = oracle_pixels(la, EYE)
    assert got.shape == want.shape
    assert np.array_equal(got, want)  # byte for byte, every lens
    assert (want > 0).all(axis=-1).mean() > 0.5  # most lenses land on the panel: the figure is not all black
    # negative control: the offset's sign turned fails on most lenses
    wrong = oracle_pixels(la, EYE, sign=-1.0)
    assert (got != wrong).any(axis=-1).mean() > 0.5


def test_chain_identity_no_sheet_at_the_panel_size() -> None:
    la = ARRAYS["hex"]()
    h3d = np.random.default_rng(3).integers(0, 256, (160, 200, 3), dtype=np.uint8)
    out = replay(h3d, la, EYE, optics="none", size=(200, 160)).image
    assert out.tobytes() == h3d.tobytes()
    # negative control: a picture one pixel wider is not the image
    wider = replay(h3d, la, EYE, optics="none", size=(201, 160)).image
    assert not np.array_equal(wider[:, :200], h3d)


def test_picture_pixels_inside_a_lens_cell_show_that_lens() -> None:
    la = presets.lens_array("demo")  # 40 x 30 lenses of 0.8 mm: 4 x 4 picture pixels a lens at 160 x 120
    h3d = coded(la)
    lenses = replay(h3d, la, EYE, size="lenses").image
    picture = replay(h3d, la, EYE, size=(160, 120)).image
    assert np.array_equal(picture, np.repeat(np.repeat(lenses, 4, axis=0), 4, axis=1))
    # negative control: from another eye the picture differs
    other = replay(h3d, la, (EYE[0] + 20, EYE[1], EYE[2]), size=(160, 120)).image
    assert not np.array_equal(other, picture)


def surface(la: LensArray, depth: float, *, pseudoscopic: bool = False) -> np.ndarray:
    """The H3D image of a plane at ``depth`` mm whose red channel codes ``x`` of the point each pixel's ray
    hits (the ray of a pixel, docs/geometry.md): 1000 codes a mm about 30000."""
    c, d, inside = pixel_rays(la)
    x = c[..., 0] + d[..., 0] / d[..., 2] * depth
    code = np.where(inside, np.rint(30000 + 1000 * x), 0).astype(np.uint16)
    img = np.stack([code, code, code], axis=-1)
    if pseudoscopic:  # each elemental image turned 180 degrees
        ny, nx = la.views
        img = img.reshape(la.lenses_y, ny, la.lenses_x, nx, 3)[:, ::-1, :, ::-1].reshape(img.shape)
    return img


def screen_position(la: LensArray, image: np.ndarray, eye, x0: np.ndarray) -> np.ndarray:
    """Where on the screen (mm) the eye sees the surface points ``x0``: along the middle lens row."""
    seen = replay(image, la, eye, size="lenses").image[la.lenses_y // 2, :, 0].astype(float)
    x = (seen - 30000) / 1000
    cx = oracle_centres(la)[la.lenses_y // 2, :, 0]
    a, b = np.polyfit(cx, x, 1)  # a line through the pixel-quantised staircase of x along the row
    return (x0 - b) / a


@pytest.mark.parametrize("depth", [10.0, -10.0])
def test_parallax_of_a_surface_at_depth(depth: float) -> None:
    la = presets.lens_array("demo")
    e1, e2 = (-40.0, 0.0, -300.0), (40.0, 0.0, -300.0)
    x0 = np.linspace(-8, 8, 9)
    want = (e2[0] - e1[0]) * depth / (abs(e1[2]) + depth)
    tolerance = la.pitch_x + abs(depth) * la.panel.pitch_x / (2 * la.focal)
    img = surface(la, depth)
    got = screen_position(la, img, e2, x0) - screen_position(la, img, e1, x0)
    assert np.abs(got - want).max() <= tolerance, (got, want)
    assert np.abs(got - want).max() <= 0.05  # measured: 0.01-0.02 mm
    # negative control: the pseudoscopic image moves the wrong way
    pseudo = surface(la, depth, pseudoscopic=True)
    bad = screen_position(la, pseudo, e2, x0) - screen_position(la, pseudo, e1, x0)
    assert np.sign(bad).tolist() == [-np.sign(want)] * len(x0)
    assert np.abs(bad - want).min() > tolerance


def test_beyond_the_zone_the_next_lens_shows_the_view() -> None:
    la = presets.lens_array("demo")
    eye = np.array([10.0, 0.0, -300.0])
    beyond = eye + [abs(eye[2]) * la.pitch_x / la.focal, 0, 0]  # 160 mm on: every lens shows its neighbour's image
    h3d = coded(la)
    near = replay(h3d, la, eye).image.astype(int)
    far = replay(h3d, la, beyond).image.astype(int)
    # lens j from `beyond` shows the pixel lens j-1 shows from `eye` (the replay shifted by one lens), within
    # one pixel: the landing points differ by p f / |E_z| = 0.004 mm
    shifted = far[:, 1:, :2] - near[:, :-1, :2]
    assert np.abs(shifted).max() <= 1 and (shifted == 0).all(axis=-1).mean() > 0.9
    # negative control: unshifted, the two replays differ by a lens's worth of pixels everywhere
    assert (far[..., 0] - near[..., 0] == -round(la.ppl_x)).mean() > 0.9


@pytest.mark.parametrize("eye, words", [((0, 0, 10), "panel's side"), ((0, 0, 0), "panel's side"),
                                         ((0, 0, -1), "inside the lens sheet"), ((0, float("nan"), -300), "finite")])
def test_eye_refused(eye, words: str) -> None:
    la = presets.lens_array("demo")
    with pytest.raises(ConfigError, match=words):
        replay(coded(la), la, eye)


def test_api_matches_the_module() -> None:
    la = presets.lens_array("demo")
    h3d = coded(la)
    assert np.array_equal(povh3d.replay(h3d, la), replay(h3d, la, (0, 0, -300)).image)
    assert np.array_equal(povh3d.replay(h3d, la, EYE, size=(80, 60)), replay(h3d, la, EYE, size=(80, 60)).image)


# -- the command ---------------------------------------------------------------------------------------
def write_h3d(path: Path, la: LensArray, image: np.ndarray) -> Path:
    write_image(path, image, base_record("h3d", la))
    return path


def test_command_writes_the_replay_and_report(tmp_path: Path, cli) -> None:
    la = presets.lens_array("demo")
    h3d = write_h3d(tmp_path / "h.png", la, coded(la))
    out = tmp_path / "eye.png"
    r = cli("replay", str(h3d), "--eye", "13.7,-6.2,-250", "-o", str(out), "--json", str(tmp_path / "r.json"))
    assert r.code == 0, r.err
    assert np.array_equal(read_png(out)[..., :2], oracle_pixels(la, EYE))
    import json

    rep = json.loads((tmp_path / "r.json").read_text())["eyes"][0]
    assert rep["own_lens_share"] == 1.0 and rep["view_zone"]["lens_zone_width_mm"] == pytest.approx(0.8 * 250 / 1.5)
    assert sum(rep["view_counts"].values()) == 1200


def test_command_sweep_writes_frames_and_gif(tmp_path: Path, cli) -> None:
    la = presets.lens_array("demo")
    h3d = write_h3d(tmp_path / "h.png", la, (coded(la) >> 1).astype(np.uint8))
    r = cli("replay", str(h3d), "--sweep", "-60:60:5", "-o", str(tmp_path / "s.gif"))
    assert r.code == 0, r.err
    frames = sorted(tmp_path.glob("s_*.png"))
    assert len(frames) == 5 and (tmp_path / "s.gif").is_file()
    assert not np.array_equal(read_png(frames[0]), read_png(frames[-1]))
    pytest.importorskip("imageio_ffmpeg")
    r = cli("replay", str(h3d), "--sweep", "y:-30:30:3", "-o", str(tmp_path / "v.mp4"))
    assert r.code == 0, r.err
    assert (tmp_path / "v.mp4").stat().st_size > 0 and len(list(tmp_path.glob("v_*.png"))) == 3


@pytest.mark.parametrize("args, words", [
    (["--eye", "0,0,20"], "panel's side"),
    (["--eye", "0,0,-0.5"], "inside the lens sheet"),
    (["--eye", "0,0"], "X,Y,Z"),
    (["--optics", "barrier"], "lenticular"),
    (["--sweep", "1:2"], "X0:X1:N"),
])
def test_command_bad_input_is_one_line_and_writes_nothing(tmp_path: Path, cli, args, words) -> None:
    la = presets.lens_array("demo")
    h3d = write_h3d(tmp_path / "h.png", la, coded(la))
    out = tmp_path / "eye.png"
    r = cli("replay", str(h3d), "-o", str(out), *args)
    assert r.code != 0 and words in r.err and len(r.err.strip().splitlines()) == 1, r.err
    assert not out.exists()


def test_command_refuses_an_image_without_sidecar(tmp_path: Path, cli) -> None:
    from povh3d.image.io import write_png

    la = presets.lens_array("demo")
    write_png(tmp_path / "bare.png", coded(la))
    r = cli("replay", str(tmp_path / "bare.png"), "-o", str(tmp_path / "eye.png"))
    assert r.code != 0 and "no sidecar" in r.err and len(r.err.strip().splitlines()) == 1
    assert not (tmp_path / "eye.png").exists()


def test_light_shares_of_the_pinhole_picture_are_all_chief() -> None:
    """The coded pinhole picture itself: every aperture pixel its chief pixel (the shares' own oracle)."""
    la = presets.lens_array("demo")
    eye = (60.0, 0.0, -300.0)
    seen = replay(coded_panel(la), la, eye, size=(160, 120)).image
    shares = light_shares(seen, la, eye, (160, 120))
    assert shares["chief_pixel"] == 1.0
    other = replay(coded_panel(la), la, (0.0, 0.0, -300.0), size=(160, 120)).image
    assert light_shares(other, la, eye, (160, 120))["chief_pixel"] < 0.5


# -- mapped slanted panels -----------------------------------------------------------------------------
@pytest.mark.parametrize("preset, mapping, exact, within_one", [("alioscopy-42", "alioscopy", 0.74, 0.999),
                                                                ("philips-20", "philips", 0.43, 0.93)])
def test_mapped_panel_shows_the_view_pointing_at_the_eye(preset: str, mapping: str, exact: float,
                                                         within_one: float) -> None:
    """A mapped panel through the sheet its mapping addresses (subpixel.placed_sheet), eye at 4 m: the view
    the mapping gives the subpixel each ray lands on is the view whose direction points at the eye (the
    landing point's place across its lenticule) on 75 % (alioscopy) / 44 % (philips) of lens samples, and
    within one view on 100 % / 94 %: a subpixel spans about two views across a slanted lenticule, so a
    point lands in a neighbour's view near its corners.  Against a sheet half a pitch off, on none."""
    from povh3d.display.display import build_display
    from povh3d.display.replay import mapped_report, mapped_sheet

    d = build_display(preset, mapping=mapping)
    panel = d.mapped_panel
    sheet, shift, views = mapped_sheet(d.mapping, panel, d.lens_array.focal)
    h3d = np.random.default_rng(2).integers(1, 256, (panel.height, panel.width, 3), dtype=np.uint8)
    eye = (0.0, 0.0, -4000.0)
    r = replay(h3d, sheet, eye, optics="barrier", shift=shift, subpixels=True)
    rep = mapped_report(r, sheet, shift, views, eye)
    assert rep["geometric_view_share"] >= exact and rep["within_one_view_share"] >= within_one
    assert rep["samples"] - rep["off_panel"] > 0.7 * rep["samples"]
    # the eye sees channel c of the pixel the subpixel 3 col + c belongs to, and nothing of the others
    ok = r.pixel[..., 0] >= 0
    col3, row = r.pixel[..., 0][ok], r.pixel[..., 1][ok]
    seen = r.image[ok]
    assert np.array_equal(seen[np.arange(col3.size), col3 % 3], h3d[row, col3 // 3, col3 % 3])
    assert (seen.astype(int).sum(axis=1) == seen[np.arange(col3.size), col3 % 3]).all()
    # negative control: the views judged against a sheet half a pitch across
    wrong = mapped_report(r, sheet, shift + sheet.pitch_x / 2, views, eye)
    assert wrong["geometric_view_share"] < 0.05


def test_command_replays_a_mapped_panel(tmp_path: Path, cli) -> None:
    from povh3d.display.display import build_display

    d = build_display("alioscopy-42", mapping="alioscopy")
    w, h = d.image_size
    path = tmp_path / "panel.png"
    write_image(path, np.random.default_rng(0).integers(0, 256, (h, w, 3), dtype=np.uint8),
                {**base_record("panel"), **d.as_record()})
    r = cli("replay", str(path), "--eye", "0,0,-4000", "-o", str(tmp_path / "eye.png"), "--json", str(tmp_path / "r.json"))
    assert r.code == 0, r.err
    import json

    rep = json.loads((tmp_path / "r.json").read_text())["eyes"][0]
    assert rep["geometric_view_share"] > 0.74 and set(rep["view_counts"]) <= {str(v) for v in range(8)}
    r = cli("replay", str(path), "--optics", "none", "--size", "80x60", "-o", str(tmp_path / "lens.png"))  # no sheet
    assert r.code != 0 and "mapped panel" in r.err and not (tmp_path / "lens.png").exists()


def test_view_flips_are_where_the_centre_lens_changes_pixel() -> None:
    from povh3d.display.replay import view_zone

    la = presets.lens_array("demo")
    zone = view_zone(la, 300.0)
    flips = zone["view_flips_x_mm"]
    assert len(flips) == 9 and flips[0] == pytest.approx(zone["centre_lens_zone_mm"][0])  # 8 pixels, 9 edges
    i, j = 14, 19  # the lens at (-0.4, 0.4): row 14, column 19 of 30 x 40
    assert np.allclose(oracle_centres(la)[i, j], zone["centre_lens_mm"])
    h3d = coded(la)

    def col(x: float) -> int:
        return int(replay(h3d, la, (x, 0.0, -300.0)).image[i, j, 0])

    for edge in flips[1:-1]:
        assert col(edge - 0.3) == col(edge + 0.3) + 1  # the eye moves right: the pixel one column left
        assert col(edge + 0.3) == col(edge + 19.0)    # negative control: between two flips, no change
