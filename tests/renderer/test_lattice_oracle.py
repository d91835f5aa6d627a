"""General lattices (two lattice vectors) rendered by POV-Ray through ``multi-ortho``.

The cross-lenticular sheet of the thesis's section 5.3 (a vertical sheet crossed with
a horizontal one slanted 6.34 degrees, parallelogram cells) and a strongly skewed
lattice, against the analytic checker oracle in front of and behind the screen
(``checker_oracle``: at least 99.5 % of the clear pixels right); the pseudoscopic
image and the unslanted cross sheet (a square grid) are controls that must fail.
A position-coded plane checks every ray to 16-bit precision.
"""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.renderer.methods.registry import METHODS, run_method
from povh3d.errors import ConfigError
from povh3d.geometry.view_bank import stack_shots
from povh3d.geometry.lattice import cross_lenticular_basis
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.display.presets import lens_array_from_fields
from povh3d.geometry.rays import pixel_rays
from povh3d.scene.scene import load_scene

from tests.renderer.test_single_stage import decode_positions, render_linear16, write_position_plane
from tests.support.scenes import checker_oracle, classify, match, write_checker_plane
from tests.support.render import DRAFT

PANEL = Panel(120, 90, 0.1, 0.1)
PERIOD = 2.5
LATTICES = {"cross-6.34": cross_lenticular_basis(0.6, 0.6, 6.34), "skewed": ((0.6, 0.05), (0.3, 0.6))}


def lattice(name: str) -> LensArray:
    """The lattice with as many lenses as cover the panel (the preset rule)."""
    return lens_array_from_fields({"lattice": LATTICES[name], "panel": [120, 90], "pixel_pitch": 0.1, "focal": 1.5})


@pytest.mark.povray
@pytest.mark.parametrize("name", LATTICES)
@pytest.mark.parametrize("z0", [6.0, -6.0], ids=["behind", "in-front"])
def test_lattice_checker_matches_oracle(tmp_path, name, z0):
    la = lattice(name)
    h3d = run_method("multi-ortho", load_scene(write_checker_plane(tmp_path, z0, PERIOD)), la, DRAFT).h3d
    inside = pixel_rays(la)[2]
    assert inside.mean() > 0.99, "test set-up: the lattice should cover the panel"
    assert not h3d[~inside].any(), "pixels outside every lens must stay black"
    expected, clear = checker_oracle(la, z0, PERIOD)
    assert clear.mean() > 0.2, "test set-up: too few pixels clear of pattern edges"
    got = classify(h3d)
    assert match(got, expected, clear) >= 0.995
    pseudo, pclear = checker_oracle(la, z0, PERIOD, pseudoscopic=True)
    assert match(got, pseudo, clear & pclear) < 0.9
    if name.startswith("cross"):  # the same sheets uncrossed by the slant: a square grid
        square = LensArray("square", 20, 15, 0.6, 0.6, 1.5, PANEL)
        upright, uclear = checker_oracle(square, z0, PERIOD)
        assert match(got, upright, clear & uclear) < 0.97


@pytest.mark.povray
@pytest.mark.parametrize("z0", [4.0, -4.0], ids=["behind", "in-front"])
def test_every_lattice_ray_in_povray(tmp_path, z0):
    la, half = lattice("skewed"), 12.0  # code +-12 mm: 16-bit steps of 3.7e-4 mm
    plan = METHODS["multi-ortho"].plan(la, 10.0, np.zeros((1, 4)))
    scene = write_position_plane(tmp_path, z0, half)
    out = render_linear16(plan.batch, "multi-ortho", scene, la)
    hits = decode_positions(plan.batch.context["mesh"].crop(stack_shots(out)), half)
    centres, dirs, inside = pixel_rays(la)
    expected = centres + dirs[..., :2] * (z0 / dirs[..., 2])[..., None]
    err = np.abs(hits - expected)[inside].max()
    assert err < 0.002, f"worst ray {err:.4f} mm off"  # measured 1.7e-4 (the 16-bit step)


def test_single_stage_refuses_a_lattice_in_one_line(tmp_path):
    scene = load_scene(write_checker_plane(tmp_path, 6.0, PERIOD))
    with pytest.raises(ConfigError, match="method multi-ortho"):
        run_method("single-stage", scene, lattice("skewed"), DRAFT)
    with pytest.raises(ConfigError, match="method multi-ortho"):
        run_method("pinhole", scene, lattice("skewed"), DRAFT)


@pytest.mark.povray
def test_cli_renders_a_lattice_and_records_it(tmp_path, cli):
    import json

    out = tmp_path / "out.png"
    scene = write_checker_plane(tmp_path, 6.0, PERIOD)
    assert cli("render", scene, "-o", out, "--quality", "draft", "--panel", "120x90", "--pixel-pitch", "0.1",
               "--lattice", "cross:0.6,6.34", "-q").code == 0
    record = json.loads(out.with_suffix(".json").read_text())["lens_array"]
    assert record["grid"] == "lattice" and record["lattice_mm"][1][0] == 0.0
    from tests.support.cli import one_error_line

    bad = tmp_path / "bad.png"
    line = one_error_line(cli("render", scene, "-o", bad, "--lattice", "cross:0.6,6.34", "--method", "single-stage"))
    assert "multi-ortho" in line and not bad.exists()
