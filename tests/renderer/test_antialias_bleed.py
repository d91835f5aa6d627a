"""Antialiasing stays inside each pixel's own footprint: every method, grid and quality.

The set-up of issue 21 (item 4): an emissive L on a black background, a thin slab
6 mm behind the screen lit where ``x > X_EDGE`` or ``y < Y_EDGE`` (the right and the
lower third), so that a view's first row and column, which POV-Ray's mesh camera
gave the shared corners of the tile before, are dark and that tile's last ones lit.
docs/geometry.md's footprint of a pixel is its lens aperture times its angular
width; where that whole box meets the plane ``z = Z_SLAB`` off the L ("dark"
pixels), no sample of any quality may see the slab: the pixel reads 0.  The
oracle is the ray of a pixel (``pixel_rays``) with the footprint's extent at the
plane; it is validated on renders known to be right (point-sampled ``draft``,
which lights every "lit" pixel fully and no dark one; ``multi-ortho-views`` and
``pinhole``, one image per view or lens) and kept with its negative control, the
one-pass view bank as it was (views tiled edge to edge at ``normal``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from povh3d.renderer.shots.shots import render_shots
from povh3d.renderer.methods.registry import display_header, run_method, _multi_ortho
from povh3d.renderer.methods.quality import QUALITY_LEVELS, RenderSettings
from povh3d.display.subpixel import sheet_phase, subpixel_array
from povh3d.geometry.camera_mesh import default_front_clearance
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays
from povh3d.scene.scene import load_scene

from tests.support.arrays import lenticular_array, square_array

pytestmark = pytest.mark.povray  # every test here renders with POV-Ray

Z_SLAB = 6.0
X_EDGE, Y_EDGE = 0.8, -0.6   # mm: the lit L is x > X_EDGE or y < Y_EDGE

SQUARE = square_array(lx=12, ly=9, nx=4, ny=4, s=0.1, f=1.5)
LENTICULAR = lenticular_array(lx=12, rows=36, nx=4, s=0.1, f=1.5)
HEX = LensArray("hex", 11, 10, 0.4, 0.4 * math.sqrt(3) / 2, 1.5, Panel(48, 36, 0.1, 0.1))
# 6.5 pixels per lens: lens borders through pixels (one quad per lens).
FRACTIONAL = LensArray("square", 7, 5, 0.65, 0.65, 1.5, Panel(48, 36, 0.1, 0.1))
# The Philips sheet (tests/renderer/test_subpixel.py): 4.5 subpixels per lenticule, tan a = 1/6,
# rational, so that --method subpixel antialiases it.
_TURN = math.atan(1 / 6)
SLANTED = LensArray("lenticular", 101, 48, 0.15 * math.cos(_TURN), 0.1, 1.2, Panel(120, 48, 0.1, 0.1),
                    math.degrees(_TURN))

CASES = [
    ("multi-ortho", SQUARE), ("multi-ortho", LENTICULAR), ("multi-ortho", HEX), ("multi-ortho", FRACTIONAL),
    ("multi-ortho-views", SQUARE), ("multi-ortho-views", LENTICULAR),
    ("pinhole", SQUARE), ("pinhole", LENTICULAR),
    ("single-stage", SQUARE), ("single-stage", LENTICULAR), ("single-stage", HEX), ("single-stage", FRACTIONAL),
    ("subpixel", SLANTED),
]
GRID_NAME = {id(SQUARE): "square", id(LENTICULAR): "lenticular", id(HEX): "hex", id(FRACTIONAL): "square-6.5", id(SLANTED): "slanted"}


def write_lit_l(folder) -> object:
    path = folder / "lit_l.pov"
    z0, z1 = Z_SLAB, Z_SLAB + 0.01
    path.write_text(f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
background {{ rgb 0 }}
union {{
  box {{ <{X_EDGE!r}, -1000, {z0!r}>, <1000, 1000, {z1!r}> }}
  box {{ <-1000, -1000, {z0!r}>, <1000, {Y_EDGE!r}, {z1!r}> }}
  pigment {{ rgb 1 }} finish {{ emission 1 diffuse 0 ambient 0 }}
}}
""")
    return load_scene(path)


def footprint_classes(la: LensArray) -> tuple[np.ndarray, np.ndarray]:
    """(H, W) bool twice: pixels whose whole footprint meets ``z = Z_SLAB`` off the L
    (dark), and wholly on it (lit).  The footprint's extent there: the aperture (its
    bounding box on a turned sheet; lenticular: the pixel's own height along the
    lenticule) plus the angular width ``s/2`` per mm of ``f`` times the depth."""
    centres, dirs, inside = pixel_rays(la)
    hit = centres + dirs[..., :2] * (Z_SLAB / dirs[..., 2])[..., None]
    theta = np.radians(la.rotation)
    c, s = abs(np.cos(theta)), abs(np.sin(theta))
    if la.grid == "hex":
        hx = hy = la.pitch_x / np.sqrt(3)
    else:
        hx = la.pitch_x / 2
        hy = la.panel.pitch_y / 2 if la.grid == "lenticular" else la.pitch_y / 2
        hx, hy = c * hx + s * hy, s * hx + c * hy
    half_x = hx + Z_SLAB * la.panel.pitch_x / 2 / la.focal + 1e-6
    half_y = hy + Z_SLAB * la.panel.pitch_y / 2 / la.focal + 1e-6
    x, y = hit[..., 0], hit[..., 1]
    dark = inside & (x + half_x < X_EDGE) & (y - half_y > Y_EDGE)
    lit = inside & ((x - half_x > X_EDGE) | (y + half_y < Y_EDGE))
    return dark, lit


def classes_of(method: str, la: LensArray) -> tuple[np.ndarray, np.ndarray]:
    """Dark and lit pixels of the image ``method`` writes: the panel's, or for ``subpixel``
    each R, G, B subpixel's own (``(H, W, 3)``; channel c of pixel col is subpixel 3 col + c)."""
    if method != "subpixel":
        dark, lit = footprint_classes(la)
        return dark[..., None], lit[..., None]
    dark, lit = footprint_classes(subpixel_array(la))
    # --method subpixel models the light of a subpixel's whole area, which passes through
    # whichever lenticule lies over each point of it (``phase_tiles.tiles_mesh``): a subpixel
    # across a lenticule border lights through both.  Those are left out here.
    _, phase = sheet_phase(la)
    turn = np.radians(la.rotation)
    sx, sy = la.panel.pitch_x / 3, la.panel.pitch_y
    half = (sx * abs(np.cos(turn)) + sy * abs(np.sin(turn))) / 2 / la.pitch_x   # of the lenticule, across
    dark &= (phase > half) & (phase < 1 - half)
    h, w = la.panel.height, la.panel.width
    return dark.reshape(h, w, 3), lit.reshape(h, w, 3)


def bleed(image: np.ndarray, dark: np.ndarray) -> int:
    """The brightest dark pixel (8-bit; 0: no light from outside any footprint)."""
    rgb = image[..., :3].astype(int)
    return int(np.max(np.where(dark, rgb, 0)))


@pytest.mark.parametrize("quality", list(QUALITY_LEVELS))
@pytest.mark.parametrize("method, la", CASES, ids=[f"{m}-{GRID_NAME[id(la)]}" for m, la in CASES])
def test_no_light_from_outside_the_footprint(tmp_path, method, la, quality):
    scene = write_lit_l(tmp_path)
    dark, lit = classes_of(method, la)
    assert dark.mean() > 0.2 and lit.mean() > 0.1, "test set-up: too few dark or lit pixels"
    result = run_method(method, scene, la, RenderSettings(quality=quality, use_cache=False))
    assert bleed(result.h3d, dark) == 0
    if quality == "draft" and method != "single-stage":
        # The oracle's other half, point-sampled: every lit pixel sees the slab fully.
        assert np.all(np.where(lit, result.h3d[..., :3], 255) == 255)


def test_views_tiled_edge_to_edge_bleed(tmp_path):
    # The negative control: the one-pass bank of today's normal as it was, no gutters.
    scene = write_lit_l(tmp_path)
    la = SQUARE
    plan = _multi_ortho(la, default_front_clearance(la), np.zeros((1, 4)), gutter=0)
    settings = RenderSettings(quality="normal", use_cache=False)
    images, _ = render_shots(scene, plan.batch, settings, method="multi-ortho", header=display_header(la))
    dark, _ = classes_of("multi-ortho", la)
    assert bleed(plan.assemble(images), dark) > 50


@pytest.mark.parametrize("la", [HEX, FRACTIONAL, LensArray("square", 7, 5, 0.6, 0.6, 1.5, Panel(48, 36, 0.1, 0.1), 9.46)],
                         ids=["hex", "square-6.5", "square-turned"])
def test_lens_mesh_samples_are_footprint_rays(la):
    # POV-Ray's lookup simulated in NumPy (normals normalised before they are interpolated),
    # then the mesh's direction shear: every pixel's sample ray crosses z = 0 at its own lens
    # centre plus the aperture sample, with its own direction plus the angular sample.
    from tests.geometry.test_rotated_lattice import simulate_lookup
    from povh3d.geometry.lattice_mesh import lens_mesh

    ax, ay, du, dv = 0.3, -0.2, 0.4, -0.35
    front_clearance = 20.0
    mesh = lens_mesh(la, front_clearance, sample=(ax, ay, du, dv))
    a, b = mesh.direction_shear
    origin, normal, _ = (mesh.crop(x[1:, :-1]) for x in simulate_lookup(mesh))
    origin[..., 2] -= a * origin[..., 0] + b * origin[..., 1]        # points by the matrix
    normal = normal + np.stack([a * normal[..., 2], b * normal[..., 2], 0 * normal[..., 2]], axis=-1)  # directions
    slope = normal[..., :2] / normal[..., 2:]
    crossing = origin[..., :2] - slope * origin[..., 2:]
    centres, dirs, inside = pixel_rays(la)
    step = np.array(la.from_lattice(ax * la.pitch_x, ay * la.pitch_y))
    s = np.array([la.panel.pitch_x, la.panel.pitch_y])
    np.testing.assert_allclose(crossing[inside], (centres + step)[inside], atol=1e-9)
    np.testing.assert_allclose(slope[inside], (dirs[..., :2] / dirs[..., 2:] + np.array([du, dv]) * s / la.focal)[inside],
                               atol=1e-9)
    # The negative control: the same offsets put into the normals bend the rays (POV-Ray's normalisation).
    plain = lens_mesh(la, front_clearance)
    bent = replace(plain, normals=plain.normals + np.array([du * s[0], dv * s[1], 0.0]))
    _, n2, _ = (plain.crop(x[1:, :-1]) for x in simulate_lookup(bent))
    error = np.abs(n2[..., :2] / n2[..., 2:] - (dirs[..., :2] / dirs[..., 2:] + np.array([du, dv]) * s / la.focal))
    assert error[inside].max() > 1e-4
