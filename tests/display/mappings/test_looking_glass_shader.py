"""The quilt -> native mapping against a naive per-subpixel reading of the vendor's shader.

The oracle below is written from the shader's formula (Bridge's ``Lenticular_RGBA_With_Aspect``,
nearest-view mode) one subpixel at a time, with scalar math and the shader's own route to the
texel: a quilt texture coordinate, scaled by ``viewPortion``, read at the nearest texel.  It
shares no code with ``quilt_to_native``.  It is checked on a Portrait-size panel at 200,000
seeded random subpixels (a full scalar loop over 9.4 million subpixels takes minutes).

At the end: the view ``quilt_to_native`` gives every subpixel against the one POV-Ray traced for
it, ``render --method subpixel --calibration visual.json`` read back from a direction-coding sky.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from povh3d.display.looking_glass import DEVICES, Calibration
from povh3d.display.mappings.looking_glass_shader import quilt_to_native

SAMPLES = 200_000


def naive_subpixel(quilt, cols, rows, cal: Calibration, row, col, c, *, slope_sign=1.0):
    w, h = cal.screen_w, cal.screen_h
    hq, wq = quilt.shape[:2]
    n = cols * rows
    slope = cal.slope * slope_sign
    pitch = cal.pitch * w / cal.dpi * math.cos(math.atan(1.0 / slope))
    tilt = h / (w * slope) * (-1.0 if cal.flip_x else 1.0)
    uvx = (col + 0.5) / w
    uvy = 1.0 - (row + 0.5) / h
    if cal.subpixel_cells:
        xpos, ypos = int(uvx * w), int(uvy * h)
        mode = cal.cell_pattern
        cell = {0: 0, 1: 0 if (xpos % 2 == ypos % 2) else 1, 2: xpos % 2,
                3: (ypos + (xpos % 2) * 2) % 4, 4: ypos % 2}[mode]
        x = uvx + cal.subpixel_cells[cell][2 * c] / w
        y = uvy + cal.subpixel_cells[cell][2 * c + 1] / h
    else:
        x = uvx + c / (3.0 * w)
        y = uvy
    a = (x + y * tilt) * pitch - cal.center
    view = a - math.floor(a)
    if cal.inv_view:
        view = 1.0 - view
    view = min(max(view, 0.00001), 0.999999)
    index = min(int(view * n), n - 1)
    tx, ty = index % cols, index // cols
    tu = 1.0 - uvx if cal.flip_x else uvx
    tv = 1.0 - uvy if cal.flip_y else uvy
    portion_x, portion_y = cols * (wq // cols) / wq, rows * (hq // rows) / hq
    qu = (tx + tu) / cols * portion_x
    qv = (ty + tv) / rows * portion_y
    texel_x = min(int(qu * wq), wq - 1)
    texel_y = min(int(qv * hq), hq - 1)          # counted from the bottom
    return quilt[hq - 1 - texel_y, texel_x, c]


def agreement(native, quilt, grid, cal, samples=SAMPLES, **kw):
    rng = np.random.default_rng(23)
    rows = rng.integers(0, cal.screen_h, samples)
    cols = rng.integers(0, cal.screen_w, samples)
    chans = rng.integers(0, 3, samples)
    expect = np.array([naive_subpixel(quilt, *grid, cal, r, c, ch, **kw) for r, c, ch in zip(rows, cols, chans)])
    return float(np.mean(native[rows, cols, chans] == expect))


@pytest.fixture(scope="module")
def portrait_quilt():
    d = DEVICES["looking-glass-portrait"]
    w, h = d.quilt_size
    return np.random.default_rng(0).integers(0, 256, (h, w, 3), np.uint8)


@pytest.fixture(scope="module")
def portrait_native(portrait_quilt):
    d = DEVICES["looking-glass-portrait"]
    return quilt_to_native(portrait_quilt, d.grid, d.calibration)


def test_portrait_native_matches_the_naive_shader(portrait_quilt, portrait_native):
    d = DEVICES["looking-glass-portrait"]
    assert portrait_native.shape == (2048, 1536, 3)
    assert agreement(portrait_native, portrait_quilt, d.grid, d.calibration) >= 0.999


def test_negative_control_flipped_slope_fails(portrait_quilt, portrait_native):
    d = DEVICES["looking-glass-portrait"]
    assert agreement(portrait_native, portrait_quilt, d.grid, d.calibration, slope_sign=-1.0) < 0.999


@pytest.mark.parametrize("change", [
    {"flip_x": True}, {"flip_y": True}, {"inv_view": False},
    {"cell_pattern": 4, "subpixel_cells": DEVICES["looking-glass-16-portrait"].calibration.subpixel_cells},
    {"cell_pattern": 2, "subpixel_cells": DEVICES["looking-glass-16-landscape"].calibration.subpixel_cells},
])
def test_flips_inversion_and_gen3_cells_match_the_naive_shader(change):
    # a smaller panel keeps the scalar oracle quick; a 65-view grid with padding (the 65" layout)
    cal = replace(DEVICES["looking-glass-portrait"].calibration, screen_w=300, screen_h=200, **change)
    quilt = np.random.default_rng(1).integers(0, 256, (9 * 40 + 2, 8 * 50, 3), np.uint8)
    native = quilt_to_native(quilt, (8, 9), cal)
    plain = quilt_to_native(quilt, (8, 9), replace(DEVICES["looking-glass-portrait"].calibration,
                                                     screen_w=300, screen_h=200))
    assert agreement(native, quilt, (8, 9), cal, samples=40_000) >= 0.999
    assert np.mean(native != plain) > 0.5        # the field changes the picture


def test_bilinear_equals_nearest_on_a_flat_tile():
    cal = replace(DEVICES["looking-glass-portrait"].calibration, screen_w=120, screen_h=160)
    quilt = np.repeat(np.repeat(np.arange(48, dtype=np.uint8).reshape(6, 8)[::-1] * 5, 30, 0), 20, 1)
    quilt = np.dstack([quilt] * 3)
    near = quilt_to_native(quilt, (8, 6), cal)
    bil = quilt_to_native(quilt, (8, 6), cal, sampling="bilinear")
    assert np.array_equal(near, bil)
    # tile t holds 5 t: the native value is 5 x the view the shader picks
    assert set(np.unique(near) // 5) <= set(range(48))


def test_view_index_agrees_with_the_view_space_slanted_mapping():
    """Cross-check with an independent implementation: display.mappings.slanted's van Berkel form of the
    same calibration, fed a view-space image whose every view is its own index."""
    from povh3d.display.mappings.looking_glass_shader import slanted_mapping, view_fractions

    cal = DEVICES["looking-glass-portrait"].calibration
    n = 48
    m = slanted_mapping(cal, n)
    rows, cols = m.source((cal.screen_w, cal.screen_h)).shape[:2]
    image = np.broadcast_to((np.arange(cols) % n).astype(np.uint8)[None, :, None], (rows, cols, 3))
    mapped = m.apply(np.ascontiguousarray(image), (cal.screen_w, cal.screen_h))
    shader = np.minimum((view_fractions(cal) * n).astype(np.int64), n - 1)
    assert np.mean(mapped == shader) >= 0.999
    flipped = np.minimum((view_fractions(replace(cal, slope=-cal.slope)) * n).astype(np.int64), n - 1)
    assert np.mean(mapped == flipped) < 0.999             # negative control


def test_view_space_mapping_reports_what_it_ignores():
    from povh3d.errors import Povh3dWarning
    from povh3d.display.mappings.looking_glass_shader import slanted_mapping

    with pytest.warns(Povh3dWarning, match="flipImageX"):
        slanted_mapping(replace(DEVICES["looking-glass-portrait"].calibration, flip_x=True), 48)


# -- against a measured pattern: ``render --method subpixel --calibration visual.json`` --------------
# A tiny panel under a Portrait-like sheet (slope -7, 48 views), its every subpixel traced by
# POV-Ray.  The scene is a sky whose grey level codes the ray's direction across the lenticule,
# so each subpixel's traced position across its lenticule (its view) is read back from its own
# channel.  docs/displays.md: the render puts a subpixel's centre half a subpixel past the phase
# the shader gives it (the phase of its left edge), so that phase is the traced one less half a
# subpixel; the shader's view fraction is one minus it (invView).
LG_PANEL, LG_PIXEL, LG_FOCAL = (150, 100), 0.1, 1.0
LG_PITCH_PX, LG_SLANT, LG_CENTER, LG_VIEWS, LG_GRID = 4.37, -8.13, 0.37, 48, (8, 6)
LG_CODE = 2.0                  # grey = 0.5 + LG_CODE * (ray across the lenticule) / (ray along z)
BOUNDARY = 0.01                # views: a subpixel this near a view boundary may show either view


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """The rendered panel's subpixels as shader view fractions ``(H, W, 3)`` (0..views), and the
    calibration the render read."""
    from povh3d.display.looking_glass import read_visual
    from povh3d.image.colour import decode
    from povh3d.image.io import read_png
    from tests.cli.test_subpixel_calibration import looking_glass_file
    from tests.support.cli import run_in_process

    folder = tmp_path_factory.mktemp("lg")
    cal = looking_glass_file(folder / "visual.json", LG_PANEL, LG_PIXEL, LG_PITCH_PX, LG_SLANT, LG_CENTER, inv=1)
    t = math.radians(LG_SLANT)
    scene = folder / "sky.pov"
    scene.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
sky_sphere {{ pigment {{ function {{ 0.5 + {LG_CODE!r} * (x * {math.cos(t)!r} + y * {math.sin(t)!r}) / z }}
                        color_map {{ [0 rgb 0] [1 rgb 1] }} }} }}
""")
    out = folder / "panel.png"
    result = run_in_process("render", scene, "--method", "subpixel", "--calibration", cal, "--panel",
                            "%dx%d" % LG_PANEL, "--pixel-pitch", LG_PIXEL, "--focal", LG_FOCAL, "--quality", "draft",
                            "--bit-depth", "16", "--no-cache", "-o", out)
    assert result.code == 0, result.err
    u = (decode(read_png(out)) - 0.5) / LG_CODE * LG_FOCAL            # mm across the lenticule
    traced = u / (LG_PITCH_PX * LG_PIXEL) + 0.5                          # 0..1 across it
    per_lens = 3 * LG_PITCH_PX / math.cos(t)                             # subpixels along a row
    edge = traced - 0.5 / per_lens
    return ((1.0 - edge) % 1.0) * LG_VIEWS, read_visual(cal)


def _shader_views(cal):
    """The view ``quilt_to_native`` lights every subpixel with: tile ``t`` of the quilt is ``5 t``."""
    cols, rows = LG_GRID
    tiles = (np.arange(LG_VIEWS).reshape(rows, cols)[::-1] * 5).astype(np.uint8)   # view 0 bottom left
    return quilt_to_native(np.repeat(tiles[..., None], 3, axis=-1), LG_GRID, cal) // 5


@pytest.mark.povray
def test_every_traced_subpixel_shows_the_view_the_shader_gives_it(measured):
    fraction, cal = measured
    boundary = np.abs(fraction - np.rint(fraction)) < BOUNDARY
    shown = np.floor(fraction).astype(np.int64) % LG_VIEWS
    shader = _shader_views(cal)
    assert shader.shape == (LG_PANEL[1], LG_PANEL[0], 3)
    # measured: 2.0 % of the 45,000 subpixels lie within 0.01 view of a boundary; every other
    # one shows the shader's view; the traced fraction is the shader's to 0.001 view
    assert boundary.mean() < 0.025
    assert np.array_equal(shown[~boundary], shader[~boundary])
    from povh3d.display.mappings.looking_glass_shader import view_fractions

    miss = (fraction - view_fractions(cal) * LG_VIEWS + LG_VIEWS / 2) % LG_VIEWS - LG_VIEWS / 2
    assert np.abs(miss).max() < 0.005


@pytest.mark.povray
@pytest.mark.parametrize("change", [{"center": LG_CENTER + 1 / LG_VIEWS}, {"center": LG_CENTER + 0.25},
                                    {"pitch": 25.4 / LG_PIXEL / LG_PITCH_PX * 1.01}])
def test_negative_control_a_wrong_centre_or_pitch_fails(measured, change):
    fraction, cal = measured
    boundary = np.abs(fraction - np.rint(fraction)) < BOUNDARY
    shown = np.floor(fraction).astype(np.int64) % LG_VIEWS
    wrong = _shader_views(replace(cal, **change))
    assert np.mean(shown[~boundary] == wrong[~boundary]) < 0.1    # measured: 0 %, 0 %, 5.4 %
