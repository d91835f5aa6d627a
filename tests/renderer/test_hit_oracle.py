"""Hit-point oracle for single-stage (and multi-ortho, which validates it) on every grid.

Emissive planes 30 mm in front of and behind the screen encode the point each
pixel's ray hits (``tests.support.hit_oracle``).  Point-sampled, at least 99.5 % of
the pixels clear of lens borders (0.1 pixel) must land within 0.05 mm of the point
their conventions ray hits.  Measured (this branch, POV-Ray 3.7):

=============  ========  ================================  =======================
grid           where     single-stage before (main)        single-stage after
=============  ========  ================================  =======================
hex-5.6 30x24  behind    70.87 %, worst 1.84 mm, border 0  100 %, worst 0.0012 mm
hex-5.6 30x24  in front  76.43 %, worst 1.78 mm, border 0  100 %, worst 0.0013 mm
hex 6.5 PPL    behind    76.24 %, worst 1.77 mm, border 0  100 %, worst 0.0006 mm
hex 6.5 PPL    in front  77.54 %, worst 1.74 mm, border 0  100 %, worst 0.0007 mm
square 8x8     behind    93.75 %, worst 0.067 mm           100 %, worst 0.0007 mm
square 8x8     in front  100 %, worst 0.023 mm             100 %, worst 0.0007 mm
lenticular     behind    100 %, worst 0.028 mm             100 %, worst 0.0006 mm
lenticular     in front  100 %, worst 0.004 mm             100 %, worst 0.0006 mm
=============  ========  ================================  =======================

("border": pixels within 0.1 pixel of a lens border, now 100 % too.)  The worst hits
are the 16-bit position code's step, 2 half / 65535 mm.
multi-ortho: 100 %, worst 0.0008 mm on all of them.  The controls (views reversed,
focal length x1.02, lens pitch x1.001) must fail the same check.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from povh3d.display import presets
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays

from tests.support.arrays import lenticular_array, square_array
from tests.support.hit_oracle import expected_hits, half_for, render_hits, score

pytestmark = pytest.mark.povray  # every test here renders with POV-Ray

GRIDS = {
    "hex-5.6": presets.lens_array("hex-5.6", lenses=(30, 24)),
    "hex-6.5": LensArray("hex", 20, 16, 0.65, 0.65 * math.sqrt(3) / 2, 1.5, Panel(134, 91, 0.1, 0.1)),
    "square-8": square_array(lx=16, ly=12, nx=8, ny=8, s=0.1, f=1.5),
    "lenticular": lenticular_array(lx=24, rows=40, nx=6, s=0.1, f=1.5),
}
WHERE = {"behind": 30.0, "in-front": -30.0}


@pytest.mark.parametrize("method", ["single-stage", "multi-ortho"])
@pytest.mark.parametrize("grid", list(GRIDS))
@pytest.mark.parametrize("where", list(WHERE))
def test_every_pixel_hits_where_its_ray_does(tmp_path, method, grid, where):
    la, z0 = GRIDS[grid], WHERE[where]
    got = render_hits(method, la, tmp_path, z0, half_for(la, z0))
    result = score(la, got, z0)
    print(f"{method} {grid} {where}: {result}")
    assert result.clear > 0.7 * pixel_rays(la)[2].sum(), "test set-up: too few clear pixels"
    assert result.within >= 0.995, str(result)


@pytest.mark.parametrize("method", ["single-stage", "multi-ortho"])
def test_controls_fail_the_oracle(tmp_path, method):
    la, z0 = GRIDS["hex-6.5"], WHERE["in-front"]
    half = half_for(la, z0) * 1.1
    got = render_hits(method, la, tmp_path, z0, half)
    assert score(la, got, z0).within >= 0.995
    # Views reversed (pseudoscopic): the ray through c along (-u, -v, f) hits 2 c' - want.
    c = pixel_rays(la)[0]
    pseudo = 2 * c - got
    assert score(la, pseudo, z0).within < 0.5
    for wrong in (replace(la, focal=la.focal * 1.02), replace(la, pitch_x=la.pitch_x * 1.001,
                                                              pitch_y=la.pitch_y * 1.001)):
        off = render_hits(method, wrong, tmp_path, z0, half)
        assert score(la, off, z0).within < 0.9, f"control {wrong} passed"
    assert np.isfinite(expected_hits(la, z0)[pixel_rays(la)[2]]).all()


def test_impossible_lenslets_are_refused_in_one_line(tmp_path):
    from povh3d.renderer.methods.registry import run_method
    from povh3d.renderer.methods.quality import RenderSettings
    from povh3d.errors import ConfigError
    from povh3d.scene.scene import load_scene
    from tests.support.hit_oracle import write_position_plane

    scene = load_scene(write_position_plane(tmp_path, 30.0, 20.0))
    settings = RenderSettings(quality="draft", use_cache=False)
    # f = 0.05 mm under a 0.6 mm lenticule: no real index bends the rim pixels' rays
    # (before: index 3601 picked, hits 7-21 mm off, exit 0).
    short = lenticular_array(lx=24, rows=40, nx=6, s=0.1, f=0.05)
    with pytest.raises(ConfigError, match=r"lengthen focal to [0-9.]+ mm or more") as err:
        run_method("single-stage", scene, short, settings)
    assert "\n" not in str(err.value) and "1.3..2.5" in str(err.value)
    for ior in (1.1, 3.0, 6401.0):
        with pytest.raises(ConfigError, match="no lens material"):
            run_method("single-stage", scene, GRIDS["square-8"], settings, ior=ior)
    # The focal length the refusal names is accepted (at the index it names).
    need = float(str(err.value).split("lengthen focal to ")[1].split(" mm")[0])
    ok = lenticular_array(lx=24, rows=40, nx=6, s=0.1, f=need)
    got = render_hits("single-stage", ok, tmp_path, 30.0, half_for(ok, 30.0), ior=2.5)
    assert score(ok, got, 30.0).within >= 0.995
