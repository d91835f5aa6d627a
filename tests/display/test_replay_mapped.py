"""Replay of mapped panels and Looking Glass images (display/replay.py, commands/replay.py): the
mapping rebuilt from the sidecar's options, the view each lens shows over its aperture, and a
Looking Glass native image or quilt through the device's sheet.

Every panel here is written by the mapping (or the vendor's shader) from views that code their own
index, so the view a replayed lens shows is read from the image itself; each figure has a negative
control that fails it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from povh3d.commands.replay import sidecar_mapping
from povh3d.display import presets
from povh3d.display.display import Display, build_display
from povh3d.display.looking_glass import DEVICES, visual_json, with_overrides
from povh3d.display.mappings.looking_glass_shader import quilt_to_native, view_fractions
from povh3d.display.quilt import default_viewing_distance
from povh3d.display.replay import (aperture_views, device_report, device_sheet, label_centre_offset,
                                   mapped_sheet)
from povh3d.errors import Povh3dWarning
from povh3d.image.io import read_png
from povh3d.renderer.records import base_record, write_image

# Design viewing distances (mm).  Philips 20": the thesis's "Optimal viewing distance: 80 cm" (4.6.1).
# Alioscopy 42": the thesis gives none; 805 mm is where its adjacent views lie one eye separation
# (65 mm) apart with the preset's geometry: 65 f / (lens pitch / N) = 65 x 2.0 / 0.1615.
DESIGN_MM = {"alioscopy-42": 805.0, "philips-20": 800.0}
LENSES = 3000  # lenses measured an eye (a seeded sample)


def coded_panel(display: Display) -> np.ndarray:
    """The physical panel the display's mapping writes from view images whose every pixel codes its view
    ``v`` as ``10 + 20 v`` (the view-space array's column ``col`` is view ``col % N``)."""
    p = display.render_array.panel
    n = display.mapping.views
    views = np.broadcast_to((10 + 20 * (np.arange(p.width) % n))[None, :, None], (p.height, p.width, 3))
    panel = display.mapped_panel
    return display.mapping.apply(views.astype(np.uint8), (panel.width, panel.height))


def decoded(image: np.ndarray) -> np.ndarray:
    return (image.astype(np.int64) - 10) // 20


def zone_eye(sheet, views: int, v: int, distance: float) -> tuple[float, float, float]:
    """An eye at ``distance`` in the middle of view ``v``'s zone for the centre lens (``v``-th N-th of a
    lenticule seen through its axis: ``x = -(v + 1/2 - N/2) (p / N) D / f``)."""
    return (-(v + 0.5 - views / 2) * sheet.pitch_x / views * distance / sheet.focal, 0.0, -distance)


# -- 1. the mapping's options in the sidecar ----------------------------------------------------------------
def test_sidecar_rebuilds_a_mapping_with_other_options(tmp_path: Path, cli) -> None:
    """A panel written with `--mapping alioscopy --offset 3` (the sheet 3 subpixels over): its sidecar records
    every parameter, replay rebuilds that mapping, and over each lens's aperture the view read from the image
    is the one pointing at the eye on >= 99 % of lenses.  Negative control: the same sidecar without the options
    (an older render) replays the preset's default mapping (a warning naming it) and the views are wrong."""
    d = build_display("alioscopy-42", mapping="alioscopy", mapping_options={"offset": 3.0})
    panel = coded_panel(d)
    path = tmp_path / "panel.png"
    record = {**base_record("panel"), **d.as_record()}
    assert record["display"]["mapping_options"]["offset"] == 3.0
    write_image(path, panel, record)
    side = json.loads(path.with_suffix(".json").read_text())
    mapping, focal = sidecar_mapping(Display.from_record(side), path)
    assert mapping == d.mapping
    D = DESIGN_MM["alioscopy-42"]

    def share(m) -> float:
        sheet, shift, views = mapped_sheet(m, d.mapped_panel, focal)
        offset = label_centre_offset(sheet, shift, views, m.views)  # the rebuilt mapping's own, not the image's
        eye = zone_eye(sheet, 8, 2, D)
        return aperture_views(sheet, shift, decoded(panel), eye, 8, offset=offset, lenses=LENSES)["dominant_view_share"]

    assert share(mapping) >= 0.99
    old = {**side, "display": {k: v for k, v in side["display"].items() if k != "mapping_options"}}
    with pytest.warns(Povh3dWarning, match="default 'alioscopy'"):
        default, _ = sidecar_mapping(Display.from_record(old), path)
    assert default.offset == 0.0 and share(default) < 0.2
    # through the command: the report's apertures, and the warning for the older sidecar
    r = cli("replay", str(path), "--eye", "0,0,-805", "-o", str(tmp_path / "eye.png"), "--json", str(tmp_path / "r.json"))
    assert r.code == 0, r.err
    rep = json.loads((tmp_path / "r.json").read_text())["eyes"][0]
    assert rep["aperture"]["dominant_view_share"] >= 0.99 and rep["aperture_3d_pixel"]["aperture_rows"] == 3
    path.with_suffix(".json").write_text(json.dumps(old))
    r = cli("replay", str(path), "--eye", "0,0,-805", "-o", str(tmp_path / "eye2.png"))
    assert r.code == 0 and "without its options" in r.err and "'alioscopy'" in r.err


def test_damaged_mapping_options_are_one_line(tmp_path: Path) -> None:
    from povh3d.errors import ConfigError

    d = build_display("philips-20", mapping="philips")
    side = json.loads(json.dumps(d.as_record()))
    side["display"]["mapping_options"]["views"] = "nine"
    with pytest.raises(ConfigError, match="mapping options are damaged"):
        sidecar_mapping(Display.from_record(side), tmp_path / "x.png")
    side["display"]["mapping_options"] = {"kind": "Nothing"}
    with pytest.raises(ConfigError, match="no mapping class"):
        sidecar_mapping(Display.from_record(side), tmp_path / "x.png")


# -- 2. the view each lens shows over its aperture, at the design distance ------------------------------------
@pytest.mark.parametrize("preset, mapping, options", [
    ("alioscopy-42", "alioscopy", {}),
    ("alioscopy-42", "alioscopy", {"offset": 3.0}),
    ("alioscopy-42", "alioscopy", {"reverse": True}),
    ("philips-20", "philips", {}),
    ("philips-20", "philips", {"offset": 2.0}),
    ("philips-20", "philips", {"reverse": True}),
])
def test_every_view_is_seen_from_its_eye_positions(preset: str, mapping: str, options: dict) -> None:
    """The issue's figure: every view v of a panel mapped from view-coded images, the eye at the design
    distance in the middle of v's slot (for the centre lens; the sheet does not converge, so the other
    lenses' landing points fall anywhere in their own slots).  Over each lens's 3D pixel (a lenticule over
    the mapping's rows per view row, 8 x 32 samples), on the lenses farther than half the aperture's
    element (a subpixel over its rows) from a view boundary, the centre of the views read from the image
    is the view of the eye's slot on >= 99 % of lenses, and lies within 0.05 view of the eye's place
    in its slot on 99 % of all lenses measured.  One row: the rule counts no lens (a slot is one
    subpixel wide or less, and every subpixel along a row is its own view).  Negative controls: the
    views reversed, and the slots judged half a view over."""
    d = build_display(preset, mapping=mapping, mapping_options=options)
    labels = decoded(coded_panel(d))
    sheet, shift, views = mapped_sheet(d.mapping, d.mapped_panel, d.lens_array.focal)
    assert np.array_equal(labels, views)  # the mapping writes each subpixel the view mapped_sheet says
    n, k = d.mapping.views, d.mapping.rows_per_view
    offset = label_centre_offset(sheet, shift, views, n)
    assert offset[1] == bool(options.get("reverse"))  # the views run the way the mapping says
    D = DESIGN_MM[preset]
    judged: set[int] = set()
    for v in range(n):
        eye = zone_eye(sheet, n, v, D)
        row = aperture_views(sheet, shift, labels, eye, n, offset=offset, lenses=LENSES, seed=v)
        assert row["away_from_boundaries"] == 0 and row["dominant_within_one_view_share"] >= 0.999, (v, row)
        rep = aperture_views(sheet, shift, labels, eye, n, offset=offset, rows=k, lenses=LENSES, seed=v)
        assert rep["away_from_boundaries"] > 0.5 * rep["measured"] > 0.3 * rep["lenses"], (v, rep)
        assert rep["away_mean_view_share"] >= 0.99 and rep["mean_view_error"][1] < 0.05, (v, rep)
        assert rep["dominant_view_share"] >= 0.98, (v, rep)  # the commonest view too, on all measured
        judged.update(rep["away_views"])
    assert judged == set(range(n))
    eye = zone_eye(sheet, n, 1, D)
    reversed_ = aperture_views(sheet, shift, n - 1 - labels, eye, n, offset=offset, rows=k, lenses=LENSES)
    assert reversed_["away_mean_view_share"] < 0.5
    half = aperture_views(sheet, shift, labels, eye, n, offset=(offset[0] + 0.5, offset[1]), rows=k, lenses=LENSES)
    assert half["away_mean_view_share"] < 0.7


# -- 3. a Looking Glass native image and quilt through the device's sheet ------------------------------------
PORTRAIT = DEVICES["looking-glass-portrait"]


def coded_quilt(device) -> np.ndarray:
    """The device's quilt whose tile ``q`` (vendor view q, from the bottom left) is all ``q + 1`` (16 bit)."""
    cols, rows = device.grid
    tw, th = device.tile_size
    quilt = np.zeros((device.quilt_size[1], device.quilt_size[0], 3), np.uint16)
    for q in range(device.views):
        r, c = divmod(q, cols)
        top = device.quilt_size[1] - (r + 1) * th
        quilt[top:top + th, c * tw:(c + 1) * tw] = q + 1
    return quilt


def lg_eye(cal, q: int, distance: float) -> tuple[float, float, float]:
    """An eye at ``distance`` in the middle of view ``q``'s zone: the view fraction ``(q + 1/2) / N`` of the
    cone seen through the lenticule (``tan = (fraction - 1/2) 2 tan(cone / 2)``)."""
    n = PORTRAIT.views
    t = ((q + 0.5) / n - 0.5) * 2 * math.tan(math.radians(cal.view_cone) / 2)
    return (distance * t, 0.0, -distance)


def test_looking_glass_native_image_shows_each_eye_its_slot_view() -> None:
    """The issue's figure on a Portrait native image (the vendor's shader over a view-coded quilt), through
    the device's sheet converging at the vendor's viewer (654 mm): the eye in the middle of view q's slot
    in the shader's phase, every lens's 7-row aperture (the slope's period) shows views centred on q
    (the eye's slot at every landing point) on >= 99 % of lenses away from boundaries, at the edge views
    too (their neighbour across the lobe counted as the next view); within one view on a row.  The
    vendor's camera for view q is q there.  Negative controls: the camera's own position of an edge view
    (the cameras step the cone in N - 1 steps, the slots in N: it stands on a slot boundary, so every
    lens straddles it), a native image written with the slope's sign flipped, and the views reversed."""
    cal = PORTRAIT.calibration
    n = PORTRAIT.views
    native = quilt_to_native(coded_quilt(PORTRAIT), PORTRAIT.grid, cal, views=n)
    labels = native[..., :3].astype(np.int64) - 1
    assert np.array_equal(labels, np.minimum((view_fractions(cal) * n).astype(np.int64), n - 1))
    focal = presets.lens_array("looking-glass-portrait").focal
    D = default_viewing_distance(cal.size_mm[1])
    assert D == pytest.approx(653.8, abs=0.1)
    for q in (*range(0, n, 5), 1, n - 2, n - 1):
        eye = lg_eye(cal, q, D)
        rep = device_report(cal, labels, eye, n, focal, D, cal.view_cone, lenses=LENSES, rows=7)
        assert rep["camera_view"] == q and math.floor(rep["eye_slot"]) == q, (q, rep)
        assert rep["away_from_boundaries"] > 0.75 * rep["lenses"] and rep["away_views"] == [q], (q, rep)
        assert rep["away_mean_view_share"] >= 0.99 and rep["mean_view_error"][1] < 0.15, (q, rep)
        row = device_report(cal, labels, eye, n, focal, D, cal.view_cone, lenses=LENSES)
        assert row["away_from_boundaries"] == 0 and row["dominant_within_one_view_share"] >= 0.99, (q, row)
    for q in (0, n - 1):  # the vendor camera's own position: on the slot boundary
        angle = math.radians((q / (n - 1) - 0.5) * cal.view_cone)
        rep = device_report(cal, labels, (D * math.tan(angle), 0.0, -D), n, focal, D, cal.view_cone,
                            lenses=LENSES, rows=7)
        assert rep["camera_view"] == q and rep["measured"] == 0 and rep["straddling_a_view_boundary"] > 0.75 * LENSES
    eye = lg_eye(cal, 24, D)
    flipped = with_overrides(cal, slope=-cal.slope)
    wrong = quilt_to_native(coded_quilt(PORTRAIT), PORTRAIT.grid, flipped, views=n)[..., :3].astype(np.int64) - 1
    rep = device_report(cal, wrong, eye, n, focal, D, cal.view_cone, lenses=LENSES, rows=7)
    assert rep["away_mean_view_share"] < 0.5
    rep = device_report(cal, n - 1 - labels, lg_eye(cal, 5, D), n, focal, D, cal.view_cone, lenses=LENSES, rows=7)
    assert rep["away_mean_view_share"] < 0.05


def write_device_files(tmp_path: Path, with_device: bool = True) -> tuple[Path, Path]:
    """A device render's files as the renderer writes them (renderer/outputs/device_quilt.py): the H3D's
    sidecar naming the device and calibration, the quilt and the native image."""
    cal_path = tmp_path / "visual.json"
    cal_path.write_text(visual_json(PORTRAIT.calibration))
    h3d = tmp_path / "scene.png"
    spec = {"device": PORTRAIT.name, "calibration": str(cal_path), "camera_model": "perspective"}
    write_image(h3d, np.zeros((4, 4, 3), np.uint8),
                {**base_record("h3d"), "display": {"preset": PORTRAIT.name, **({"quilt": spec} if with_device else {})}})
    quilt = coded_quilt(PORTRAIT)
    quilt_path = tmp_path / "scene_qs8x6a0.75.png"
    write_image(quilt_path, quilt, base_record("quilt", grid=list(PORTRAIT.grid), views=PORTRAIT.views,
                                               source=str(h3d.resolve())))
    native_path = tmp_path / "scene_native.png"
    write_image(native_path, quilt_to_native(quilt, PORTRAIT.grid, PORTRAIT.calibration, views=PORTRAIT.views),
                base_record("panel", mapping="looking-glass-shader", calibration=str(cal_path),
                            size_px=[1536, 2048], source=str(h3d.resolve())))
    return native_path, quilt_path


def test_command_replays_a_native_image_and_a_quilt(tmp_path: Path, cli) -> None:
    native, quilt = write_device_files(tmp_path)
    cal = PORTRAIT.calibration
    D = default_viewing_distance(cal.size_mm[1])
    eye = lg_eye(cal, 30, D)
    outs = []
    for src, name in ((native, "n"), (quilt, "q")):
        r = cli("replay", str(src), "--eye", ",".join(f"{v:.4f}" for v in eye), "-o", str(tmp_path / f"{name}.png"),
                "--json", str(tmp_path / f"{name}.json"))
        assert r.code == 0, r.err
        assert "camera view 30" in r.out
        rep = json.loads((tmp_path / f"{name}.json").read_text())["eyes"][0]
        assert rep["aperture"]["camera_view"] == 30 and rep["aperture"]["dominant_within_one_view_share"] >= 0.99
        outs.append(read_png(tmp_path / f"{name}.png"))
    assert np.array_equal(outs[0], outs[1])  # the quilt is replayed as the native image its shader makes
    seen = outs[0][..., :3].max(axis=-1).astype(np.int64) - 1  # one channel lit, coding its view
    lit = seen >= 0
    assert lit.mean() > 0.8 and (np.abs(seen[lit] - 30) <= 1).mean() > 0.9  # point samples: most within one view


def test_a_quilt_without_its_device_is_refused(tmp_path: Path, cli) -> None:
    _, quilt = write_device_files(tmp_path, with_device=False)
    r = cli("replay", str(quilt), "-o", str(tmp_path / "eye.png"))
    assert r.code != 0 and "without its Looking Glass device" in r.err and len(r.err.strip().splitlines()) == 1
    assert not (tmp_path / "eye.png").exists()


def test_device_sheet_converges_at_the_viewer() -> None:
    """Through the device's sheet every lenticule shows the centred eye at 654 mm the middle of the cone
    (view fraction 1/2 at every landing point); the panel's own sheet (no convergence) drifts across the
    screen by ``W f / (D p)`` lenticules: many views (the negative control)."""
    from povh3d.display.replay import device_views_at, replay as rp

    cal = PORTRAIT.calibration
    focal = presets.lens_array("looking-glass-portrait").focal
    D = default_viewing_distance(cal.size_mm[1])
    lens, lshift, panel_sheet, pshift = device_sheet(cal, focal, D)
    h = np.zeros((cal.screen_h, cal.screen_w, 3), np.uint8)
    for sheet, shift, ok in ((lens, lshift, True), (panel_sheet, pshift, False)):
        r = rp(h, sheet, (0.0, 0.0, -D), optics="barrier", shift=shift, subpixels=True)
        land = r.landing[r.pixel[..., 0] >= 0]
        v = device_views_at(cal, land, PORTRAIT.views)
        spread = np.ptp(v)
        assert (spread <= 1) if ok else (spread > 5), spread


@pytest.mark.povray
def test_a_render_with_another_offset_is_replayed_through_its_own_sheet(tmp_path: Path, cli) -> None:
    """`povh3d render --preset alioscopy-42 --mapping alioscopy --offset 3` (a small panel) records the mapping's
    every parameter; replay rebuilds it (no warning) and its report's apertures show the right view."""
    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "ali.png"
    r = cli("render", str(root / "sample_models" / "sample.pov"), "--preset", "alioscopy-42", "--panel", "240x120",
            "--mapping", "alioscopy", "--offset", "3", "--quality", "draft", "-o", str(out))
    assert r.code == 0, r.err
    side = json.loads(out.with_suffix(".json").read_text())
    assert side["display"]["mapping_options"]["offset"] == 3.0 and side["display"]["mapping_options"]["kind"] == "Slanted"
    r = cli("replay", str(out), "--eye", "0,0,-805", "-o", str(tmp_path / "eye.png"), "--json", str(tmp_path / "r.json"))
    assert r.code == 0 and "warning" not in r.err, r.err
    rep = json.loads((tmp_path / "r.json").read_text())["eyes"][0]
    assert rep["aperture"]["dominant_view_share"] >= 0.99 and rep["aperture"]["measured"] > 1000
