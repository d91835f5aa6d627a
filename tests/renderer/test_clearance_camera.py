"""Rays never start behind the scene's camera: a wall just behind it, which the 2D render cannot see,
stays out of the H3D image for every method and with --fit-depth, unless --front-clearance asks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.povray   # every test renders

ARRAY = ("--preset", "demo", "--quality", "draft", "-q")
# The camera 10 units out, a red wall 0.3 units behind it (its front face toward the camera),
# a white sphere at the look_at point.  multi-ortho's view bank rounded 0.9 of the camera's
# distance (39.6 mm) up to 48 mm, 10.9 units out: behind the wall, which then filled the image.
SCENE = """#version 3.7;
camera { location <0, 0, -10> angle 40 right x*image_width/image_height look_at <0, 0, 0> }
light_source { <5, 5, -20> rgb 1 }
box { <-1000, -1000, -10.5>, <1000, 1000, -10.3> pigment { rgb <1, 0, 0> } finish { ambient 1 diffuse 0 } }
sphere { 0, 1 pigment { rgb 1 } }
"""


def red_share(path) -> float:
    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.int32)
    return float(((rgb[..., 0] > 200) & (rgb[..., 1] < 60)).mean())


@pytest.mark.parametrize("extra", [
    ("--method", "multi-ortho"),
    ("--method", "multi-ortho", "--fit-depth", "auto"),
    ("--method", "multi-ortho", "--fit-depth", "auto", "--depth-scale"),
    ("--method", "multi-ortho-views"),
    ("--method", "single-stage"),
])
def test_a_wall_behind_the_camera_stays_out(cli, tmp_path, extra):
    scene = tmp_path / "wall.pov"
    scene.write_text(SCENE)
    out = tmp_path / "w.png"
    result = cli("render", str(scene), "-o", str(out), *ARRAY, *extra)
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    frame = record["placement"]
    distance_mm = 10 / frame["units_per_mm"]
    used = record["quality"]["front_clearance_mm"]
    assert used <= 0.9 * distance_mm * (1 + 1e-9)
    reason = record["quality"]["front_clearance_reason"]
    assert "scene camera" in reason or (extra[1] == "single-stage" and reason == "the method's default")
    assert f"rays from {used:.4g} mm" in result.out
    assert red_share(out) < 0.01


def test_an_explicit_front_clearance_may_pass_the_camera(cli, tmp_path):
    """Negative control: asked for, rays start behind the camera and the wall fills the image."""
    scene = tmp_path / "wall.pov"
    scene.write_text(SCENE)
    out = tmp_path / "w.png"
    result = cli("render", str(scene), "-o", str(out), *ARRAY, "--front-clearance", "200")
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["quality"]["front_clearance_mm"] >= 200
    assert red_share(out) > 0.9


NEAR = """#version 3.7;
camera { location <0, 0, -10> angle 40 right x*image_width/image_height look_at <0, 0, 0> }
light_source { <5, 5, -20> rgb 1 }
sphere { <0, 0, -6>, 1 pigment { rgb 1 } }
sphere { 0, 1 pigment { rgb 1 } }
"""


def test_a_foreground_cut_by_the_clearance_is_one_warning(cli, tmp_path):
    """single-stage's lens array moves in 24 mm steps: within the camera's 39.6 mm it starts rays at 24 mm,
    and the sphere 6 units out (about 31 mm) is cut; multi-ortho starts at 39.6 mm and cuts nothing."""
    scene = tmp_path / "near.pov"
    scene.write_text(NEAR)
    cut = cli("render", str(scene), "-o", str(tmp_path / "s.png"), *ARRAY, "--method", "single-stage")
    assert cut.code == 0, cut.err
    lines = [line for line in cut.err.splitlines() if "foreground" in line]
    assert len(lines) == 1 and "rays start at z = -24 mm" in lines[0] and "--method multi-ortho" in lines[0]
    record = json.loads((tmp_path / "s.json").read_text())
    assert any("foreground" in w for w in record["placement"]["warnings"])
    whole = cli("render", str(scene), "-o", str(tmp_path / "m.png"), *ARRAY)   # negative control
    assert whole.code == 0 and "foreground" not in whole.err, whole.err


def test_a_camera_nearer_than_one_view_bank_step_is_traced_through_a_lens_mesh(cli, tmp_path):
    """A 120-degree camera stands 9.2 mm from the demo display: 0.9 of it is under the view bank's 12 mm
    step, so multi-ortho traces a lens mesh from 8.3 mm (the bank had rounded up, behind the camera)."""
    scene = tmp_path / "wide.pov"
    scene.write_text(SCENE.replace("angle 40", "angle 120"))
    out = tmp_path / "w.png"
    result = cli("render", str(scene), "-o", str(out), *ARRAY, "--quality", "normal")
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    used = record["quality"]["front_clearance_mm"]
    assert used == pytest.approx(0.9 * 32 / (2 * np.tan(np.radians(60))), rel=1e-9)
    assert "lens mesh" in record["quality"]["front_clearance_reason"]
    assert red_share(out) < 0.01
