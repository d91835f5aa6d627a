"""``render --dataset`` and ``povh3d dataset``: a POV-Ray render of an analytic plane in front of and
behind the screen, exported in the HCI layout and read back with the toolkit's own readers
(tests/dataset/test_hci.py: line for line its ``read_pfm`` and ``read_parameters``)."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.image.interleave import extract
from povh3d.image.io import read_png
from tests.dataset.test_hci import toolkit_read_parameters, toolkit_read_pfm
from tests.support.cli import one_error_line

# 20 lenses of 7 pixels (0.1 mm), f = 1.5 mm, 16 rows: a plane at z moves -z s / (f p) px per camera step
ARRAY = ["--grid", "lenticular", "--lenses", "20", "--ppl", "7", "--rows", "16", "--pixel-pitch", "0.1",
         "--focal", "1.5", "--quality", "draft"]
S, F, P = 0.1, 1.5, 0.7


def _plane(folder, z0):
    """A checkered plane filling the field at depth z0, its solid side away from the viewer."""
    path = folder / f"plane_{z0:+g}.pov"
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
background {{ rgb 0 }}
light_source {{ <0, 0, -1000> rgb 1 }}
plane {{ -z, {-z0!r} pigment {{ checker rgb 0.2 rgb 0.6 }} finish {{ ambient 0 diffuse 0.6 }} }}
""")
    return path


@pytest.mark.povray  # main registers the marker (make test-fast leaves it out)
@pytest.mark.parametrize("z0", [-3.0, 3.0])
def test_plane_disparity_is_geometry_with_hcis_sign(tmp_path, cli, z0):
    out, folder = tmp_path / "h3d.png", tmp_path / "hci"
    result = cli("render", _plane(tmp_path, z0), *ARRAY, "--dataset", folder, "-o", out)
    assert result.code == 0, result.err
    disp = toolkit_read_pfm(folder / "gt_disp_lowres.pfm")
    depth = toolkit_read_pfm(folder / "gt_depth_lowres.pfm")
    expected = -z0 * S / (F * P)                          # HCI: positive in front of the focus plane
    assert disp.shape == (16, 20) and np.isfinite(disp).all()
    assert np.abs(disp - expected).max() < 0.01
    assert np.abs(disp + expected).max() > 0.5           # control: the render's own sign (p_ maps) fails
    assert np.abs(depth - (1000.0 + z0) / 1000.0).max() < 1e-4         # Z metres from the camera plane
    params = toolkit_read_parameters(folder / "parameters.cfg")
    assert (int(params["num_cams_x"]), int(params["num_cams_y"])) == (7, 1)
    assert float(params["disp_min"]) == pytest.approx(expected, abs=0.01)
    bank = extract(read_png(out), (1, 7))[0]
    assert np.array_equal(read_png(folder / "input_Cam000.png"), bank[6])   # leftmost camera: k = Nx - 1
    assert not np.array_equal(read_png(folder / "input_Cam000.png"), bank[0])
    # and from the render and its sidecar afterwards: the same disparity
    again = tmp_path / "again"
    result = cli("dataset", out, "-o", again, "--all-views")
    assert result.code == 0, result.err
    assert np.array_equal(toolkit_read_pfm(again / "gt_disp_lowres.pfm"), disp)
    for cam in range(7):
        d = toolkit_read_pfm(again / f"gt_disp_lowres_Cam{cam:03d}.pfm")
        assert np.abs(d - expected).max() < 0.01


def test_even_views_and_a_mapping_are_one_line_and_nothing_written(tmp_path, cli):
    scene = _plane(tmp_path, 2.0)
    out = tmp_path / "x.png"
    even = [a if a != "7" else "8" for a in ARRAY]
    line = one_error_line(cli("render", scene, *even, "--dataset", tmp_path / "d", "-o", out))
    assert "odd count" in line and not out.exists() and not (tmp_path / "d").exists()
    line = one_error_line(cli("render", scene, "--preset", "alioscopy-42", "--mapping", "alioscopy",
                              "--dataset", tmp_path / "d", "-o", out))
    assert "drop --mapping" in line and not out.exists()
    line = one_error_line(cli("render", scene, *ARRAY, "--dataset-all-views", "-o", out))
    assert "needs --dataset" in line and not out.exists()
