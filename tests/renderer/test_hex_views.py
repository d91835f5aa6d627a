"""``refocus`` and ``preview`` on hex images: the views ``extract`` writes, refocused on the
offset-row lattice of the lens centres, and previewed frame for frame.

Oracles:
- a render of a plane (a smooth wave texture) refocused at the plane's depth agrees with the
  centre view (``u = v = 0``: each lens's own straight-ahead sample) and with the texture at
  the lens centres, and is the sharpest plane of a sweep; refocused at the screen or twice
  the depth it does not (negative controls), nor at the right depth without the odd rows'
  half-pitch offset;
- each preview frame is the view ``extract`` writes for the viewer's angle, byte for byte.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from povh3d.commands.images import lens_info, refocus_file
from povh3d.renderer.records import base_record, write_image
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.colour import decode, to_linear
from povh3d.image.io import read_png
from povh3d.image.refocus import contact_sheet, lens_steps, shift_and_add
from tests.support import scenes
from tests.support.cli import one_error_line

S, F = 0.1, 1.5                 # pixel pitch, focal length (mm)
PPL, LENSES = 5, (20, 16)       # 5 px lenses: view (2, 2) is the centre view; 104 x 70 px
DEPTH, PERIOD = 7.5, 4.0        # the plane (mm behind the screen) and its texture's period
SWEEP = (0.0, 2 * DEPTH, 5)     # 0, 3.75, 7.5, 11.25, 15 mm
EDGE = 2                        # lenses left out at each border (a shift clamps there)


def hex_array(lenses=LENSES, ppl=PPL) -> LensArray:
    px = ppl * S
    py = px * math.sqrt(3) / 2
    width = math.ceil(lenses[0] * ppl + ppl / 2)
    width += width % 2          # even: the even rows' lens centres sit on pixel centres
    return LensArray("hex", *lenses, px, py, F, Panel(width, math.ceil(lenses[1] * py / S), S, S))


def texture(x, y):
    """The plane's linear-light grey level at ``(x, y)`` mm (the scene's pigment function)."""
    return 0.5 + 0.25 * (np.sin(2 * np.pi * x / PERIOD) + np.sin(2 * np.pi * y / PERIOD))


def write_wave_plane(folder):
    return scenes.write_wave_plane(folder, DEPTH, PERIOD)


@pytest.fixture(scope="module")
def hex_render(tmp_path_factory):
    """The plane rendered through the hex array (point-sampled), its views extracted by the CLI,
    and the refocus sweep: ``(folder, record)``."""
    from tests.support.cli import run_in_process
    from tests.support.render import DRAFT, render

    folder = tmp_path_factory.mktemp("hex")
    render(write_wave_plane(folder), hex_array(), folder / "h.png", settings=DRAFT)
    assert run_in_process("extract", folder / "h.png", "-o", folder / "views").code == 0
    record = refocus_file(folder / "h.png", folder / "sweep.png", lens_info(folder / "h.png", None, None, None, resampled=True),
                          sweep=SWEEP)
    return folder, record


def _plane(folder, n):
    return decode(read_png(folder / f"sweep_{n:03d}.png")).mean(axis=-1)[EDGE:-EDGE, EDGE:-EDGE]


@pytest.mark.povray
def test_refocus_at_the_plane_agrees_with_the_centre_view(hex_render):
    folder, record = hex_render
    depths = record["depths_mm"]
    focus = depths.index(DEPTH)
    centre = decode(read_png(folder / "views" / "v_002_002.png")).mean(axis=-1)[EDGE:-EDGE, EDGE:-EDGE]
    la = hex_array()
    truth = texture(*np.moveaxis(la.lens_centres(), -1, 0))[EDGE:-EDGE, EDGE:-EDGE]
    miss = [float(np.abs(_plane(folder, n) - centre).mean()) for n in range(len(depths))]
    off = [float(np.abs(_plane(folder, n) - truth).max()) for n in range(len(depths))]
    # measured (linear light; the texture swings 0..1): 0.0092 and 0.035 at the plane (the centre
    # view itself is 0.033 off the texture); at the screen 0.037 and 0.127, at twice the depth
    # 0.040 and 0.127
    assert miss[focus] < 0.02 and off[focus] < 0.05, (miss, off)
    for n in (0, len(depths) - 1):                                # negative controls: wrong depths
        assert miss[n] > 2.5 * miss[focus] and off[n] > 2.5 * off[focus], (depths[n], miss, off)
    assert record["sharpest_depth_mm"] == DEPTH, record["gradient_energy"]


@pytest.mark.povray
def test_refocus_needs_the_odd_rows_half_pitch(hex_render):
    """Control: the same views summed as if on a square lattice (no half-pitch offset of the odd
    rows) miss the texture by twice as much at the plane's own depth."""
    folder, _ = hex_render
    la = hex_array()
    image = read_png(folder / "h.png")
    from povh3d.renderer.outputs.views import sidecar_bank

    views = to_linear(sidecar_bank(image, la), np.float32).mean(axis=-1)[..., None]
    steps, used, row_shift = lens_steps(la, views.shape[:2])
    truth = texture(*np.moveaxis(la.lens_centres(), -1, 0))[EDGE:-EDGE, EDGE:-EDGE]
    errors = [np.abs(shift_and_add(views, steps * DEPTH, row_shift=r, used=used)[EDGE:-EDGE, EDGE:-EDGE, 0]
                     - truth).max() for r in (row_shift, 0.0)]
    assert row_shift == 0.5 and errors[0] < 0.05 and errors[1] > 1.5 * errors[0], errors


def _noise_hex(tmp_path):
    la = hex_array((6, 5), 5)
    image = np.random.default_rng(23).integers(0, 256, (la.panel.height, la.panel.width, 3), dtype=np.uint8)
    write_image(tmp_path / "h.png", image, base_record("h3d", la))
    return tmp_path / "h.png", la


def test_preview_frames_are_the_views_extract_writes(tmp_path, cli):
    """A viewer walking left to right past a 5-view hex image sees the middle row's views from
    the rightmost (k = 4) to the leftmost, each one exactly as ``extract`` wrote it."""
    path, la = _noise_hex(tmp_path)
    assert cli("extract", path, "-o", tmp_path / "views").code == 0
    result = cli("preview", path, "--frames", "5", "--scale", "1", "-o", tmp_path / "p.gif")
    assert result.code == 0, result.err
    views = [[read_png(tmp_path / "views" / f"v_{l:03d}_{k:03d}.png") for k in range(5)] for l in range(5)]
    sheet = read_png(tmp_path / "p.png")
    assert np.array_equal(sheet, contact_sheet([views[2][4 - t] for t in range(5)]))
    assert not np.array_equal(sheet, contact_sheet([views[1][4 - t] for t in range(5)]))   # another row
    assert not np.array_equal(sheet, contact_sheet([views[2][t] for t in range(5)]))       # the other way


def test_refocus_of_a_hex_image_accepts_no_contradicting_options(tmp_path, cli):
    path, _ = _noise_hex(tmp_path)
    for args, words in ((["--ppl", "5"], ("--ppl contradicts", "hex lens array")),
                        (["--pixel-pitch", "0.2"], ("--pixel-pitch 0.2 contradicts", "(0.1 mm)"))):
        line = one_error_line(cli("refocus", path, "--depth", "2", *args, "-o", tmp_path / "r.png"))
        assert all(w in line for w in words), line
        assert not (tmp_path / "r.png").exists()
    assert cli("refocus", path, "--depth", "2", "--focal", "2", "-o", tmp_path / "r.png").code == 0
    assert read_png(tmp_path / "r.png").shape[:2] == (5, 6)   # one pixel a lens, as the views


def test_resample_of_a_hex_image_keeps_its_lenses(tmp_path, cli):
    """resample takes a hex image as extract does (tests/renderer/test_resample_any.py holds its oracle);
    the output's sidecar is the same hex lenses at the new pixels per lens."""
    path, la = _noise_hex(tmp_path)
    assert cli("resample", path, "--ppl-out", "3", "-o", tmp_path / "r.png").code == 0
    out = lens_info(tmp_path / "r.png", None, None, None, resampled=True)["lens_array"]
    assert out.grid == "hex" and out.ppl_x == 3 and np.allclose(out.lens_centres(), la.lens_centres())
