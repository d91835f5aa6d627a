"""Replay of mapped panels through their real slanted lenticules (renderer/replay.py with ``subpixels``):
the panel as its R, G, B stripes behind the sheet its mapping addresses, against the slits of the NumPy
replay (display/replay.py).  Every panel here codes the view of each subpixel (``view_codes``), so the
view each lens shows is read from the picture; each figure has a negative control that fails it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from povh3d.display import presets
from povh3d.display.display import build_display
from povh3d.display.looking_glass import DEVICES
from povh3d.display.mappings.looking_glass_shader import view_fractions
from povh3d.display.quilt import default_viewing_distance
from povh3d.display.replay import (decode_views, device_sheet, device_slots_at, label_centre_offset,
                                   lens_picture_agreement, mapped_sheet, replay, sheet_slots, view_codes)
from povh3d.renderer.records import base_record, write_image
from povh3d.renderer.replay import render_replay

pytestmark = pytest.mark.povray

DESIGN_MM = {"alioscopy-42": 805.0, "philips-20": 800.0}


def small(preset: str, mapping: str, options: dict | None = None):
    """The preset's mapped panel cut to 120 x 60 (alioscopy) or 160 x 80 (philips) pixels: its sheet, the
    view of every subpixel, and the display."""
    width = {"alioscopy-42": 120, "philips-20": 160}[preset]
    d = build_display(preset, {"panel": (width, width // 2)}, mapping=mapping, mapping_options=options)
    sheet, shift, views = mapped_sheet(d.mapping, d.mapped_panel, d.lens_array.focal)
    return d, sheet, shift, views


@pytest.mark.parametrize("preset, mapping, options", [
    ("alioscopy-42", "alioscopy", {}),
    ("philips-20", "philips", {"offset": 2.0}),
])
def test_lenticules_show_each_lens_the_slits_view(preset: str, mapping: str, options: dict) -> None:
    """A 960 x 480 picture through the spherical lenticules (index 1.49) from 30 mm off-centre at the design
    distance: each lens (a lenticule over a row, and over the mapping's 3D pixel) shows the view the slits
    show it, their mean views within half a view, on >= 99 % of lenses away from boundaries (the slits'
    landing points in one slot).  Negative controls: the slits half a pitch over, and the views reversed."""
    d, sheet, shift, views = small(preset, mapping, options)
    n, k = d.mapping.views, d.mapping.rows_per_view
    slots = sheet_slots(sheet, shift, label_centre_offset(sheet, shift, views, n), n)
    codes = view_codes(views)
    eye = np.array([30.0, 0.0, -DESIGN_MM[preset]])
    size = (960, 480)
    pictures, timings = render_replay(codes, sheet, eye[None], size=size, shift=shift, subpixels=True)
    seen = decode_views(pictures[0])
    assert (seen >= 0).mean() > 0.95  # lit: one channel a subpixel, coding its view
    slit = replay(codes, sheet, eye, optics="barrier", size=size, shift=shift, subpixels=True)
    for rows in (1, k):
        rep = lens_picture_agreement(seen, slit, n, slots, rows, sheet=(sheet, shift))
        assert rep["measured"] > 0.95 * rep["lenses"], rep
        assert rep["same_view_share"] >= 0.99 and rep["mean_view_gap"][1] < 0.25, rep
        # per pixel the edges of a lenticule (spherical aberration) differ most; its middle agrees
        assert rep["pixels_same_view_share_across"][0] > 0.97, rep
    over = replay(codes, sheet, eye, optics="barrier", size=size, shift=shift + sheet.pitch_x / 2, subpixels=True)
    assert lens_picture_agreement(seen, over, n, slots, k)["same_view_share"] < 0.3
    rev = replay(view_codes(n - 1 - views), sheet, eye, optics="barrier", size=size, shift=shift, subpixels=True)
    assert lens_picture_agreement(seen, rev, n, slots, k)["same_view_share"] < 0.3


def test_portrait_lenticules_agree_with_the_slits_on_their_middle() -> None:
    """A Portrait native image through spherical lenticules of its pitch and effective focal length (f/1.4),
    the eye centred at 654 mm: in the middle fifth of every lenticule the picture shows the slits' view on
    >= 97 % of pixels; toward the edges the lenslet's spherical aberration lands rays views away (under 5 %
    the same view in the outer tenth).  Negative control: the slits half a pitch over."""
    dev = DEVICES["looking-glass-portrait"]
    cal, n = dev.calibration, dev.views
    focal = presets.lens_array(dev.name).focal
    D = default_viewing_distance(cal.size_mm[1])
    sheet, shift, _, _ = device_sheet(cal, focal, D)
    codes = view_codes(np.minimum((view_fractions(cal) * n).astype(np.int64), n - 1))
    eye = np.array([0.0, 0.0, -D])
    size = (300, 400)
    pictures, _ = render_replay(codes, sheet, eye[None], size=size, shift=shift, subpixels=True)
    seen = decode_views(pictures[0])

    def slots(p: np.ndarray) -> np.ndarray:
        return device_slots_at(cal, p, n)

    slit = replay(codes, sheet, eye, optics="barrier", size=size, shift=shift, subpixels=True)
    bands = lens_picture_agreement(seen, slit, n, slots, 7, sheet=(sheet, shift))["pixels_same_view_share_across"]
    assert bands[0] >= 0.97 and bands[4] < 0.05, bands
    over = replay(codes, sheet, eye, optics="barrier", size=size, shift=shift + sheet.pitch_x / 2, subpixels=True)
    assert lens_picture_agreement(seen, over, n, slots, 7, sheet=(sheet, shift))["pixels_same_view_share_across"][0] < 0.2


def test_command_replays_a_mapped_panel_through_lenticules(tmp_path: Path, cli) -> None:
    """`povh3d replay --optics lens` on a mapped panel: the picture through its lenticules and, with `--json`,
    each eye's lenses against the slits (a row and the 3D pixel); `--size lenses` is refused in one line."""
    d, sheet, shift, views = small("alioscopy-42", "alioscopy", {"offset": 3.0})
    path = tmp_path / "panel.png"
    write_image(path, view_codes(views).astype(np.uint16), {**base_record("panel"), **d.as_record()})
    r = cli("replay", str(path), "--optics", "lens", "--size", "480x240", "--eye", "20,0,-805",
            "-o", str(tmp_path / "lens.png"), "--json", str(tmp_path / "r.json"))
    assert r.code == 0, r.err
    rep = json.loads((tmp_path / "r.json").read_text())["eyes"][0]
    against = rep["lenses_against_slits"]
    assert against["3d_pixel"]["aperture_rows"] == 3 and against["a_row"]["same_view_share"] >= 0.98, against
    assert rep["aperture_3d_pixel"]["away_mean_view_share"] >= 0.99
    r = cli("replay", str(path), "--optics", "lens", "-o", str(tmp_path / "lenses.png"))
    assert r.code != 0 and "--size" in r.err and len(r.err.strip().splitlines()) == 1
    assert not (tmp_path / "lenses.png").exists()
