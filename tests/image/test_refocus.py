"""Refocusing a rendered scene: the plane's depth is the sharpest of the sweep."""

import pytest
import numpy as np

from tests.support.render import render
from povh3d.app.display import lens_info, refocus_file
from povh3d.image.io import read_png, read_sidecar
from povh3d.image.refocus import gradient_energy, refocus_linear
from povh3d.engine.quality import RenderSettings

from tests.support.arrays import square_array
from tests.support.scenes import write_checker_plane

DEPTH = 6.0
SWEEP = [-6.0, -3.0, 0.0, 3.0, DEPTH, 9.0, 12.0]


@pytest.mark.povray
def test_refocus_is_sharpest_at_the_textured_plane(tmp_path):
    la = square_array(lx=24, ly=16, nx=6, ny=6, s=0.1, f=1.5)
    scene = write_checker_plane(tmp_path, DEPTH, 1.2)
    out = tmp_path / "h3d.png"
    render(scene, la, out, settings=RenderSettings(quality="draft"))
    sheet = tmp_path / "sweep.png"
    record = refocus_file(out, sheet, lens_info(out, None, None, None), sweep=(SWEEP[0], SWEEP[-1], len(SWEEP)))
    energy = record["gradient_energy"]
    assert record["depths_mm"] == SWEEP
    assert record["sharpest_depth_mm"] == DEPTH
    assert energy[SWEEP.index(DEPTH)] > 1.2 * max(e for d, e in zip(SWEEP, energy) if d != DEPTH)
    assert read_png(sheet).shape[0] > 16 and (tmp_path / "sweep_004.png").is_file()
    assert read_sidecar(sheet)["kind"] == "refocus"


def test_shift_sign_follows_the_ray_of_a_pixel():
    # Views of a point at depth z: view k sees it at lens j = j0 - z u_k / (f px).  Build such views
    # and check refocusing at +z (not -z) gathers them into one sharp point.
    nx, lx, f, s = 5, 40, 1.5, 0.1
    px = nx * s
    u = (np.arange(nx) + 0.5 - nx / 2) * s
    z = 7.5  # whole-lens shifts: z u_k / (f px) = k - 2
    views = np.zeros((1, nx, 1, lx, 1), np.float32)
    for k in range(nx):
        views[0, k, 0, int(round(20 - z * u[k] / (f * px)))] = 1
    sharp = refocus_linear(views, (u, np.zeros(1)), (px, s), f, z)
    wrong = refocus_linear(views, (u, np.zeros(1)), (px, s), f, -z)
    assert sharp.max() == 1 and gradient_energy(sharp) > 2 * gradient_energy(wrong)
