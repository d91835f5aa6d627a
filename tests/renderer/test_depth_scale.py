"""--depth-scale: depth compressed along the display normal, traced as ray slopes times k.

Oracles: an uncompressed render of the same scene physically compressed by
POV-Ray's own ``scale <1, 1, k>`` (every method point-sampled: identical pixels);
the parallax of a striped plane at a known depth, k times the uncompressed one
(analytic: a view of slope u/f sees the plane at depth z shifted by k z u / f);
depth maps against the compressed plane's analytic distance; ``--fit-depth auto
--depth-scale`` against the measured reach.
"""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.display.display import Display
from povh3d.renderer.placement.pose import PlacementOptions
from povh3d.renderer.placement.place import place_display
from povh3d.renderer.request import RenderRequest
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.errors import ConfigError
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import depth_scaled_rays, pixel_rays
from povh3d.image.interleave import extract
from povh3d.image.io import read_png
from povh3d.scene.scene import load_scene
from tests.support.render import render

# Self-lit (no light, no shading to distort), textures fixed to the objects, so the scene compressed by
# scale <1, 1, K> shows every surface point in the colour it has uncompressed.
SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
#ifndef (K) #declare K = 1; #end
background {{ rgb <0.05, 0.1, 0.2> }}
#declare Lit = finish {{ ambient 0 diffuse 0 emission 1 }};
union {{
  sphere {{ <1.5, -0.5, -2>, 2.6 pigment {{ checker rgb <0.9, 0.4, 0.1> rgb 0.15 scale 0.9 }} finish {{ Lit }} }}
  box {{ <-6, -5, 1>, <-2, 4, 5> pigment {{ gradient y colour_map {{ [0 rgb 0.2] [1 rgb <0.2, 0.9, 0.3>] }} scale 3 }}
        finish {{ Lit }} }}
  plane {{ -z, -{far} pigment {{ checker rgb 0.9 rgb 0.1 scale <1.7, 1.3, 1> rotate 20 * z }} finish {{ Lit }} }}
  scale <1, 1, K>
}}
"""


# The striped plane alone: white where (x / 1.7) mod 1 < 0.5.
PLANE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
plane {{ -z, -{far} pigment {{ gradient x colour_map {{ [0 rgb 0.8] [0.5 rgb 0.8] [0.5 rgb 0.1] [1 rgb 0.1] }} scale 1.7 }}
        finish {{ ambient 0 diffuse 0 emission 1 }} }}
"""


def small() -> LensArray:
    return LensArray("square", 20, 15, 1.2, 1.2, 2.0, Panel(120, 90, 0.2, 0.2))


def test_depth_scaled_rays_are_the_slopes_times_k():
    a = small()
    c0, d0, _ = pixel_rays(a)
    c1, d1, _ = pixel_rays(depth_scaled_rays(a, 0.4))
    np.testing.assert_array_equal(c0, c1)   # through the same lens centres
    np.testing.assert_allclose(d1[..., :2] / d1[..., 2:], 0.4 * d0[..., :2] / d0[..., 2:], rtol=1e-12)
    assert depth_scaled_rays(a, 1) is a


@pytest.mark.povray
@pytest.mark.parametrize("method, array", [
    ("multi-ortho", small()),
    ("multi-ortho", LensArray("square", 18, 13, 1.3, 1.3, 2.0, Panel(120, 90, 0.2, 0.2))),   # fractional PPL
    ("multi-ortho-views", small()),
])
def test_compressed_render_equals_the_physically_compressed_scene(tmp_path, method, array):
    k = 0.35
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE.format(far=6))
    squashed = tmp_path / "squashed.pov"
    squashed.write_text(f"#declare K = {k!r};\n#include \"s.pov\"\n")
    ours = render(scene, array, tmp_path / "a.png", method=method,
                  settings=RenderSettings(quality="draft", depth_scale=k))
    render(squashed, array, tmp_path / "b.png", method=method, settings=RenderSettings(quality="draft"))
    render(scene, array, tmp_path / "c.png", method=method, settings=RenderSettings(quality="draft"))
    a, b, c = (read_png(tmp_path / f"{n}.png").astype(int) for n in "abc")
    differ = (np.abs(a - b).max(-1) > 2).mean()
    assert differ < 0.003, differ        # a few pixels on checker edges, in the last bits of a ray
    assert (np.abs(a - c).max(-1) > 2).mean() > 0.05   # negative control: uncompressed differs
    record = ours["placement"]
    assert record["depth_scale"] == k and "distortion" in record["depth_scale_note"]
    assert ours["lens_array"]["focal_mm"] == array.focal   # the display is recorded as it is


@pytest.mark.povray
def test_single_stage_lenslets_of_focal_f_over_k(tmp_path):
    """Single-stage is a physical simulation (aberrations): compared by an error figure, not identity."""
    from povh3d.image.metrics import psnr

    k = 0.35
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE.format(far=6))
    squashed = tmp_path / "squashed.pov"
    squashed.write_text(f"#declare K = {k!r};\n#include \"s.pov\"\n")
    for name, path, scale in (("a", scene, k), ("b", squashed, 1.0), ("c", scene, 1.0)):
        render(path, small(), tmp_path / f"{name}.png", method="single-stage",
               settings=RenderSettings(quality="draft", depth_scale=scale))
    a, b, c = (read_png(tmp_path / f"{n}.png") for n in "abc")
    assert psnr(a, b) > 35      # measured 39.7 dB
    assert psnr(c, b) < 15      # negative control: uncompressed (8 dB)


@pytest.mark.povray
def test_pinhole_behind_the_screen(tmp_path):
    """Pinhole cameras see only z > 0: a scene wholly behind the screen, compressed both ways."""
    k = 0.5
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE.format(far=9).replace("<1.5, -0.5, -2>", "<1.5, -0.5, 5>"))
    squashed = tmp_path / "squashed.pov"
    squashed.write_text(f"#declare K = {k!r};\n#include \"s.pov\"\n")
    # A quarter of small()'s lenses: pinhole renders one camera a lens.
    array = LensArray("square", 10, 8, 1.2, 1.2, 2.0, Panel(60, 48, 0.2, 0.2))
    render(scene, array, tmp_path / "a.png", method="pinhole", settings=RenderSettings(quality="draft",
                                                                                        depth_scale=k))
    render(squashed, array, tmp_path / "b.png", method="pinhole", settings=RenderSettings(quality="draft"))
    render(scene, array, tmp_path / "c.png", method="pinhole", settings=RenderSettings(quality="draft"))
    a, b, c = (read_png(tmp_path / f"{n}.png").astype(int) for n in "abc")
    assert (np.abs(a - b).max(-1) > 2).mean() < 0.002
    assert (np.abs(a - c).max(-1) > 2).mean() > 0.05   # negative control: uncompressed differs


@pytest.mark.povray
def test_parallax_of_a_plane_is_k_times(tmp_path):
    """Stripes of period P on the plane z = Z: view k sees them shifted by K Z u_k / f (analytic)."""
    far, period, k = 6.0, 1.7, 0.4
    scene = tmp_path / "s.pov"
    scene.write_text(PLANE.format(far=far))
    array = LensArray("square", 60, 4, 1.2, 1.2, 2.0, Panel(360, 24, 0.2, 0.2))
    ny, nx = array.require_views()
    cx = (np.arange(60) + 0.5 - 30) * 1.2
    for scale in (1.0, k):
        render(scene, array, tmp_path / "h.png", settings=RenderSettings(quality="draft", depth_scale=scale))
        views = extract(read_png(tmp_path / "h.png"), (ny, nx))
        for view in (0, nx // 2, nx - 1):
            u = (view + 0.5 - nx / 2) * 0.2
            x = cx + scale * far * u / 2.0           # where each lens's ray meets the plane
            white = (x / period) % 1 < 0.5
            seen = views[ny // 2, view][1, :, 0] > 128
            clear = np.abs(((x / period) % 0.5) - 0.25) < 0.2   # away from stripe edges
            assert (seen == white)[clear].all(), (scale, view)


@pytest.mark.povray
def test_fit_depth_by_depth_scale_keeps_the_frame(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE.format(far=30))
    array = small()
    request = RenderRequest(source=scene, display=Display(array), output=tmp_path / "o.png",
                            settings=RenderSettings(quality="draft"),
                            placement=PlacementOptions(fit_depth="auto", depth_scale="fit"))
    placed, record = place_display(request, load_scene(scene))
    k = placed.settings.depth_scale
    before = record["depth"]["before_fit"]
    budget = record["depth_budget_mm"]
    reach = max(abs(before["near_mm"]), abs(before["far_mm"]))
    assert k == pytest.approx(budget / 2 / reach) and k < 1
    assert record["depth"]["within_budget"] and record["units_per_mm"] == 1.0
    assert record["depth"]["far_mm"] == pytest.approx(before["far_mm"] * k)
    assert placed.settings.pose is None   # the pose is not scaled: lateral sizes kept
    # Without --depth-scale the frame shrinks instead.
    request = RenderRequest(source=scene, display=Display(array), output=tmp_path / "o.png",
                            settings=RenderSettings(quality="draft"), placement=PlacementOptions(fit_depth="auto"))
    placed, record = place_display(request, load_scene(scene))
    assert placed.settings.depth_scale == 1 and record["units_per_mm"] == pytest.approx(1 / k)


def test_depth_scale_options_are_checked():
    with pytest.raises(ConfigError, match="needs placement.fit_depth"):
        PlacementOptions(depth_scale="fit")
    with pytest.raises(ConfigError, match="both set the depth"):
        PlacementOptions(fit_depth="auto", depth_scale=0.5)
    with pytest.raises(ConfigError, match="depth_scale"):
        RenderSettings(depth_scale=0.0)


@pytest.mark.povray
def test_depth_maps_show_the_compressed_depth(tmp_path):
    """Per view: distance along the display's ray (slope u/f) to the plane z = K Z."""
    from povh3d.renderer.passes.depth import view_depth_maps

    far, k = 6.0, 0.4
    scene = tmp_path / "s.pov"
    scene.write_text(PLANE.format(far=far))
    array = small()
    maps = view_depth_maps(load_scene(scene), array, RenderSettings(depth_scale=k), 20.0, 1.0)
    ny, nx = array.require_views()
    for l, j in [(0, 0), (ny - 1, nx - 1), (2, 4)]:
        a, b = (j + 0.5 - nx / 2) * 0.2 / 2.0, (ny / 2 - l - 0.5) * 0.2 / 2.0
        expected = k * far * np.sqrt(a * a + b * b + 1)
        assert np.nanmax(np.abs(maps[l, j] - expected)) < 0.02
        assert np.isfinite(maps[l, j]).all()

