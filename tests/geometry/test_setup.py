"""The set-up picture's geometry against the conventions' own numbers (docs/geometry.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from povh3d.geometry.fit import depth_budget_mm
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.display.presets import get_preset, lens_array, names
from povh3d.geometry.setup import (
    BEHIND,
    FRONT,
    INSIDE,
    array_outline,
    classify,
    depth_figures,
    depth_points,
    set_up,
)


#: The presets with a sheet of their own (the Looking Glass 27"'s is the unit's calibration).
SHEETS = [n for n in names() if get_preset(n).get("sheet_from") != "calibration"]


@pytest.mark.parametrize("preset", SHEETS)
def test_screen_is_the_panel_and_the_slab_is_2_n_f(preset):
    a = lens_array(preset)
    s = set_up(a, depth_budget_mm(a))
    lo, hi = s.slab
    w, h = a.panel.width * a.panel.pitch_x, a.panel.height * a.panel.pitch_y
    assert np.allclose(hi[:2] - lo[:2], (w, h)) and np.allclose(s.screen[:, 2], 0)
    # N: pixels per lens, horizontally for lenticular and hex, the smaller of the two otherwise
    n = a.pitch_x / a.panel.pitch_x
    if a.grid == "square":
        n = min(n, a.pitch_y / a.panel.pitch_y)
    assert hi[2] - lo[2] == pytest.approx(2 * n * a.focal) and lo[2] == pytest.approx(-hi[2])


@pytest.mark.parametrize("preset", SHEETS)
def test_cone_half_angle_is_the_edge_pixels_ray(preset):
    a = lens_array(preset)
    s = set_up(a, 10.0)
    # the ray of a pixel at the lens's edge, u = p/2, reversed towards the viewer: -(u, 0, f)
    edge = -np.array([a.pitch_x / 2, 0.0, a.focal])
    assert s.half_angles_deg[0] == pytest.approx(math.degrees(math.atan2(-edge[0], -edge[2])))
    assert 2 * s.half_angles_deg[0] == pytest.approx(a.viewing_angle_deg)
    if a.views is not None:   # the outermost view's pixel centre lies half a pixel inside the edge
        u_max = (a.views[1] - 1) / 2 * a.panel.pitch_x
        assert s.view_angles_deg[0] == pytest.approx(math.degrees(math.atan(u_max / a.focal)))
        assert s.view_angles_deg[0] == pytest.approx(np.max(np.abs(a.view_angles_deg()[0])))
        assert s.view_angles_deg[0] < s.half_angles_deg[0]
    if a.unidirectional:
        assert math.isnan(s.half_angles_deg[1])
        assert np.allclose(s.apex[:, 1], (-a.panel.size_mm[1] / 2, a.panel.size_mm[1] / 2))
    else:
        assert s.half_angles_deg[1] == pytest.approx(math.degrees(math.atan(a.pitch_y / (2 * a.focal))))


@pytest.mark.parametrize("preset", ["demo", "hex-5.6", "ipad-retina"])
def test_cone_ends_where_every_lens_is_in_view(preset):
    a = lens_array(preset)
    s = set_up(a, 10.0)
    d = s.viewing_distance_mm
    assert np.allclose(s.cone_end[:, 2], -d)
    # from (0, 0, -D) the screen's edges are seen at most at the cone's half-angles, one of them exactly
    w, h = a.panel.size_mm
    seen = [math.degrees(math.atan(w / 2 / d)) / s.half_angles_deg[0]]
    if not a.unidirectional:
        seen.append(math.degrees(math.atan(h / 2 / d)) / s.half_angles_deg[1])
    assert max(seen) == pytest.approx(1.0) and min(seen) <= 1 + 1e-12
    # the cone's far corners lie on its edges: at the half-angles from the apex
    x = np.abs(s.cone_end[:, 0])
    assert np.allclose(np.degrees(np.arctan(x / d)), s.half_angles_deg[0])


def test_array_outline_is_the_lens_cells_turned_with_the_lattice():
    panel = Panel(320, 240, 0.1, 0.1)
    flat = LensArray("square", 36, 28, 0.8, 0.8, 1.5, panel)
    o = array_outline(flat)
    assert np.allclose(o.max(axis=0)[:2] - o.min(axis=0)[:2], (36 * 0.8, 28 * 0.8))
    turned = array_outline(LensArray("square", 36, 28, 0.8, 0.8, 1.5, panel, rotation=10.0))
    assert np.allclose(np.linalg.norm(turned, axis=1), np.linalg.norm(o, axis=1))   # a rotation about 0
    angle = math.degrees(math.atan2(turned[1, 1] - turned[0, 1], turned[1, 0] - turned[0, 0]))
    assert angle == pytest.approx(10.0)


def test_depth_points_sit_at_pixel_centres():
    z = np.array([[1.0, np.nan], [3.0, 4.0]])
    p = depth_points(z, 8.0, 6.0)
    # row 0 at the top: (col + 0.5 - W/2) * step, (H/2 - row - 0.5) * step
    assert np.allclose(p, [[-2.0, 1.5, 1.0], [-2.0, -1.5, 3.0], [2.0, -1.5, 4.0]])


def test_classify_and_figures_against_the_slab():
    z = np.array([-7.0, -5.0, 0.0, 5.0, 6.0, np.nan])
    assert classify(z[:5], 10.0).tolist() == [FRONT, INSIDE, INSIDE, INSIDE, BEHIND]
    f = depth_figures(z, 10.0)
    assert f["points"] == 5 and f["near_mm"] == -7 and f["far_mm"] == 6
    assert f["outside"] == pytest.approx(0.4) and f["front_outside"] == pytest.approx(0.2)
    # a box's depth sampled evenly: the share of its depth outside the budget
    assert depth_figures(np.linspace(-10, 10, 20001), 10.0)["outside"] == pytest.approx(0.5, abs=1e-3)
    assert depth_figures(np.array([np.nan]), 10.0) == {"points": 0}
