"""Mesh models as users have them: z up, in metres, far from the origin (issue 13)."""

from __future__ import annotations

import pytest
import json

import numpy as np

from povh3d.image.interleave import extract
from povh3d.image.io import read_png
from tests.support.gallery_meshes import planet_stl, tower_ply

pytestmark = pytest.mark.povray  # every test here starts POV-Ray

ARRAY = ("--grid", "square", "--lenses", "24x18", "--ppl", "6x6", "--pixel-pitch", "0.2", "--focal", "2")


def _centre_view(path, ny=6, nx=6):
    views = extract(read_png(path), (ny, nx))
    return views[ny // 2, nx // 2].astype(int)


def _object_mask(view):
    grey = np.abs(view - view[0, 0]).max(axis=-1) > 10   # the stage's grey background in a corner
    return grey


def test_z_up_tower_stands_upright_and_says_why(cli, tmp_path):
    model = tower_ply(tmp_path)
    result = cli("render", str(model), "-o", str(tmp_path / "t.png"), "--quality", "draft", *ARRAY)
    assert result.code == 0, result.err
    assert "up z (detected" in result.out
    mask = _object_mask(_centre_view(tmp_path / "t.png"))
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    assert np.ptp(rows) > 1.3 * np.ptp(cols)          # taller than wide: seen from the front, not from above
    # The foot reaches right (+x of the file stays right): lowest rows extend further right.
    assert np.flatnonzero(mask[rows.max()]).max() > np.flatnonzero(mask[rows.min()]).max()
    # Negative control: taken as y up, the tower is seen from above (a square-ish top).
    cli("render", str(model), "-o", str(tmp_path / "y.png"), "--quality", "draft", "--up", "y", *ARRAY)
    mask_y = _object_mask(_centre_view(tmp_path / "y.png"))
    ry, cy = np.flatnonzero(mask_y.any(axis=1)), np.flatnonzero(mask_y.any(axis=0))
    assert np.ptp(ry) < 1.3 * np.ptp(cy)


def test_planet_in_metres_far_away_fills_the_panel(cli, tmp_path):
    model = planet_stl(tmp_path)
    out = tmp_path / "p.png"
    result = cli("render", str(model), "-o", str(out), "--quality", "draft", *ARRAY)
    assert result.code == 0, result.err
    assert "flat colour" not in result.err
    mask = _object_mask(_centre_view(out))
    rows = np.flatnonzero(mask.any(axis=1))
    assert np.ptp(rows) + 1 >= 0.8 * mask.shape[0]        # the disc fills ~90 % of the height
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["model"]["fit"]["limit"] == "height"


def test_an_empty_image_is_a_warning(cli, tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text("#version 3.7;\nbackground { rgb 0.2 }\nsphere { <0, 0, 0>, 1 pigment { rgb 1 } }\n")
    result = cli("render", str(scene), "-o", str(tmp_path / "e.png"), "--quality", "draft",
                 "--display-center", "100,0,0", "--display-normal", "1,0,0", "--display-width", "5", *ARRAY)
    assert result.code == 0 and "no ray hit anything" in result.err
    hit = cli("render", str(scene), "-o", str(tmp_path / "h.png"), "--quality", "draft",
              "--display-center", "0,0,0", "--display-normal", "1,0,0", "--display-width", "5", *ARRAY)
    assert hit.code == 0 and "no ray hit anything" not in hit.err     # negative control
