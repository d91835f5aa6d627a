"""``povh3d render --method subpixel --calibration FILE``: the calibrated sheet, traced exactly.

Oracles:
- the render and ``map --mapping slanted --calibration`` read one file as one sheet: every
  subpixel has the same position across its lenticule (to 1e-9) and the same lenticule (up to
  one constant renumbering) under the sheet the render traces as under the mapping's formula;
- the truth of a synthetic white image (known pitch, slant and phase) comes back through
  ``calibrate`` -> file -> the render's sheet within the issue's calibration tolerances;
- the rays POV-Ray traced hit an emissive plane coding x and y where the Looking Glass
  shader's own lenticule coordinate (``display.mappings.slanted.looking_glass``) says they should;
- bad calibrations: one line, non-zero exit, nothing written.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from povh3d.commands.calibration import calibrate_lenticular_file
from povh3d.display.display import mapping_for_display
from povh3d.cli.main import build_parser
from povh3d.cli.options import display_from_args
from povh3d.cli.render import request_from_args
from povh3d.display.calibrated_sheet import calibrated_sheet
from povh3d.renderer.methods.registry import METHODS
from povh3d.display.subpixel import sheet_phase, subpixel_array, subpixel_image
from povh3d.errors import ConfigError
from povh3d.geometry.lens_array import Panel
from povh3d.geometry.phase_tiles import phase_tiles
from povh3d.image.colour import decode, encode
from povh3d.image.io import read_png, write_png
from tests.renderer.test_single_stage import write_position_plane
from tests.geometry.test_rotated_lattice import simulate_lookup
from tests.support.cli import one_error_line
from tests.support.synth import render_lenticular_white

ALIOSCOPY = ("--preset", "alioscopy-42", "--panel", "60x30")
PLAIN = ("--panel", "60x30", "--pixel-pitch", "0.1", "--focal", "1.0")  # the demo preset's square array


def looking_glass_file(path, size, pixel_mm, pitch_px, slant_deg, center, inv=0, **extra):
    """A Looking Glass ``visual.json`` (values wrapped as the device writes them) of a sheet."""
    dpi = 25.4 / pixel_mm
    t = math.radians(slant_deg)
    fields = {"pitch": dpi / pitch_px, "slope": 1 / math.tan(t), "center": center, "invView": inv, "DPI": dpi,
              "screenW": size[0], "screenH": size[1], **extra}
    path.write_text(json.dumps({k: {"value": v} for k, v in fields.items()}))
    return path


def pixel_file(path, size, pitch_px, slant_deg, phase_px, **extra):
    """A ``povh3d calibrate --lattice lenticular`` file without the Looking Glass fields."""
    path.write_text(json.dumps({"kind": "lenticular", "pitch_px": pitch_px, "slant_deg": slant_deg,
                                "phase_px": phase_px, "k1": 0.0, "image_size": list(size), **extra}))
    return path


def render_sheet(scene, *args):
    """The sheet, its shift and the display record ``povh3d render --method subpixel ARGS`` traces."""
    parsed = build_parser().parse_args(["render", str(scene), "--method", "subpixel", *map(str, args)])
    request = request_from_args(parsed)
    return request.display.lens_array, request.method_options["sheet_shift_mm"], request.display


def files(tmp_path):
    """(name, calibration path, CLI display args) of several sheets near the displays' own."""
    yield "alioscopy visual.json", looking_glass_file(tmp_path / "a.json", (60, 30), 0.4845, 2.5298 * 1.004,
                                                      18.2, 0.27), ALIOSCOPY
    yield "alioscopy invView", looking_glass_file(tmp_path / "b.json", (60, 30), 0.4845, 2.5298 * 0.997,
                                                  18.5, 0.91, inv=1), ALIOSCOPY
    yield "pixel file", pixel_file(tmp_path / "c.json", (60, 30), 4.37, 11.3, -1.62), PLAIN
    yield "pixel file, negative slant", pixel_file(tmp_path / "d.json", (60, 30), 5.9, -7.2, 2.4), PLAIN


def test_render_and_map_address_one_sheet(tmp_path):
    scene = write_position_plane(tmp_path, 4.0)
    for name, path, display_args in files(tmp_path):
        sheet, shift, display = render_sheet(scene, *display_args, "--calibration", path)
        parsed = build_parser().parse_args(["render", str(scene), *display_args])
        mapping, panel = mapping_for_display("slanted", display_from_args(parsed), calibration=path, views=7)
        assert display.sheet["mapping_offset"] == pytest.approx(mapping.offset, abs=1e-9), name
        lens, across = sheet_phase(sheet, shift)
        m_lens, _, frac = mapping.phases((panel.width, panel.height))
        centre = (frac * mapping.per_lens / mapping.views + 0.5) / mapping.per_lens  # the mapping's, 0..1
        assert np.abs((centre - across + 0.5) % 1 - 0.5).max() < 1e-9, name
        # One lenticule each: the two numberings differ by one constant where no centre sits on a border.
        clear = np.abs(centre - 0.5) < 0.5 - 1e-6
        assert np.unique((lens - m_lens)[clear]).size == 1, name
        # Control: the centred sheet (no shift) is not the calibrated one.
        _, across0 = sheet_phase(sheet, 0.0)
        assert np.abs((centre - across0 + 0.5) % 1 - 0.5).max() > 1e-3 or abs(shift) < 1e-9, name


def test_both_files_of_one_sheet_are_one_mapping(tmp_path):
    """The pixel file and the same sheet in Looking Glass fields (``calibrate --dpi``) agree."""
    white = render_lenticular_white((240, 160), 9.37, 9.46, 0.4, noise=0.01)
    png = tmp_path / "white.png"
    write_png(png, encode(np.clip(np.repeat(white[..., None], 3, 2), 0, 1), np.uint16))
    with_lg = calibrate_lenticular_file(png, tmp_path / "lg.json", dpi=254.0)
    plain = calibrate_lenticular_file(png, tmp_path / "px.json")
    assert "pitch" in with_lg and "pitch" not in plain
    panel = Panel(240, 160, 0.1, 0.1)
    a, sa, _ = calibrated_sheet(with_lg, panel, 1.0)
    b, sb, _ = calibrated_sheet(plain, panel, 1.0)
    assert (a.pitch_x, a.rotation, a.lenses_x) == pytest.approx((b.pitch_x, b.rotation, b.lenses_x), rel=1e-12)
    assert sa == pytest.approx(sb, abs=1e-9)
    # A center half a pixel off its phase_px (as an older calibrate wrote it) contradicts the file.
    t = math.radians(with_lg["slant_deg"])
    assert set(with_lg["center"]) == {"value"}  # written the vendor's way
    stale = {**with_lg, "center": (with_lg["center"]["value"] - 0.5 * math.cos(t) / with_lg["pitch_px"]) % 1}
    with pytest.raises(ConfigError, match="contradicts itself: center"):
        calibrated_sheet(stale, panel, 1.0)


@pytest.mark.slow
@pytest.mark.parametrize("pitch,slant,phase", [(9.37, 9.46, 0.31), (7.71, 18.43, -1.7), (12.3, -6.34, 2.2)])
def test_calibrate_then_render_recovers_the_sheet(tmp_path, pitch, slant, phase):
    size, pixel_mm = (800, 600), 0.2   # the calibration tests' size: smaller ones fit the phase less well
    white = render_lenticular_white(size, pitch, slant, phase, k1=0.02, vignetting=0.3, noise=0.02)
    png = tmp_path / "white.png"
    write_png(png, encode(np.clip(np.repeat(white[..., None], 3, 2), 0, 1), np.uint16))
    record = calibrate_lenticular_file(png, tmp_path / "cal.json")
    sheet, shift, _ = calibrated_sheet(json.loads((tmp_path / "cal.json").read_text()),
                                       Panel(*size, pixel_mm, pixel_mm), 1.0)
    assert record["kind"] == "lenticular"
    assert abs(sheet.pitch_x / (pitch * pixel_mm) - 1) < 1e-4
    assert abs(sheet.rotation - slant) < 0.01
    # The true axes lie at lattice x = (phase + m pitch) px (calibration.lenticular conventions);
    # the sheet's at (n + 1/2 - Lx/2) pitch + shift.
    axis = (0.5 - sheet.lenses_x / 2) * sheet.pitch_x + shift
    miss = ((axis / pixel_mm - phase) / pitch + 0.5) % 1 - 0.5
    assert abs(miss * pitch) < 0.02
    # And every subpixel centre sits where the truth puts it across its lenticule (to 0.02 px).
    sub_x = (np.arange(3 * size[0]) + 0.5) / 3 - size[0] / 2
    sub_y = size[1] / 2 - np.arange(size[1]) - 0.5
    t = math.radians(slant)
    across_true = ((np.cos(t) * sub_x[None, :] + np.sin(t) * sub_y[:, None] - phase) / pitch + 0.5) % 1
    _, across = sheet_phase(sheet, shift)
    assert np.abs((across - across_true + 0.5) % 1 - 0.5).max() * pitch < 0.02


@pytest.mark.povray
def test_povray_traces_the_calibrated_rays(cli, tmp_path):
    """Every red subpixel shows the x, every green one the y, where its ray from the Looking Glass
    shader's lenticule coordinate meets an emissive plane (a sheet neither centred nor rational)."""
    z0, half, size, pixel_mm, focal = 3.0, 12.0, (60, 30), 0.1, 1.0
    pitch_px, slant, center = 4.37, 11.3, 0.37
    cal = looking_glass_file(tmp_path / "visual.json", size, pixel_mm, pitch_px, slant, center)
    scene = write_position_plane(tmp_path, z0, half)
    out = tmp_path / "panel.png"
    result = cli("render", scene, "--method", "subpixel", "--calibration", cal, *PLAIN, "--quality", "draft",
                 "--bit-depth", "16", "--no-cache", "-o", out)
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["display"]["sheet"]["from_calibration"] and record["subpixel"]["sheet_shift_mm"] != 0
    coded = decode(read_png(out)) * 2 * half - half
    worst = _worst(coded, size, pixel_mm, focal, z0, pitch_px, slant, center)
    assert worst < 0.01, f"worst subpixel {worst:.4f} mm off"
    # Control: the same sheet a quarter lenticule across (another phase) misses by far more.
    assert _worst(coded, size, pixel_mm, focal, z0, pitch_px, slant, center + 0.25) > 10 * worst


@pytest.mark.povray
def test_the_python_api_makes_the_calibrated_render(tmp_path):
    """``povh3d.render(..., method="subpixel", calibration=FILE)``: the same calibrated sheet as the
    command line's, through the one display builder (same oracle and control as above)."""
    import povh3d

    z0, half, size, pixel_mm, focal = 3.0, 12.0, (60, 30), 0.1, 1.0
    pitch_px, slant, center = 4.37, 11.3, 0.37
    cal = looking_glass_file(tmp_path / "visual.json", size, pixel_mm, pitch_px, slant, center)
    scene = write_position_plane(tmp_path, z0, half)
    out = tmp_path / "api.png"
    array = povh3d.presets.lens_array("demo", panel=list(size), pixel_pitch=pixel_mm, focal=focal)
    record = povh3d.render(scene, out, lens_array=array, method="subpixel", calibration=cal, quality="draft",
                           bit_depth=16, use_cache=False)
    assert record["display"]["sheet"]["from_calibration"] and record["subpixel"]["sheet_shift_mm"] != 0
    coded = decode(read_png(out)) * 2 * half - half
    worst = _worst(coded, size, pixel_mm, focal, z0, pitch_px, slant, center)
    assert worst < 0.01, f"worst subpixel {worst:.4f} mm off"
    assert _worst(coded, size, pixel_mm, focal, z0, pitch_px, slant, center + 0.25) > 10 * worst


def _worst(coded, size, pixel_mm, focal, z0, pitch_px, slant, center):
    """Worst miss (mm) of the red x and green y against the rays of the Looking Glass shader.

    The shader: ``a = (x + y / slope) * lenses / W - center``, x from the left, y up (pixels),
    read for a subpixel half a pixel right of its left edge and taken (van Berkel's ``floor``)
    as the phase of that edge: the sheet's lenticule coordinate at ``x`` is ``a(x + 1/2)``, an
    axis where its fraction is 1/2 (docs/displays.md).  A subpixel ``u`` mm across (along
    ``n``) sees along ``normalize(u n, f)`` through the axis beside it (docs/geometry.md)."""
    w, h = size
    t = math.radians(slant)
    lenses = w * math.cos(t) / pitch_px
    x = (np.arange(3 * w) + 0.5) / 3
    y = h - np.arange(h) - 0.5
    a = (x[None, :] + 0.5 + y[:, None] * math.tan(t)) * lenses / w - center
    u = (a - np.floor(a) - 0.5) * pitch_px * pixel_mm
    n = np.array([math.cos(t), math.sin(t)])
    px = np.stack(np.broadcast_arrays((x[None, :] - w / 2) * pixel_mm, (y[:, None] - h / 2) * pixel_mm), -1)
    hit = px - u[..., None] * n + u[..., None] * n * (z0 / focal)
    clear = np.abs(a - np.floor(a) - 0.5) < 0.45          # not beside a lenticule border (a tie)
    err_x = np.abs(coded[..., 0] - hit[:, 0::3, 0])[clear[:, 0::3]]
    err_y = np.abs(coded[..., 1] - hit[:, 1::3, 1])[clear[:, 1::3]]
    return max(err_x.max(), err_y.max())


@pytest.mark.parametrize("make, args, words", [
    (lambda p: p.write_text(json.dumps({"kind": "povh3d-lens-grid", "lattice": "square", "pitch_px": 8.0})),
     ALIOSCOPY, "square lens grid"),
    (lambda p: looking_glass_file(p, (60, 30), 0.4845, 2.5298 * 1.05, 18.43, 0.2), ALIOSCOPY, "not this display's"),
    (lambda p: looking_glass_file(p, (60, 30), 0.4845, 2.5298, 14.0, 0.2), ALIOSCOPY, "not this display's"),
    (lambda p: looking_glass_file(p, (64, 30), 0.4845, 2.5298, 18.43, 0.2), ALIOSCOPY, "60x30"),
    (lambda p: looking_glass_file(p, (60, 30), 0.3, 2.5298, 18.43, 0.2), ALIOSCOPY, "--pixel-pitch"),
    (lambda p: p.write_text(json.dumps({"pitch": 50.0, "slope": 3.0, "DPI": 52.4, "screenW": 60, "screenH": 30})),
     ALIOSCOPY, "lacks 'center'"),
    (lambda p: p.write_text(json.dumps({"kind": "lenticular", "slant_deg": 11.3, "phase_px": 0.2,
                                        "image_size": [60, 30]})), PLAIN, "'pitch_px'"),
    (lambda p: p.write_text(json.dumps({**json.loads(looking_glass_file(p, (60, 30), 0.4845, 2.53, 18.43, 0.2)
                                                      .read_text()), "slant_deg": 17.0})), ALIOSCOPY,
     "contradicts itself"),
    (lambda p: p.write_text("{not json"), ALIOSCOPY, "not JSON"),
])
def test_bad_calibrations_are_refused(cli, tmp_path, make, args, words):
    scene = write_position_plane(tmp_path, 4.0)
    path = tmp_path / "cal.json"
    make(path)
    out = tmp_path / "x.png"
    line = one_error_line(cli("render", scene, "--method", "subpixel", "--calibration", path, *args, "-o", out))
    assert words in line and not out.exists() and not out.with_suffix(".json").exists()


def test_a_calibration_without_a_sheet_to_give_is_refused(cli, tmp_path):
    scene = write_position_plane(tmp_path, 4.0)
    cal = pixel_file(tmp_path / "c.json", (60, 30), 4.37, 11.3, -1.6)
    out = tmp_path / "x.png"
    line = one_error_line(cli("render", scene, "--calibration", cal, *PLAIN, "-o", out))
    assert "--method subpixel" in line and not out.exists()


@pytest.mark.parametrize("rational", [True, False])
def test_every_calibrated_ray_through_the_lookup(tmp_path, rational):
    """POV-Ray's mesh-camera lookup, simulated in NumPy, gives every subpixel the ray of the
    position across its lenticule that the mapping's formula gives it (docs/geometry.md: through
    the lenticule's axis beside it, along ``normalize(R(u, 0), f)``), to 1e-9: the phase tiles of
    a rational calibrated sheet and the strips of an irrational one, both moved across."""
    scene = write_position_plane(tmp_path, 4.0)
    if rational:  # Alioscopy's own pitch and slant (8 subpixels a row, tan a = 1/3), a calibrated phase
        path = looking_glass_file(tmp_path / "r.json", (60, 30), 0.4845, 8 / math.sqrt(10),
                                  math.degrees(math.atan(1 / 3)), 0.61)
        display_args = ALIOSCOPY
    else:
        path, display_args = pixel_file(tmp_path / "i.json", (60, 30), 4.37, 11.3, -1.62), PLAIN
    sheet, shift, _ = render_sheet(scene, *display_args, "--calibration", path)
    parsed = build_parser().parse_args(["render", str(scene), *display_args])
    mapping, panel = mapping_for_display("slanted", display_from_args(parsed), calibration=path, views=5)
    sub = subpixel_array(sheet)
    tiles = phase_tiles(sub)
    assert (tiles is not None) == rational and shift != 0
    mesh = METHODS["subpixel"].plan(sheet, 10.0, np.zeros((1, 4)), sheet_shift_mm=shift).batch.context["mesh"]
    origin, normal, _ = (subpixel_image(mesh, tiles, [a]) for a in simulate_lookup(mesh))
    # The oracle: the mapping's phase of every subpixel centre, in mm across its lenticule.
    _, _, frac = mapping.phases((panel.width, panel.height))
    u = ((frac * mapping.per_lens / mapping.views + 0.5) / mapping.per_lens - 0.5) * sheet.pitch_x
    t = math.radians(sheet.rotation)
    n = np.array([math.cos(t), math.sin(t)])
    xs, ys = np.meshgrid(*sub.panel.pixel_centres())
    axis = np.stack([xs, ys], -1) - u[..., None] * n
    dirs = np.concatenate([u[..., None] * n, np.full(u.shape + (1,), sheet.focal)], -1)
    dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
    clear = np.abs(u) < 0.5 * sheet.pitch_x * (1 - 1e-6)        # not a centre on a lenticule border
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    np.testing.assert_allclose(d[clear], dirs[clear], atol=1e-9)
    reach = -origin[..., 2] / d[..., 2]
    np.testing.assert_allclose((origin[..., :2] + reach[..., None] * d[..., :2])[clear], axis[clear], atol=1e-9)
