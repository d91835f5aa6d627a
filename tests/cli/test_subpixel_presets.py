"""``povh3d render --preset alioscopy-42|philips-20 --method subpixel``: the slanted sheet of the
preset's mapping, traced subpixel by subpixel straight to the panel image.

Oracles:
- the sheet is the mapping's own: with the offset the sidecar records, the mapping's phase
  formula (``display.mappings.slanted``) puts every subpixel where the sheet does (to 1e-9);
- every subpixel's ray (docs/geometry.md) through POV-Ray's lookup simulated in NumPy (to 1e-9);
- the rendered panel of an emissive plane coding x (red) and y (green): each red subpixel shows
  the x, each green one the y, where its own ray hits the plane; one ray per pixel (the
  control) misses by far more.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from povh3d.display.display import build_display, mapping_for_display
from povh3d.renderer.methods.registry import METHODS
from povh3d.display.subpixel import slanted_sheet, subpixel_array
from povh3d.geometry.phase_tiles import phase_tiles
from povh3d.geometry.rays import pixel_rays
from povh3d.image.colour import decode
from povh3d.image.io import read_png

from tests.renderer.test_single_stage import write_position_plane
from tests.geometry.test_rotated_lattice import simulate_lookup

PRESETS = pytest.mark.parametrize("preset", ["alioscopy-42", "philips-20"])
PANEL = (60, 30)


def _sheet(preset: str):
    display = build_display(preset, {"panel": PANEL})
    mapping, panel = mapping_for_display(display.mapping_name, display)
    return mapping, panel, display.lens_array, display


@PRESETS
def test_the_sheet_is_the_mappings(preset):
    mapping, panel, la, display = _sheet(preset)
    sheet, offset = slanted_sheet(mapping, panel, la.focal)
    shifted, _ = mapping_for_display(mapping.name, display, offset=offset or None)
    _, _, frac = shifted.phases((panel.width, panel.height))
    sub = subpixel_array(sheet)
    x, _ = sub.to_lattice(*np.meshgrid(*sub.panel.pixel_centres()))
    t = x / sheet.pitch_x + sheet.lenses_x / 2
    across = t - np.floor(t + 1e-9)                        # the centre, 0..1 across its lens
    from_mapping = (frac * mapping.per_lens / mapping.views + 0.5) / mapping.per_lens
    assert np.abs((from_mapping - across + 0.5) % 1 - 0.5).max() < 1e-9
    # Control: the mapping without the offset puts the sheet elsewhere.
    _, _, frac0 = mapping.phases((panel.width, panel.height))
    assert offset and np.abs(frac0 - frac).max() > 0.5


@PRESETS
def test_every_subpixel_ray_through_the_lookup(preset):
    mapping, panel, la, _ = _sheet(preset)
    sheet, _ = slanted_sheet(mapping, panel, la.focal)
    tiles = phase_tiles(subpixel_array(sheet))
    assert tiles is not None  # the thesis's sheets are rational: one quad per phase coset
    mesh = METHODS["subpixel"].plan(sheet, 50.0, np.zeros((1, 4))).batch.context["mesh"]
    origin, normal, _ = (tiles.to_panel(a[1:, :-1]) for a in simulate_lookup(mesh))
    centres, dirs, inside = pixel_rays(subpixel_array(sheet))
    assert inside.all()
    d = normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    np.testing.assert_allclose(d, dirs, atol=1e-9)
    t = -origin[..., 2] / d[..., 2]
    np.testing.assert_allclose(origin[..., :2] + t[..., None] * d[..., :2], centres, atol=1e-9)


@pytest.mark.povray
@PRESETS
def test_render_writes_the_panel_from_every_subpixels_ray(cli, tmp_path, preset):
    z0, half = 4.0, 20.0
    scene = write_position_plane(tmp_path, z0, half)
    out = tmp_path / "panel.png"
    result = cli("render", str(scene), "--preset", preset, "--method", "subpixel", "--panel", "x".join(map(str, PANEL)),
                 "--quality", "draft", "--bit-depth", "16", "--no-cache", "-o", str(out))
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["method"] == "subpixel" and "mapping" not in record.get("kind", "")
    mapping, panel, la, _ = _sheet(preset)
    sheet, offset = slanted_sheet(mapping, panel, la.focal)
    assert record["display"]["sheet"]["mapping_offset"] == pytest.approx(offset)
    assert record["lens_array"]["rotation_deg"] == pytest.approx(sheet.rotation)
    image = decode(read_png(out))
    assert image.shape == (PANEL[1], PANEL[0], 3)
    centres, dirs, _ = pixel_rays(subpixel_array(sheet))
    hit = centres + dirs[..., :2] * (z0 / dirs[..., 2])[..., None]      # (H, 3W, 2)
    coded = image * 2 * half - half
    x_red, y_green = hit[:, 0::3, 0], hit[:, 1::3, 1]
    err = max(np.abs(coded[..., 0] - x_red).max(), np.abs(coded[..., 1] - y_green).max())
    assert err < 0.01, f"worst subpixel {err:.4f} mm off"
    # Control: every subpixel of a pixel on the green one's ray.
    assert np.abs(coded[..., 0] - hit[:, 1::3, 0]).max() > 10 * err


@pytest.mark.parametrize("extra, words", [(("--mapping", "alioscopy"), "drop --mapping"),
                                          (("--offset", "1"), "drop --offset")])
def test_subpixel_refuses_a_mapping_of_its_own(cli, tmp_path, extra, words):
    scene = write_position_plane(tmp_path, 4.0)
    result = cli("render", str(scene), "--preset", "alioscopy-42", "--method", "subpixel", "--panel", "24x12",
                 "-o", str(tmp_path / "x.png"), *extra)
    assert result.code != 0 and words in result.err and len(result.err.strip().splitlines()) == 1
    assert not (tmp_path / "x.png").exists()
