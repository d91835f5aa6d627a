"""Stitching captures taken a whole number of lenses apart (thesis 4.5), and the calibration CLI.

Captures are made by povh3d itself: moving the camera by ``s`` lenses is
rendering the scene translated by ``-s`` lens pitches (emissive scene, so
nothing but geometry moves).  Two overlapping renders must stitch into
exactly the render of the wider camera.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.support.render import DRAFT, render
from povh3d.calibration.gridfile import write_grid
from povh3d.calibration.lattice import calibrate
from povh3d.calibration.stitch import find_shift, stitch
from tests.support.oracles import grid_for_lens_array
from tests.support.synth import WhiteSpec, render_white, to_uint
from povh3d.errors import InputError
from povh3d.image.io import read_png, write_png

from tests.support.arrays import square_array

PITCH = 0.4  # mm: 4 px of 0.1 mm


def scene(folder, shift_lenses: float):
    path = folder / f"scene_{shift_lenses:+g}.pov"
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
plane {{ z, 3
  pigment {{ function {{ 0.5 + 0.25 * sin(x * 2.1) * cos(y * 1.7) + 0.2 * sin(x * 0.37 + y * 0.9) }}
            color_map {{ [0 rgb <0.1, 0.2, 0.9>] [1 rgb <1, 0.8, 0.1>] }} }}
  finish {{ emission 1 diffuse 0 ambient 0 }}
  translate <{shift_lenses * PITCH!r}, 0, 0> }}
""")
    return path


@pytest.fixture(scope="module")
def captures(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stitch")
    settings = DRAFT
    out = {}
    # Wide camera: 24 lenses. A = its lenses 0..15, B = 8..23, C = B moved half a lens more.
    for name, lenses, shift in [("wide", 24, 0.0), ("a", 16, 4.0), ("b", 16, -4.0), ("c", 16, -4.5)]:
        la = square_array(lx=lenses, ly=8, nx=4, ny=4)
        render(scene(folder, shift), la, folder / f"{name}.png", settings=settings)
        out[name] = folder / f"{name}.png"
    write_grid(folder / "grid.json", grid_for_lens_array(square_array(lx=16, ly=8, nx=4, ny=4)))
    out["grid"] = folder / "grid.json"
    return out


@pytest.mark.povray
def test_stitched_renders_equal_the_wide_render(captures, tmp_path, cli):
    result = cli("stitch", captures["a"], captures["b"], "--grid", captures["grid"], "-o", tmp_path / "ab.png")
    assert result.code == 0
    np.testing.assert_array_equal(read_png(tmp_path / "ab.png"), read_png(captures["wide"]))
    record = json.loads((tmp_path / "ab.json").read_text())
    assert record["shift_lenses"] == {"rows": 0, "cols": 8} and record["mode"] == "pixels"


@pytest.mark.povray
def test_half_lens_shift_is_refused(captures, tmp_path, cli):
    result = cli("stitch", captures["a"], captures["c"], "--grid", captures["grid"], "-o", tmp_path / "ac.png")
    assert result.code == 3
    assert "whole number of lenses" in result.err
    assert not (tmp_path / "ac.png").exists()


def test_shift_in_both_directions_with_a_slanted_non_integral_grid():
    """Synthetic: a rotated, non-integral lattice; B is A moved by (2, -5) lenses."""
    spec = WhiteSpec((300, 240), pitch_px=9.3, rotation_deg=6.34, profile="flat")
    grid = calibrate(render_white(spec))

    def scene_at(di, dj):
        def content(centre, uv):
            # the scene as a function of the lens's lattice position: moving the camera by
            # (di, dj) lenses shifts which lens sees what
            q = (centre - grid.origin) @ np.linalg.inv(np.stack([grid.a1, grid.row_step]))
            j, i = q[..., 0] + dj, q[..., 1] + di
            return 0.5 + 0.3 * np.sin(0.7 * j + 2 * uv[..., 0]) * np.cos(0.9 * i - 2 * uv[..., 1]) + 0.1 * np.sin(0.23 * i * j)
        return render_white(spec, content=content)
    a, b = scene_at(0, 0), scene_at(2, -5)
    shift = find_shift(a, b, grid)
    assert (shift.di, shift.dj) == (2, -5)
    out, _, mode = stitch(a, b, grid, shift)
    assert mode == "rectified"
    n = int(round(grid.pitch_px))
    assert out.shape == ((grid.table[0] + 2) * n, (grid.table[1] + 5) * n)
    with pytest.raises(InputError, match="whole number"):
        find_shift(a, scene_at(2, -5.5), grid)


def test_calibrate_cli_and_errors(tmp_path, cli):
    spec = WhiteSpec((240, 180), lattice="hex", pitch_px=8.3, rotation_deg=9.46)
    write_png(tmp_path / "white.png", to_uint(render_white(spec), 16))
    result = cli("calibrate", tmp_path / "white.png", "-o", tmp_path / "grid.json")
    assert result.code == 0
    record = json.loads((tmp_path / "grid.json").read_text())
    assert record["lattice"] == "hex" and abs(record["rotation_deg"] - 9.46) < 0.01
    assert "hex" in result.out
    for cmd in (["undistort"], ["borders"], ["equalise"]):
        assert cli(*cmd, tmp_path / "white.png", "--grid", tmp_path / "grid.json",
                   "-o", tmp_path / f"{cmd[0]}.png").code == 0
        assert (tmp_path / f"{cmd[0]}.json").is_file()
    assert cli("viewpoints", tmp_path / "white.png", "--grid", tmp_path / "grid.json",
               "--ppl", "4", "-o", tmp_path / "views").code == 0
    assert len(list((tmp_path / "views").glob("v_*.png"))) == 16
    # a grid that does not match the image
    write_png(tmp_path / "small.png", np.zeros((50, 60, 3), np.uint8))
    result = cli("undistort", tmp_path / "small.png", "--grid", tmp_path / "grid.json", "-o", tmp_path / "x.png")
    assert result.code == 3 and "240x180" in result.err
    # a white image with no lattice
    write_png(tmp_path / "flat.png", np.full((120, 160), 200, np.uint8))
    result = cli("calibrate", tmp_path / "flat.png", "-o", tmp_path / "g2.json")
    assert result.code == 3 and "no lens lattice" in result.err
    assert not (tmp_path / "g2.json").exists()
    # not a grid file
    (tmp_path / "bad.json").write_text("{}")
    result = cli("borders", tmp_path / "white.png", "--grid", tmp_path / "bad.json", "-o", tmp_path / "y.png")
    assert result.code == 3
