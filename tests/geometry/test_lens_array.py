import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays

from tests.support.arrays import lenticular_array, square_array


def test_lens_centres_follow_conventions_formula():
    la = square_array(lx=5, ly=3, nx=4, ny=2, s=0.25)
    c = la.lens_centres()
    j, i = 3, 1
    assert c[i, j, 0] == (j + 0.5 - 5 / 2) * la.pitch_x
    assert c[i, j, 1] == (3 / 2 - i - 0.5) * la.pitch_y
    assert c.shape == (3, 5, 2)


def test_no_drift_across_4000_lenses():
    s = 0.0945
    la = LensArray("square", 4000, 1, 8 * s, 8 * s, 1.0, Panel(32000, 8, s, s))
    c = la.lens_centres()[0, :, 0]
    exact = (np.arange(4000) + 0.5 - 2000) * (8 * s)
    assert np.max(np.abs(c - exact)) == 0.0


def test_view_offsets_and_directions():
    la = square_array(nx=4, ny=2, s=0.1, f=2.0)
    u, v = la.view_offsets()
    np.testing.assert_allclose(u, [-0.15, -0.05, 0.05, 0.15])
    np.testing.assert_allclose(v, [0.05, -0.05])  # l = 0 is the top row: looks up
    d = la.view_directions()
    assert d.shape == (2, 4, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0)
    np.testing.assert_allclose(d[0, 3], np.array([0.15, 0.05, 2.0]) / math.sqrt(0.15**2 + 0.05**2 + 4))


def test_derived_display_figures():
    la = square_array(lx=10, ly=5, nx=8, ny=8, s=0.1, f=1.5)
    assert la.views == (8, 8)
    assert la.h3d_size == (40, 80)
    assert la.view_size == (5, 10)
    assert la.viewing_angle_deg == pytest.approx(math.degrees(2 * math.atan(0.8 / 3.0)))
    assert la.ppi_3d[0] == pytest.approx(25.4 / 0.8)
    assert la.resolution_3d == (10, 5)


def test_lenticular_views_are_one_row():
    la = lenticular_array(lx=8, rows=12, nx=4)
    assert la.views == (1, 4)
    assert la.h3d_size == (12, 32)
    assert la.view_offsets()[1].tolist() == [0.0]


@pytest.mark.parametrize("kwargs, message", [
    (dict(grid="round"), "grid must be one of"),
    (dict(focal=0.0), "focal length"),
    (dict(focal=float("nan")), "focal length"),
    (dict(lenses_x=0), "lens count"),
    (dict(lenses_x=100), "larger than the panel"),
    (dict(pitch_x=0.05), "under one pixel"),
])
def test_invalid_values_name_the_field(kwargs, message):
    base = dict(grid="square", lenses_x=4, lenses_y=4, pitch_x=0.4, pitch_y=0.4, focal=1.0,
                panel=Panel(16, 16, 0.1, 0.1))
    base.update(kwargs)
    with pytest.raises(ConfigError, match=message):
        LensArray(**base)


def test_non_integral_ppl_has_no_camera_bank():
    la = LensArray("square", 4, 4, 0.45, 0.45, 1.0, Panel(20, 20, 0.1, 0.1))
    assert la.views is None
    with pytest.raises(ConfigError, match="whole"):
        la.require_views()


def test_pixel_rays_match_view_bank():
    """Every pixel's ray is the ray of its view: lens centre + view direction."""
    la = square_array(lx=5, ly=4, nx=3, ny=2)
    centres, dirs, inside = pixel_rays(la)
    assert inside.all()
    vd = la.view_directions()
    lc = la.lens_centres()
    for row, col in [(0, 0), (3, 7), (7, 14)]:
        i, l, j, k = row // 2, row % 2, col // 3, col % 3
        np.testing.assert_allclose(centres[row, col], lc[i, j])
        np.testing.assert_allclose(dirs[row, col], vd[l, k])


def test_pixel_right_of_centre_looks_right():
    # docs/geometry.md: a pixel right of its lens centre shows the scene as seen from the left,
    # i.e. its ray heads right (+x) into the scene.
    la = square_array(nx=4)
    _, dirs, _ = pixel_rays(la)
    assert dirs[0, 3, 0] > 0 and dirs[0, 0, 0] < 0


@settings(max_examples=60, deadline=None)
@given(pitch=st.floats(0.01, 10), ppl=st.integers(1, 200), lenses=st.integers(1, 50),
       focal=st.floats(0.05, 50))
def test_geometry_is_finite_and_scale_free(pitch, ppl, lenses, focal):
    s = pitch / ppl
    la = LensArray("square", lenses, 2, pitch, pitch, focal, Panel(lenses * ppl, 2 * ppl, s, s))
    d = la.view_directions()
    assert np.all(np.isfinite(d))
    # Direction depends only on offsets relative to the focal length.
    scaled = LensArray("square", lenses, 2, pitch * 1e3, pitch * 1e3, focal * 1e3,
                       Panel(lenses * ppl, 2 * ppl, s * 1e3, s * 1e3))
    np.testing.assert_allclose(scaled.view_directions(), d, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(scaled.lens_centres() / 1e3, la.lens_centres(), rtol=1e-12)


def test_odd_pixel_margin_has_no_camera_bank():
    # 5 lenses of 4 px on 21 px: a 0.5-px margin puts every pixel off the u_k grid.
    assert LensArray("square", 5, 1, 0.4, 0.4, 1.0, Panel(21, 4, 0.1, 0.1)).views is None
    even = LensArray("square", 5, 1, 0.4, 0.4, 1.0, Panel(22, 4, 0.1, 0.1))
    assert even.views == (4, 4)
    assert even.bank_region == (slice(0, 4), slice(1, 21))
