"""``render --dataset`` and ``--depth-maps`` with the viewer inside a solid (issue 38 item 3): a backdrop
``plane { z, 6 }`` is a half-space that holds the viewer, and POV-Ray applies no fog inside a solid, so
the fog depth pass saw nothing there and wrote an all-NaN ground truth with exit 0.  The oracle: two
analytic planes (a box face at z = -2 over the left half, the backdrop at z = 6) give HCI disparity
``-z s / (f p)`` within 0.01 px, the same with and without ``hollow`` on the backdrop (the control)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from povh3d.scene.rewrite import all_hollow
from tests.dataset.test_hci import toolkit_read_pfm

ARRAY = ["--grid", "lenticular", "--lenses", "20", "--ppl", "7", "--rows", "16", "--pixel-pitch", "0.1",
         "--focal", "1.5", "--quality", "draft"]
S, F, P = 0.1, 1.5, 0.7
NEAR, FAR = -2.0, 6.0


def _scene(folder, backdrop):
    path = folder / "backdrop.pov"
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
background {{ rgb 0 }}
light_source {{ <0, 0, -1000> rgb 1 }}
box {{ <-50, -50, {NEAR}>, <0, 50, {NEAR + 1}> pigment {{ rgb 0.5 }} }}
{backdrop}
""")
    return path


BACKDROPS = {"solid": "plane { z, 6 pigment { checker rgb 0.2 rgb 0.6 } }",
             "hollow": "plane { z, 6 pigment { checker rgb 0.2 rgb 0.6 } hollow }"}


@pytest.mark.povray
@pytest.mark.parametrize("kind", ["solid", "hollow"])
def test_two_planes_disparity_with_the_viewer_inside_the_backdrop(tmp_path, cli, kind):
    folder, maps = tmp_path / "hci", tmp_path / "maps"
    result = cli("render", _scene(tmp_path, BACKDROPS[kind]), *ARRAY, "--dataset", folder, "--depth-maps", maps,
                 "-o", tmp_path / "h3d.png")
    assert result.code == 0, result.err
    assert "cannot measure" not in result.err, result.err
    disp = toolkit_read_pfm(folder / "gt_disp_lowres.pfm")
    assert disp.shape == (16, 20) and np.isfinite(disp).all()
    near, far = -NEAR * S / (F * P), -FAR * S / (F * P)
    assert np.abs(disp[:, :9] - near).max() < 0.01      # lenses 0-8: x < 0, the box's face
    assert np.abs(disp[:, 11:] - far).max() < 0.01      # lenses 11-19: the backdrop
    assert json.loads((maps / "depth_maps.json").read_text())["nan_fraction"] == 0.0
    # and from the render and its sidecar afterwards (povh3d dataset): the same ground truth
    result = cli("dataset", tmp_path / "h3d.png", "-o", tmp_path / "again")
    assert result.code == 0 and "cannot measure" not in result.err, result.err
    assert np.array_equal(toolkit_read_pfm(tmp_path / "again" / "gt_disp_lowres.pfm"), disp)


def test_all_hollow_reaches_top_level_objects_only():
    text = ('#declare P = plane { z, 1 }\n// plane { z, 2 }\nplane { z, 6 pigment { rgb 1 } }\n'
            'union { sphere { 0, 1 } object { P } }\n#declare S = "box {";\nlight_source { 0 rgb 1 }\n')
    out = all_hollow(text)
    assert out.count("hollow") == 2
    assert "plane { z, 6 pigment { rgb 1 }  hollow }" in out and "object { P }  hollow }" in out
    assert "#declare P = plane { z, 1 }\n" in out and "light_source { 0 rgb 1 }" in out
    assert all_hollow("plane { z, 6 ") == "plane { z, 6 "       # unbalanced: left as it is


@pytest.mark.povray
def test_a_solid_the_copy_cannot_reach_is_a_named_warning(tmp_path, cli):
    """The backdrop in an include of another folder (--include) is not copied: rays start inside it,
    unmeasured; said by name, never a silent NaN file."""
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "backdrop.inc").write_text(BACKDROPS["solid"] + "\n")
    scene = _scene(tmp_path, '#include "backdrop.inc"')
    folder = tmp_path / "hci"
    result = cli("render", scene, *ARRAY, "--include", lib, "--dataset", folder, "-o", tmp_path / "h3d.png")
    assert result.code == 0, result.err
    assert "cannot measure" in result.err and "hollow" in result.err, result.err
    assert "all NaN" in result.err and "gt_disp_lowres.pfm" in result.err, result.err
    assert np.isnan(toolkit_read_pfm(folder / "gt_disp_lowres.pfm")).all()
