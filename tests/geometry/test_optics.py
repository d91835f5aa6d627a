"""Lens-maker and conic optics, checked by an exact Snell trace and Fermat's principle."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.geometry.optics import DEFAULT_THINNESS, Lenslet, aperture_radius, default_ior, sag
from tests.support.oracles import trace_collimated


def test_lens_maker_radius():
    # Thesis Eq. 3.1 with r2 = inf: f = r1 / (n - 1).
    lens = Lenslet("spherical", "square", 0.6, 0.6, 1.5, 1.5)
    assert lens.radius == pytest.approx(0.75)
    assert 1 / ((lens.ior - 1) * (1 / lens.radius)) == pytest.approx(1.5)


@settings(max_examples=60, deadline=None)
@given(n=st.floats(1.2, 30), focal=st.floats(0.3, 5), frac=st.floats(0.01, 0.99))
def test_conic_focuses_every_height_on_the_focal_point(n, focal, frac):
    lens = Lenslet("conic", "square", 0.5 * focal, 0.5 * focal, focal, n)
    h = np.array([frac * lens.aperture_radius])
    z_axis, _ = trace_collimated(lens, h)
    assert z_axis[0] == pytest.approx(focal, rel=1e-9)


@settings(max_examples=60, deadline=None)
@given(n=st.floats(1.2, 30), frac=st.floats(0.0, 1.0))
def test_conic_sag_has_equal_optical_paths(n, frac):
    # Fermat: n * sag + distance(surface point, focus) is the same for every height.
    f = 1.0
    lens = Lenslet("conic", "hex", 0.8, 0.8 * math.sqrt(3) / 2, f, n)
    h = frac * lens.aperture_radius
    s = float(sag(h, lens.radius, lens.conic))
    # Path from the vertex plane inside the glass: -n*s in glass saved, then air to the focus.
    assert -n * s + math.hypot(h, f + s) == pytest.approx(f, rel=1e-9)


def test_fermat_path_explicit():
    lens = Lenslet("conic", "square", 0.8, 0.8, 1.5, 1.5)
    h = np.linspace(0, lens.aperture_radius, 9)
    s = sag(h, lens.radius, lens.conic)
    # Optical path from the plane z = -T inside the glass to the focus (0, f).
    path = lens.ior * (1.0 - s) + np.hypot(h, lens.focal + s)
    assert np.ptp(path) < 1e-12


def test_sphere_is_paraxially_exact_and_aberrated_at_the_rim():
    lens = Lenslet("spherical", "square", 0.8, 0.8, 1.5, 1.5)
    z, _ = trace_collimated(lens, np.array([1e-4, 0.4]))
    assert z[0] == pytest.approx(1.5, rel=1e-6)
    assert z[1] < 1.5 * 0.98  # the negative control: a sphere is not aberration-free


def test_sphere_total_internal_reflection_past_r_over_n():
    lens = Lenslet("spherical", "square", 0.8, 0.8, 1.5, 1.5)
    z, _ = trace_collimated(lens, np.array([lens.tir_height * 0.99, lens.tir_height * 1.01]))
    assert np.isfinite(z[0]) and np.isnan(z[1])


def test_quadric_is_negative_inside_the_glass_and_zero_on_the_surface():
    for shape in ("spherical", "conic"):
        lens = Lenslet(shape, "square", 0.6, 0.6, 1.2, 2.0)
        (a, b, c), _, (_, _, i), j = lens.quadric()
        q = lambda x, y, z: a * x * x + b * y * y + c * z * z + i * z + j  # noqa: E731
        h = 0.2
        z = -float(sag(h, lens.radius, lens.conic))
        assert abs(q(h, 0, z)) < 1e-12
        assert q(0, 0, -0.01) < 0 < q(0, 0, 0.01)


def test_lenticular_quadric_has_no_y_term():
    assert Lenslet("conic", "lenticular", 0.6, 0.1, 1.5).quadric()[0][1] == 0.0


def test_default_ior_makes_a_thin_lens():
    for aperture, px, py, f in (("square", 0.8, 0.8, 1.5), ("hex", 0.85, 0.85 * math.sqrt(3) / 2, 1.0),
                                ("lenticular", 0.6, 0.1, 1.5)):
        lens = Lenslet("spherical", aperture, px, py, f)
        assert lens.corner_sag <= DEFAULT_THINNESS * f * 1.01
        assert lens.ior >= 1.5
    # A slow lens keeps glass.
    assert default_ior(10.0, 0.1) == 1.5


def test_aperture_radius():
    assert aperture_radius("hex", 0.85, 0.736) == pytest.approx(0.85 / math.sqrt(3))
    assert aperture_radius("square", 0.6, 0.8) == pytest.approx(0.5)
    assert aperture_radius("lenticular", 0.6, 0.1) == pytest.approx(0.3)


@pytest.mark.parametrize("ior", [1.0, 0.9, -2.0, float("nan")])
def test_ior_of_one_or_less_is_refused(ior):
    with pytest.raises(ConfigError, match="ior"):
        Lenslet("conic", "square", 0.6, 0.6, 1.5, ior)


def test_spherical_cap_that_cannot_span_the_aperture_is_refused():
    # hex-5.6: corner 0.491 mm, f 1.0; at the thesis's n = 1.283 the radius is 0.283 mm.
    with pytest.raises(ConfigError, match=r"raise ior above 1\.49.*focal"):
        Lenslet("spherical", "hex", 0.85, 0.85 * math.sqrt(3) / 2, 1.0, 1.283)
    # The hyperboloid spans any aperture.
    Lenslet("conic", "hex", 0.85, 0.85 * math.sqrt(3) / 2, 1.0, 1.283)


def test_unknown_shape_is_refused():
    with pytest.raises(ConfigError, match="lenslet"):
        Lenslet("parabolic", "square", 0.6, 0.6, 1.5)
