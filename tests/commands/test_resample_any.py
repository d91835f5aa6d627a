"""``povh3d resample`` on every image ``extract`` takes: hex arrays, fractional pixels per lens,
an ``ipad-retina``-like lenticular sheet (whole lenses centred on a panel one pixel wider each
side) and a slanted sheet.

Oracle: a scene rendered at PPL A and resampled to PPL B agrees with the same scene rendered
directly through the lens array the resample's sidecar describes (the same lenses on the same
physical panel, checked against the input's), pixel for pixel away from the array's edge, and
so do the views ``extract`` pulls from both.  Negative controls that must miss the same
thresholds: a 2D resize of the whole image (it mixes neighbouring lenses, i.e. other
directions, at every cell border), and on the hex array a resample that reads the odd lens
rows without their half-pitch offset.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from povh3d.display.display import Display
from povh3d.renderer.records import base_record, write_image
from povh3d.renderer.outputs.views import sidecar_bank
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.colour import decode, encode
from povh3d.image.elemental import lens_index_map
from povh3d.image.interleave import extract
from povh3d.image.io import read_png, read_sidecar
from povh3d.image.resample import resample_micro_images, resample_panel, resampled_array
from tests.support import scenes
from tests.support.cli import one_error_line

S, F = 0.1, 1.5            # pixel pitch, focal length (mm)
DEPTH, PERIOD = 3.0, 4.0   # the plane behind the screen and its texture's period (mm)


def write_wave_plane(folder):
    return scenes.write_wave_plane(folder, DEPTH, PERIOD)


def hex_array(lenses=(12, 10), ppl=8) -> LensArray:
    px = ppl * S
    py = px * math.sqrt(3) / 2
    width = math.ceil(lenses[0] * ppl + ppl / 2)
    width += width % 2
    return LensArray("hex", *lenses, px, py, F, Panel(width, math.ceil(lenses[1] * py / S), S, S))


CASES = {   # name: (the array rendered at PPL A, --ppl-out B)
    "hex 8 -> 5": (hex_array(), "5"),
    "square 6.5 -> 4.5": (LensArray("square", 10, 8, 0.65, 0.65, F, Panel(66, 53, S, S)), "4.5"),
    # ipad-retina's layout (341 lenses of 6 px on 2048 px): 20 lenses of 6 px on 122 px
    "ipad-like 6 -> 4": (LensArray("lenticular", 20, 40, 0.6, S, F, Panel(122, 40, S, S)), "4"),
    "ipad-like 6 -> 4.5": (LensArray("lenticular", 20, 40, 0.6, S, F, Panel(122, 40, S, S)), "4.5"),
    "slanted 6 -> 4.5": (LensArray("lenticular", 22, 40, 0.6, S, F, Panel(122, 40, S, S), rotation=9.46), "4.5"),
}


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    """Per case: the input render, its resample by the CLI, and the direct render through the
    resample's sidecar array: ``{name: (input array, output array, folder)}``."""
    from tests.support.cli import run_in_process
    from tests.support.render import DRAFT, render

    folder = tmp_path_factory.mktemp("resample")
    scene = write_wave_plane(folder)
    out = {}
    for n, (name, (la, ppl_out)) in enumerate(CASES.items()):
        case = folder / f"c{n}"
        case.mkdir()
        render(scene, la, case / "a.png", settings=DRAFT)
        result = run_in_process("resample", case / "a.png", "--ppl-out", ppl_out, "-o", case / "r.png")
        assert result.code == 0, result.err
        lo = Display.from_record(read_sidecar(case / "r.png")).lens_array
        render(scene, lo, case / "b.png", settings=DRAFT)
        out[name] = (la, lo, case)
    return out


def _interior(la: LensArray) -> np.ndarray:
    """Pixels of lenses off the array's outer ring (a direct render and a resample both clamp there)."""
    lens = lens_index_map(la)
    i, j = lens // la.lenses_x, lens % la.lenses_x
    return (lens >= 0) & (i >= 1) & (i < la.lenses_y - 1) & (j >= 1) & (j < la.lenses_x - 1)


def _errors(a, b, keep) -> np.ndarray:
    return np.abs(decode(a) - decode(b)).max(axis=-1)[keep]


def _psnr(err) -> float:
    return float(10 * np.log10(1 / np.mean(err ** 2)))


def _whole_resize(image, lo: LensArray) -> np.ndarray:
    """Control: the whole image resized in linear light (area), blind to the lenses."""
    lin = decode(image).astype(np.float32)
    size = (lo.panel.width, lo.panel.height)
    out = np.stack([np.asarray(Image.fromarray(lin[..., c]).resize(size, Image.BOX)) for c in range(3)], -1)
    out = encode(np.clip(out, 0, 1), image.dtype)
    out[lens_index_map(lo) < 0] = 0
    return out


def _odd_rows_unshifted(image, resampled, la: LensArray, lo: LensArray) -> np.ndarray:
    """Control: the odd lens rows read at their pixels' offsets from lens centres without the
    half-pitch shift, i.e. half a pitch to the left (bilinear over the whole image)."""
    lin = decode(image)
    h, w = lin.shape[:2]
    x, y = np.meshgrid(*lo.panel.pixel_centres())
    col = np.clip((x - la.pitch_x / 2) / S + w / 2 - 0.5, 0, w - 1.001)
    row = np.clip(h / 2 - 0.5 - y / S, 0, h - 1.001)
    c0, r0 = np.floor(col).astype(int), np.floor(row).astype(int)
    fc, fr = (col - c0)[..., None], (row - r0)[..., None]
    value = ((1 - fr) * ((1 - fc) * lin[r0, c0] + fc * lin[r0, c0 + 1])
             + fr * ((1 - fc) * lin[r0 + 1, c0] + fc * lin[r0 + 1, c0 + 1]))
    lens = lens_index_map(lo)
    odd = (lens >= 0) & ((lens // lo.lenses_x) % 2 == 1)
    out = resampled.copy()
    out[odd] = encode(value[odd], resampled.dtype)
    return out


# measured (linear light, the texture swings 0.0 .. 1.0; under load, draft point-sampled):
# hex: mean error 0.0144, 95.5 % within 0.05 (whole resize 0.028 / 86.5 %, odd rows unshifted
# 0.064 / 67.7 %); square 6.5 -> 4.5: 42.6 dB (resize 37.0); ipad-like 6 -> 4: 45.0 dB (30.9),
# 6 -> 4.5: 39.3 dB (29.9); a sheet slanted 9.46 deg 6 -> 4.5: 39.5 dB (30.0).  The misses sit on the cell borders, where a new pixel's centre lies
# beyond the outermost old pixel of its lens and takes that pixel's light (as appendix C clamps).
LIMITS = {"hex 8 -> 5": None, "square 6.5 -> 4.5": 40.0, "ipad-like 6 -> 4": 40.0, "ipad-like 6 -> 4.5": 35.0,
          "slanted 6 -> 4.5": 35.0}


def _passes(name, err) -> bool:
    if LIMITS[name] is None:   # hex: mean and share within 0.05
        return float(err.mean()) < 0.02 and float((err < 0.05).mean()) > 0.92
    return _psnr(err) > LIMITS[name]


@pytest.mark.povray
@pytest.mark.parametrize("name", list(CASES))
def test_resample_agrees_with_a_direct_render(renders, name):
    la, lo, case = renders[name]
    a, r, b = (read_png(case / f) for f in ("a.png", "r.png", "b.png"))
    keep = _interior(lo)
    err = _errors(r, b, keep)
    assert _passes(name, err), (name, float(err.mean()), float((err < 0.05).mean()), _psnr(err))
    controls = [_whole_resize(a, lo)] + ([_odd_rows_unshifted(a, r, la, lo)] if la.grid == "hex" else [])
    for control in controls:
        bad = _errors(control, b, keep)
        assert not _passes(name, bad), (name, float(bad.mean()), float((bad < 0.05).mean()), _psnr(bad))


@pytest.mark.povray
@pytest.mark.parametrize("name", list(CASES))
def test_extract_of_the_resample_agrees_with_extract_of_the_direct_render(renders, name):
    """The views pulled through the output's sidecar, as ``extract`` pulls them."""
    la, lo, case = renders[name]
    a, r, b = (read_png(case / f) for f in ("a.png", "r.png", "b.png"))
    views = [sidecar_bank(img, lo) for img in (r, b)]
    assert views[0].shape[:2] == views[1].shape[:2] == (1 if lo.grid == "lenticular" else round(lo.ppl_x),
                                                       round(lo.ppl_x))
    inner = (slice(None), slice(None), slice(1, -1), slice(1, -1))
    err = np.abs(decode(views[0]) - decode(views[1])).max(axis=-1)[inner]
    # measured: hex 33.3 dB, square 45.9, ipad-like 45.0 and 47.1, slanted 42.8
    limit = 30.0 if lo.grid == "hex" else 40.0
    assert _psnr(err) > limit, (name, _psnr(err))
    bad = np.abs(decode(sidecar_bank(_whole_resize(a, lo), lo)) - decode(views[1])).max(axis=-1)[inner]
    assert _psnr(bad) < limit, (name, _psnr(bad))


@pytest.mark.povray
@pytest.mark.parametrize("name", list(CASES))
def test_the_sidecar_keeps_the_lenses_and_the_panel(renders, name):
    la, lo, _ = renders[name]
    assert np.allclose(lo.lens_centres(), la.lens_centres(), atol=1e-12)
    assert (lo.grid, lo.focal, lo.pitch_x, lo.pitch_y) == (la.grid, la.focal, la.pitch_x, la.pitch_y)
    (w0, h0), (w1, h1) = la.panel.size_mm, lo.panel.size_mm
    if lo.views is None:   # a panel path: the same physical panel, to a new pixel
        assert abs(w1 - w0) <= lo.panel.pitch_x and abs(h1 - h0) <= lo.panel.pitch_y, (la.panel, lo.panel)
    else:                  # whole PPL on a bank: the panel cut to the lenses, as before
        assert (w1, lo.panel.height) == (pytest.approx(la.lenses_x * la.pitch_x), la.panel.height)
    assert math.isclose(lo.ppl_x, float(CASES[name][1]))


@pytest.mark.parametrize("n_in, ppl_out", [(6, (3, 3)), (6, (4, 4)), (3, (7, 7)), (4, (2, 6)), (5, (4, 3))])
def test_panel_resample_of_whole_lenses_is_the_micro_image_resize(n_in, ppl_out):
    """Two independent routes, one result: each new pixel read at its panel point from its own
    lens, and each micro-image resized on its own (appendix C)."""
    rng = np.random.default_rng(n_in)
    la = LensArray("square", 5, 4, n_in * S, n_in * S, F, Panel(5 * n_in, 4 * n_in, S, S))
    image = rng.integers(0, 256, (4 * n_in, 5 * n_in, 3), dtype=np.uint8)
    got = resample_panel(image, la, resampled_array(la, ppl_out))
    assert np.array_equal(got, resample_micro_images(image, (n_in, n_in), ppl_out))
    # control: the lens cells ignored (one lens over the whole panel) mixes neighbouring lenses
    # where a new pixel's taps cross a cell border: growing (shrinking to whole pixels per lens,
    # the new pixels' areas end on the cell borders)
    if max(ppl_out) <= n_in:
        return
    one = LensArray("square", 1, 1, 5 * n_in * S, 4 * n_in * S, F, la.panel)
    big = resampled_array(one, (ppl_out[0] * 4, ppl_out[1] * 5))
    assert not np.array_equal(resample_panel(image, one, big), got)


def _noise_hex(tmp_path):
    la = hex_array((6, 5), 5)
    image = np.random.default_rng(23).integers(0, 256, (la.panel.height, la.panel.width, 3), dtype=np.uint8)
    write_image(tmp_path / "h.png", image, base_record("h3d", la))
    return tmp_path / "h.png"


@pytest.mark.parametrize("args, words", [
    (["--mode", "lenses", "--ppl-out", "3"], ("--mode lenses", "hex lens array", "use --mode micro")),
    (["--ppl-out", "3x2"], ("one number", "--ppl-out 3")),
    (["--ppl", "5", "--ppl-out", "3"], ("--ppl contradicts",)),
    (["--ppl-out", "0.5"], ("--ppl-out 0.5x0.5", "under one pixel")),
    (["--ppl-out", "1e9"], ("of memory", "give a smaller --ppl-out")),
])
def test_bad_resamples_of_a_hex_image_are_one_line(tmp_path, cli, args, words):
    path = _noise_hex(tmp_path)
    line = one_error_line(cli("resample", path, *args, "-o", tmp_path / "r.png"))
    assert all(w in line for w in words), line
    assert not (tmp_path / "r.png").exists() and not (tmp_path / "r.json").exists()


def test_a_fractional_ppl_out_without_a_sidecar_is_one_line(tmp_path, cli):
    image = np.zeros((8, 16, 3), np.uint8)
    from povh3d.image.io import write_png

    write_png(tmp_path / "bare.png", image)
    line = one_error_line(cli("resample", tmp_path / "bare.png", "--ppl", "4", "--ppl-out", "2.5",
                              "-o", tmp_path / "r.png"))
    assert "not whole pixels per lens" in line and not (tmp_path / "r.png").exists()
    assert extract(image, (4, 4)).shape[:2] == (4, 4)   # the same image, whole: resampled as before
    assert cli("resample", tmp_path / "bare.png", "--ppl", "4", "--ppl-out", "2", "-o", tmp_path / "r.png").code == 0
