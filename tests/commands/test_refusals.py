"""Inputs accepted where they should be refused (issue 38 item 7): object masks of another render,
a sidecar that does not name its image, a calibration number past any display, a mapped panel
that is not the one the render was made for.  Each with its control that is taken."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from povh3d.display.looking_glass import parse_visual
from povh3d.errors import ConfigError, Povh3dWarning
from povh3d.image.io import read_sidecar, write_png
from tests.conftest import SAMPLE
from tests.display.test_looking_glass import PORTRAIT
from tests.support.cli import one_error_line

TINY = ["--preset", "demo", "--lenses", "6x4", "--ppl", "4", "--quality", "draft", "-q"]


@pytest.mark.parametrize("value", [1e308, -1e7])
def test_a_calibration_number_past_any_display_is_refused(value) -> None:
    with pytest.raises(ConfigError, match="'center' is .*beyond"):
        parse_visual({**PORTRAIT, "center": {"value": value}})


def test_a_calibration_of_a_real_unit_is_taken() -> None:   # negative control
    assert parse_visual(PORTRAIT).center == pytest.approx(0.81679)


def test_a_sidecar_without_the_images_digest_is_named(tmp_path) -> None:
    write_png(tmp_path / "a.png", np.zeros((4, 4, 3), np.uint8))
    (tmp_path / "a.json").write_text(json.dumps({"kind": "h3d"}))
    with pytest.warns(Povh3dWarning, match="a.json' has no image_sha256"):
        read_sidecar(tmp_path / "a.png")
    (tmp_path / "a.json").write_text(json.dumps({"kind": "h3d", "image_sha256": "0" * 64}))
    with pytest.raises(Exception, match="describes another image"):   # the digest kept: refused
        read_sidecar(tmp_path / "a.png")


def test_a_sidecar_povh3d_wrote_says_nothing(tmp_path) -> None:   # negative control
    from povh3d.renderer.records import write_image
    write_image(tmp_path / "b.png", np.zeros((4, 4, 3), np.uint8), {"kind": "h3d"})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_sidecar(tmp_path / "b.png")["kind"] == "h3d"


@pytest.mark.povray
def test_masks_of_another_render_with_the_same_lens_array_are_refused(tmp_path, cli) -> None:
    other = tmp_path / "other.pov"
    other.write_text("camera { location <0, 0, -60> look_at 0 }\nlight_source { <0, 50, -80> rgb 1 }\n"
                     "#declare Lone = sphere { 0, 8 pigment { rgb 1 } }\nobject { Lone }\n")
    for scene, name in ((SAMPLE, "a"), (other, "b")):
        result = cli("render", scene, *TINY, "-o", tmp_path / f"{name}.png", "--objects", tmp_path / f"{name}_masks")
        assert result.code == 0, result.err
    line = one_error_line(cli("annotate", tmp_path / "a.png", "--objects", tmp_path / "b_masks",
                              "-o", tmp_path / "x.cdp.xml"), 3)
    assert "another render" in line and "a_masks" in line
    assert not (tmp_path / "x.cdp.xml").exists()
    ok = cli("annotate", tmp_path / "a.png", "--objects", tmp_path / "a_masks", "-o", tmp_path / "y.cdp.xml")
    assert ok.code == 0, ok.err   # negative control: its own masks


@pytest.mark.povray
def test_map_takes_the_panel_the_render_was_made_for(tmp_path, cli) -> None:
    """An alioscopy-42 render's sidecar names its 60x30 panel: map does not guess another from the
    image's size (it wrote 59x90 before); a --panel-size that differs is refused."""
    result = cli("render", SAMPLE, "--preset", "alioscopy-42", "--panel", "60x30", "--quality", "draft", "-q",
                 "-o", tmp_path / "al.png")
    assert result.code == 0, result.err
    assert read_sidecar(tmp_path / "al.png")["display"]["physical_panel"]["size_px"] == [60, 30]
    line = one_error_line(cli("map", tmp_path / "al.png", "--mapping", "alioscopy", "-o", tmp_path / "m.png",
                              "--panel-size", "59x90"), 2)
    assert "60x30 panel" in line
    mapped = cli("map", tmp_path / "al.png", "--mapping", "alioscopy", "-o", tmp_path / "m.png")
    if mapped.code == 0:
        assert read_sidecar(tmp_path / "m.png")["size_px"] == [60, 30]
    else:   # the view-space image of this preset is not the one the mapping reads: refused, not guessed
        assert "60x30 panel" in one_error_line(mapped)
    assert not (tmp_path / "m.png").exists() or read_sidecar(tmp_path / "m.png")["size_px"] == [60, 30]
