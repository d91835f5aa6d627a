"""Property tests (hypothesis) on the geometry and camera functions, no POV-Ray.

Random lens arrays from 10 um to 10 mm pitch, 1 to 200 pixels per lens,
focal lengths giving view angles up to 80 degrees, square, lenticular and hex
grids.  Oracles are the conventions' formulas evaluated independently here, exact
symmetries (mirror images are exact negations in floating point), and scaling
by powers of two, which is exact in binary.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from povh3d.geometry.cameras import TIE_SHIFT, camera_mesh, ortho_view_shots, pinhole_shots
from povh3d.geometry.view_bank import bank_front_clearance
from povh3d.geometry.camera_mesh import MIN_FRONT_CLEARANCE, POVRAY_MAX_DEPTH, check_front_clearance, default_front_clearance, ray_stretch
from povh3d.errors import ConfigError
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays
from tests.support.oracles import mesh_in_mm, view_bank_mesh

MAX_ANGLE = 80.0  # degrees: the widest view the issue asks for


@st.composite
def lens_arrays(draw, grids=("square", "lenticular", "hex"), integral=None, max_pixels=4000):
    """A valid LensArray; ``integral`` True/False forces whole/fractional PPL."""
    grid = draw(st.sampled_from(grids))
    pitch = 10 ** draw(st.floats(-2, 1))                       # 10 um .. 10 mm
    whole = draw(st.booleans()) if integral is None else integral
    if grid == "hex":
        whole = True
    if whole:  # hex rows are 0.87 pitch apart: at least 2 PPL to span a pixel
        nx = draw(st.integers(2 if grid == "hex" else 1, 200))
    else:
        nx = draw(st.floats(1.05, 200).filter(lambda n: abs(n - round(n)) > 0.05))
    s = pitch / nx
    lx = draw(st.integers(1, max(1, min(40, int(max_pixels // (nx * 2)) or 1))))
    angle = draw(st.floats(1.0, MAX_ANGLE))                    # of the outermost pixel offset
    focal = (pitch / 2) / math.tan(math.radians(angle))
    width = math.ceil(lx * nx) + 2 * draw(st.integers(0, 2))
    if grid == "lenticular":
        rows = draw(st.integers(1, 6))
        return LensArray("lenticular", lx, rows, pitch, s, focal, Panel(width, rows, s, s))
    if grid == "hex":
        ly = draw(st.integers(1, 4))
        py = pitch * math.sqrt(3) / 2
        width = math.ceil(lx * nx + (nx / 2 if ly > 1 else 0)) + 1
        return LensArray("hex", lx, ly, pitch, py, focal, Panel(width, math.ceil(ly * py / s) + 1, s, s))
    ny = nx if draw(st.booleans()) else (draw(st.integers(1, 200)) if whole else nx)
    ly = draw(st.integers(1, max(1, min(4, int(max_pixels // (ny * lx * nx)) or 1))))
    height = math.ceil(ly * ny) + 2 * draw(st.integers(0, 2))
    return LensArray("square", lx, ly, pitch, ny * s, focal, Panel(width, height, s, s))


SETTINGS = settings(max_examples=60, deadline=None, derandomize=True)  # CI runs are repeatable
FEWER = settings(max_examples=25, deadline=None, derandomize=True)  # the costlier properties


@SETTINGS
@given(la=lens_arrays())
def test_lens_centres_follow_the_index_formula_and_are_symmetric(la):
    c = la.lens_centres()
    assert c.shape == (la.lenses_y, la.lenses_x, 2) and np.isfinite(c).all()
    j = np.arange(la.lenses_x)
    i = np.arange(la.lenses_y)
    expect_x = (j + 0.5 - la.lenses_x / 2) * la.pitch_x
    np.testing.assert_array_equal(c[0, :, 0], expect_x)
    np.testing.assert_array_equal(c[:, 0, 1], (la.lenses_y / 2 - i - 0.5) * la.pitch_y)
    # Mirror symmetry is exact: (j + 0.5 - L/2) is a small half-integer.
    if la.grid != "hex":
        np.testing.assert_array_equal(c[::-1, ::-1], -c)
    else:  # odd rows shifted right by half a pitch (docs/geometry.md)
        shift = c[1::2, :, 0] - expect_x[None, :]
        np.testing.assert_allclose(shift, la.pitch_x / 2, rtol=1e-12)
    # Neighbour spacing is the pitch to rounding of the coordinate, never accumulated.
    if la.lenses_x > 1:
        gaps = np.diff(c[0, :, 0])
        assert np.max(np.abs(gaps - la.pitch_x)) <= 4 * np.spacing(np.max(np.abs(c)) + la.pitch_x)


@SETTINGS
@given(la=lens_arrays(grids=("square", "lenticular"), integral=True))
def test_view_offsets_directions_and_angles(la):
    assume(la.views is not None)
    ny, nx = la.views
    u, v = la.view_offsets()
    s = la.panel.pitch_x
    assert u.shape == (nx,) and v.shape == (ny,)
    np.testing.assert_array_equal(u[::-1], -u)          # exact: symmetric about the lens centre
    np.testing.assert_array_equal(v[::-1], -v)
    assert np.all(np.abs(u) < la.pitch_x / 2) and np.all(np.abs(v) <= la.pitch_y / 2)
    if nx > 1:
        np.testing.assert_allclose(np.diff(u), s, rtol=1e-12)
        assert np.all(np.diff(u) > 0) and np.all(np.diff(la.view_angles_deg()[0]) > 0)
    if ny > 1:
        assert np.all(np.diff(v) < 0)                   # l = 0 is the top row: looks up
    d = la.view_directions()
    assert np.isfinite(d).all() and np.all(d[..., 2] > 0)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=1e-15, atol=2e-16)
    # Direction is (u, v, f) rescaled: d / d_z * f recovers the offsets.
    back = d / d[..., 2:3] * la.focal
    np.testing.assert_allclose(back[..., 0], np.broadcast_to(u, (ny, nx)), rtol=1e-13, atol=1e-13 * s)
    np.testing.assert_allclose(back[..., 1], np.broadcast_to(v[:, None], (ny, nx)), rtol=1e-13, atol=1e-13 * s)
    ah, av = la.view_angles_deg()
    np.testing.assert_allclose(np.tan(np.radians(ah)), u / la.focal, rtol=1e-12, atol=1e-15)
    assert np.all(np.abs(ah) <= MAX_ANGLE) and np.isfinite(av).all()


@FEWER
@given(la=lens_arrays(max_pixels=3000))
def test_pixel_rays_go_through_the_pixels_own_lens(la):
    centres, dirs, inside = pixel_rays(la)
    H, W = la.panel.height, la.panel.width
    assert centres.shape == (H, W, 2) and dirs.shape == (H, W, 3) and inside.shape == (H, W)
    assert inside.any()
    assert np.isfinite(centres[inside]).all() and np.isfinite(dirs[inside]).all()
    assert np.isnan(dirs[~inside]).all()                # undefined outside every lens, never garbage
    np.testing.assert_allclose(np.linalg.norm(dirs[inside], axis=-1), 1.0, rtol=1e-14)
    X, Y = np.meshgrid(*la.panel.pixel_centres())
    u, v = X - centres[..., 0], Y - centres[..., 1]
    # The pixel centre lies in its lens's cell ...
    tol = 1e-9 * la.pitch_x
    if la.grid == "hex":
        assert np.all(np.hypot(u, v)[inside] <= la.pitch_x / math.sqrt(3) + tol)
    else:
        assert np.all(np.abs(u[inside]) <= la.pitch_x / 2 + tol)
        assert np.all(np.abs(v[inside]) <= la.pitch_y / 2 + tol)
    # ... and the ray's direction is (u, v, f) normalised (lenticular: v = 0).
    if la.grid == "lenticular":
        v = np.zeros_like(v)
    expect = np.stack([u, v, np.full(u.shape, la.focal)], -1)
    expect /= np.linalg.norm(expect, axis=-1, keepdims=True)
    np.testing.assert_allclose(dirs[inside], expect[inside], rtol=1e-12, atol=1e-15)


@SETTINGS
@given(la=lens_arrays(grids=("square", "lenticular"), integral=True, max_pixels=3000))
def test_bank_region_is_centred_and_pixel_rays_match_the_views(la):
    assume(la.views is not None)
    rows, cols = la.bank_region
    assert (rows.stop - rows.start, cols.stop - cols.start) == la.h3d_size
    assert rows.start == la.panel.height - rows.stop and cols.start == la.panel.width - cols.stop
    centres, dirs, inside = pixel_rays(la)
    assert inside[rows, cols].all()
    ny, nx = la.views
    # docs/geometry.md: H3D[i*Ny + l, j*Nx + k] is lens (j, i) seen in view (l, k).
    bank = dirs[rows, cols].reshape(la.lenses_y, ny, la.lenses_x, nx, 3)
    # u = X - cx carries the rounding of the panel coordinate X (a centre view's u is ~1e-16 * X).
    atol = 4 * np.finfo(float).eps * max(la.panel.size_mm) / la.focal
    np.testing.assert_allclose(bank, np.broadcast_to(la.view_directions()[None, :, None], bank.shape),
                               rtol=1e-12, atol=atol)
    lc = centres[rows, cols].reshape(la.lenses_y, ny, la.lenses_x, nx, 2)
    np.testing.assert_array_equal(lc, np.broadcast_to(la.lens_centres()[:, None, :, None], lc.shape))


@FEWER
@given(la=lens_arrays(max_pixels=2000), exponent=st.integers(-10, 10))
def test_scaling_by_a_power_of_two_is_exact(la, exponent):
    k = 2.0 ** exponent
    p = la.panel
    scaled = LensArray(la.grid, la.lenses_x, la.lenses_y, la.pitch_x * k, la.pitch_y * k, la.focal * k,
                       Panel(p.width, p.height, p.pitch_x * k, p.pitch_y * k))
    np.testing.assert_array_equal(scaled.lens_centres(), la.lens_centres() * k)
    c0, d0, in0 = pixel_rays(la)
    c1, d1, in1 = pixel_rays(scaled)
    np.testing.assert_array_equal(in0, in1)
    np.testing.assert_array_equal(c1[in1], c0[in0] * k)
    np.testing.assert_array_equal(d1[in1], d0[in0])


# -- camera geometry ----------------------------------------------------------------

def _corner_hits(mesh):
    """Where each vertex's ray (origin, normal) crosses z = 0, and the unit normals."""
    mesh = mesh_in_mm(mesh)
    n = mesh.normals / np.linalg.norm(mesh.normals, axis=-1, keepdims=True)
    t = -mesh.vertices[:, 2] / n[:, 2]
    return mesh.vertices[:, :2] + t[:, None] * n[:, :2], n


@SETTINGS
@given(la=lens_arrays(grids=("square", "lenticular"), integral=True))
def test_view_bank_mesh_corner_rays_cross_the_lens_grid(la):
    assume(la.views is not None)
    front_clearance = default_front_clearance(la)
    mesh = view_bank_mesh(la, front_clearance)
    for a in (mesh.vertices, mesh.normals, mesh.uvs):
        assert np.isfinite(a).all()
    # Rays start at the clearance rounded up to a multiple of f lcm(Nx, Ny), never nearer.
    start = bank_front_clearance(la, front_clearance)
    unit = la.focal * math.lcm(*la.views)
    assert front_clearance <= start < front_clearance + unit * (1 + 1e-9)
    assert np.all(mesh_in_mm(mesh).vertices[:, 2] == -start)
    # ... so every corner, in lens pitches, is stored exactly in POV-Ray's single precision.
    assert np.array_equal(mesh.vertices[:, :2].astype(np.float32).astype(float), mesh.vertices[:, :2])
    hit, n = _corner_hits(mesh)
    c = la.lens_centres()
    left, right = c[0, 0, 0] - la.pitch_x / 2, c[0, -1, 0] + la.pitch_x / 2
    top, bottom = c[0, 0, 1] + la.pitch_y / 2, c[-1, 0, 1] - la.pitch_y / 2
    expect = np.tile([[left, bottom], [right, bottom], [right, top], [left, top]], (len(hit) // 4, 1))
    scale = np.abs(mesh_in_mm(mesh).vertices[:, :2]).max() + np.abs(expect).max()
    np.testing.assert_allclose(hit, expect, rtol=0, atol=16 * np.finfo(float).eps * scale)
    # One direction per view, the view's own.
    np.testing.assert_allclose(n.reshape(-1, 4, 3), np.repeat(la.view_directions().reshape(-1, 1, 3), 4, 1),
                               rtol=1e-12, atol=1e-15)


@SETTINGS
@given(la=lens_arrays(grids=("square", "lenticular"), max_pixels=2000))
def test_per_lens_camera_mesh_corner_rays_meet_at_their_lens_centre(la):
    front_clearance = default_front_clearance(la)
    mesh = camera_mesh(la, front_clearance)
    assert np.isfinite(mesh.vertices).all() and np.isfinite(mesh.normals).all() and np.isfinite(mesh.uvs).all()
    hit, _ = _corner_hits(mesh)
    if la.grid == "lenticular":
        expect_x = np.repeat(la.lens_centres()[0, :, 0], 4)
        scale = np.abs(mesh.vertices).max()
        np.testing.assert_allclose(hit[:, 0], expect_x, rtol=0, atol=16 * np.finfo(float).eps * scale)
    else:
        expect = np.repeat(la.lens_centres().reshape(-1, 2), 4, axis=0)
        scale = np.abs(mesh.vertices).max()
        np.testing.assert_allclose(hit, expect, rtol=0, atol=16 * np.finfo(float).eps * scale)
    # Corners of one lens share one normal length (interpolating unit normals is exact),
    # unless lens borders run through pixel centres and the quads moved by TIE_SHIFT.
    lengths = np.linalg.norm(mesh.normals, axis=-1).reshape(-1, 4)
    corner = mesh.normals[:, :2].reshape(-1, 4, 2)
    tie = np.any(np.abs(corner + corner[:, [2, 3, 0, 1]]) > 1e-9 * np.abs(corner).max())  # not symmetric
    # With the shift d: |n|^2 changes by 4 (px/2) d, relatively at most d/f per axis.
    bound = 2 * TIE_SHIFT * max(la.panel.pitch_x, la.panel.pitch_y) / la.focal
    np.testing.assert_allclose(lengths, lengths[:, :1].repeat(4, 1), rtol=bound if tie else 1e-14)


@FEWER
@given(la=lens_arrays(grids=("square", "lenticular"), integral=True))
def test_ortho_and_pinhole_frames_are_finite_and_exact(la):
    assume(la.views is not None)
    common, frames = ortho_view_shots(la)
    u, v = la.view_offsets()
    dirs = np.array([f["direction"] for f in frames])
    assert np.isfinite(dirs).all() and np.all(dirs[:, 2] == 1.0)
    np.testing.assert_array_equal(dirs[:, 0], np.tile(u / la.focal, len(v)))
    assert np.isfinite(common["right"]).all() and np.isfinite(common["up"]).all()
    common, frames = pinhole_shots(la)
    centres = np.array([f["centre"] for f in frames])[:, :2]
    np.testing.assert_array_equal(centres, la.lens_centres().reshape(-1, 2))


# -- POV-Ray's single precision ----------------------------------------------------------

def _float32_crossing_error(la):
    """Largest distance, mm, between where POV-Ray's stored (float32) corner rays cross
    z = 0 and where docs/geometry.md puts them (float64)."""
    mesh = view_bank_mesh(la, default_front_clearance(la))
    exact, _ = _corner_hits(mesh)
    stored = type(mesh)(mesh.vertices.astype(np.float32).astype(float),
                        mesh.normals.astype(np.float32).astype(float), mesh.uvs, mesh.faces, mesh.image_size,
                        mesh.scale)
    hit, _ = _corner_hits(stored)
    return float(np.abs(hit - exact).max())


@pytest.mark.parametrize("ppl", [2, 8, 200])
@pytest.mark.parametrize("angle", [15.0, 80.0])
def test_4000_lenses_keep_the_sample_grid_in_single_precision(ppl, angle):
    """POV-Ray stores mesh vertices and normals as float32: the sample grid of 4000
    lenses must stay on the lens centres to a small fraction of a lens pitch."""
    s = 0.01
    pitch = ppl * s
    f = (ppl / 2 - 0.5 if ppl > 1 else 0.5) * s / math.tan(math.radians(angle))
    la = LensArray("lenticular", 4000, 1, pitch, s, f, Panel(4000 * ppl, 1, s, s))
    err = _float32_crossing_error(la)
    assert err <= 0.01 * pitch, f"sample grid off by {err / pitch:.2g} lens pitch"


# -- the clearance POV-Ray can trace --------------------------------------------------------

@SETTINGS
@given(la=lens_arrays(max_pixels=2000))
def test_default_clearance_is_traceable_and_refusals_name_the_range(la):
    front_clearance = default_front_clearance(la)
    assert front_clearance >= MIN_FRONT_CLEARANCE
    if front_clearance * ray_stretch(la) <= POVRAY_MAX_DEPTH / 2:
        check_front_clearance(la, front_clearance)
    with pytest.raises(ConfigError, match=r"front_clearance 0\.01 or more"):
        check_front_clearance(la, MIN_FRONT_CLEARANCE / 2)
    too_far = POVRAY_MAX_DEPTH / ray_stretch(la)
    with pytest.raises(ConfigError, match=r"between 0\.01 and"):
        check_front_clearance(la, too_far)


def test_ray_stretch_is_the_most_oblique_pixel():
    la = LensArray("square", 2, 2, 0.4, 0.4, 0.1, Panel(8, 8, 0.1, 0.1))
    assert ray_stretch(la) == pytest.approx(math.sqrt(0.2**2 + 0.2**2 + 0.1**2) / 0.1)
    _, dirs, inside = pixel_rays(la)
    assert np.max(1 / dirs[inside][:, 2]) <= ray_stretch(la)
