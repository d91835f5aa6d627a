"""Independent methods agree on one scene: multi-ortho (mesh camera), one
orthographic camera per view, and per-lens pinholes, all point-sampled.

Each negative control (wrong view order, elemental images turned 180 degrees,
a sample grid shifted by half a lens) must fail the same threshold, so the
check can fail.
"""

import numpy as np
import pytest

from povh3d.geometry.lens_array import LensArray
from povh3d.renderer.methods.registry import run_method
from povh3d.image.metrics import psnr
from povh3d.scene.scene import load_scene

from tests.support.arrays import square_array
from tests.support.scenes import write_textured_scene
from tests.support.render import DRAFT

pytestmark = pytest.mark.povray  # every test here starts POV-Ray

LA = square_array(lx=16, ly=12, nx=6, ny=6, s=0.1, f=1.5)


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    scene = load_scene(write_textured_scene(tmp_path_factory.mktemp("scene")))
    return {m: run_method(m, scene, LA, DRAFT).h3d for m in ("multi-ortho", "multi-ortho-views", "pinhole")}, scene


def _elemental(h3d):
    return h3d.reshape(LA.lenses_y, 6, LA.lenses_x, 6, -1)


def test_multi_ortho_matches_pinhole(renders):
    images, _ = renders
    assert psnr(images["multi-ortho"], images["pinhole"]) >= 45


def test_one_pass_matches_camera_per_view(renders):
    images, _ = renders
    assert psnr(images["multi-ortho"], images["multi-ortho-views"]) >= 45


def test_wrong_view_order_fails(renders):
    images, _ = renders
    wrong = _elemental(images["multi-ortho"])[:, :, :, ::-1].reshape(images["pinhole"].shape)
    assert psnr(wrong, images["pinhole"]) < 45


def test_elemental_images_turned_180_degrees_fail(renders):
    images, _ = renders
    turned = _elemental(images["multi-ortho"])[:, ::-1, :, ::-1].reshape(images["pinhole"].shape)
    assert psnr(turned, images["pinhole"]) < 45


def test_half_lens_shift_of_sample_grid_fails(renders, monkeypatch):
    images, scene = renders
    original = LensArray.lens_centres

    def shifted(self):
        return original(self) + np.array([self.pitch_x / 2, 0.0])

    monkeypatch.setattr(LensArray, "lens_centres", shifted)
    wrong = run_method("multi-ortho", scene, LA, DRAFT).h3d
    assert psnr(wrong, images["pinhole"]) < 45
