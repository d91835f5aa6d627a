"""Analytic oracle: an emissive checker plane in front of and behind the screen.

The expected H3D image is computed in NumPy from docs/geometry.md (the ray of a
pixel); POV-Ray renders it point-sampled through lenticular and square arrays.
A pseudoscopic image (views in reverse order) must fail the same check.
"""

import numpy as np
import pytest

from povh3d.geometry.lens_array import LensArray, Panel

from povh3d.geometry.rays import pixel_rays
from povh3d.renderer.methods.registry import run_method
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.scene.scene import load_scene

from tests.support.arrays import lenticular_array, square_array
from tests.support.scenes import checker_oracle, classify, write_checker_plane

pytestmark = pytest.mark.povray  # every test here starts POV-Ray

ARRAYS = {
    "lenticular": lenticular_array(lx=24, rows=40, nx=6, s=0.1, f=1.5),
    "square": square_array(lx=24, ly=16, nx=6, ny=6, s=0.1, f=1.5),
    # A panel wider than the array by 2 pixels a side (like ipad-retina's 2048 = 341*6 + 2).
    "square-margin": LensArray("square", 22, 16, 0.6, 0.6, 1.5, Panel(136, 100, 0.1, 0.1)),
}
PERIOD = 2.5


def reverse_views(h3d: np.ndarray, ppl_x: int) -> np.ndarray:
    """The pseudoscopic image: each lens's pixels mirrored left to right."""
    h, w = h3d.shape[:2]
    return h3d.reshape(h, w // ppl_x, ppl_x, -1)[:, :, ::-1].reshape(h3d.shape)


@pytest.mark.parametrize("method", ["multi-ortho", "multi-ortho-views"])
@pytest.mark.parametrize("grid", list(ARRAYS))
@pytest.mark.parametrize("z0", [6.0, -6.0], ids=["behind", "in-front"])
def test_checker_plane_matches_oracle(tmp_path, method, grid, z0):
    la = ARRAYS[grid]
    scene = load_scene(write_checker_plane(tmp_path, z0, PERIOD))
    result = run_method(method, scene, la, RenderSettings(quality="draft", use_cache=False))
    expected, clear = checker_oracle(la, z0, PERIOD)
    assert not result.h3d[~pixel_rays(la)[2]].any(), "pixels outside every lens must stay black"
    assert clear.mean() > 0.3, "test set-up: too few pixels clear of pattern edges"
    got = classify(result.h3d)
    match = np.mean(got[clear] == expected[clear])
    assert match >= 0.995, f"{match:.4f} of clear pixels match the oracle"
    # The same check must fail for the pseudoscopic (view-reversed) image.
    rows, cols = la.bank_region
    flipped = result.h3d.copy()
    flipped[rows, cols] = reverse_views(result.h3d[rows, cols], la.views[1])
    flipped = classify(flipped)
    assert np.mean(flipped[clear] == expected[clear]) < 0.9


FRACTIONAL = {
    "square-6.5": LensArray("square", 20, 14, 0.65, 0.65, 1.5, Panel(130, 91, 0.1, 0.1)),
    "lenticular-6.5": LensArray("lenticular", 20, 40, 0.65, 0.1, 1.5, Panel(130, 40, 0.1, 0.1)),
}


@pytest.mark.parametrize("grid", list(FRACTIONAL))
@pytest.mark.parametrize("z0", [6.0, -6.0], ids=["behind", "in-front"])
def test_fractional_ppl_checker_matches_oracle(tmp_path, grid, z0):
    # 6.5 pixels per lens: every other lens border runs through a row of pixel
    # centres, which belong to the lens on their right (or below) by docs/geometry.md'
    # cell rule; the per-lens mesh camera must give them that lens's ray too.
    la = FRACTIONAL[grid]
    scene = load_scene(write_checker_plane(tmp_path, z0, PERIOD))
    result = run_method("multi-ortho", scene, la, RenderSettings(quality="draft", use_cache=False))
    expected, clear = checker_oracle(la, z0, PERIOD)
    assert clear.mean() > 0.3
    match = np.mean(classify(result.h3d)[clear] == expected[clear])
    assert match >= 0.995, f"{match:.4f} of clear pixels match the oracle"
