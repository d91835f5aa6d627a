"""Numerical stability, rendered: scale, pitch, pixels per lens, view angle, long rows.

Every render is point-sampled (``quality="draft"``): each pixel is the one ray
docs/geometry.md defines, so a pixel can only differ from its oracle where that ray
meets the scene within rounding distance of a pattern edge.  The oracles are
computed here in float64 from ``pixel_rays``; a pixel counts as clear when its
ray's hit point lies further than ``margin`` from every checker edge.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from tests.support.render import DRAFT, render
from povh3d.geometry.camera_mesh import MIN_FRONT_CLEARANCE
from povh3d.errors import ConfigError, PovrayError
from povh3d.geometry.footprint import CENTRE, angular_grid
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.geometry.rays import pixel_rays
from povh3d.renderer.methods import registry as methods
from povh3d.renderer.methods.registry import METHODS, display_header, run_method
from povh3d.geometry.pose import DisplayPose
from povh3d.scene.format import pov_number
from povh3d.povray.process import PovrayJob, run_jobs
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.renderer.shots.shots import build_script
from povh3d.scene.scene import load_scene

from tests.support.scenes import classify, write_checker_plane



def point_oracle(la: LensArray, z0: float, period: float, margin: float,
                 drift: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Checker parity where each pixel's ray meets ``z = z0``, and whether it is clear of edges.

    ``drift`` (lens pitches across the row) moves the sample grid linearly in x:
    the negative control for a renderer whose lens centres wander.
    """
    centres, dirs, inside = pixel_rays(la)
    hit = centres + dirs[..., :2] * (z0 / dirs[..., 2])[..., None]
    if la.grid == "lenticular":  # one lens per row: the ray stays in its pixel's row
        hit[..., 1] = la.panel.pixel_centres()[1][:, None]
    if drift:
        x = centres[..., 0]
        hit[..., 0] += drift * la.pitch_x * (x - np.nanmin(x)) / (np.nanmax(x) - np.nanmin(x))
    cells = np.floor(hit / period)
    parity = np.where(inside, (cells[..., 0] + cells[..., 1]) % 2, 0).astype(int)
    frac = hit / period - cells
    edge = np.minimum(frac, 1 - frac).min(axis=-1) * period
    return parity, inside & (edge > margin)


def assert_matches(h3d: np.ndarray, expected: np.ndarray, clear: np.ndarray, least: float = 0.999) -> None:
    assert clear.mean() > 0.8, "test set-up: too few pixels clear of the checker edges"
    match = np.mean(classify(h3d)[clear] == expected[clear])
    assert match >= least, f"{match:.5f} of clear pixels match the oracle"


# -- the same scene at 1e-3, 1 and 1e3 -----------------------------------------------------

LIT_SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
#declare S = {scale!r};
background {{ rgb <0.05, 0.05, 0.1> }}
light_source {{ <-30, 40, -60> * S rgb 1 }}
plane {{ z, 9.2 * S pigment {{ checker rgb <0.9, 0.9, 0.85> rgb <0.2, 0.3, 0.6> scale 0.9 * S }} finish {{ diffuse 0.8 }} }}
sphere {{ <-1.0, 0.3, 3> * S, 1.6 * S
  pigment {{ gradient x color_map {{ [0 rgb <0.9, 0.3, 0.1>] [1 rgb <1, 0.9, 0.5>] }} scale 0.7 * S }}
  finish {{ specular 0.4 roughness 0.02 }} }}
box {{ <-0.6, -0.6, -0.6> * S, <0.6, 0.6, 0.6> * S rotate <20, 35, 0> translate <1.5, -0.8, -2.0> * S
  pigment {{ rgb <0.1, 0.7, 0.2> }} }}
"""


def scaled_array(grid: str, scale: float) -> LensArray:
    s = 0.1 * scale
    if grid == "lenticular":
        return LensArray("lenticular", 24, 40, 6 * s, s, 1.5 * scale, Panel(144, 40, s, s))
    return LensArray("square", 24, 16, 6 * s, 6 * s, 1.5 * scale, Panel(144, 96, s, s))


def render_scaled(tmp_path: Path, method: str, grid: str, scale: float) -> np.ndarray:
    folder = tmp_path / f"scale-{scale:g}"
    folder.mkdir(exist_ok=True)
    path = folder / "lit.pov"
    path.write_text(LIT_SCENE.format(scale=scale))
    return run_method(method, load_scene(path), scaled_array(grid, scale), DRAFT).h3d.astype(int)


# Tolerance: a scaled ray meets the scaled scene at the scaled point, so only a
# hit within float rounding (~1e-15 relative) of a silhouette, shadow or pattern
# edge can flip, and noise-free pigments are continuous.  Measured: 0 of 13 824
# pixels differ at 1e-3 and 1e3.  Allowed: 0.2 % of pixels, by at most the
# difference of two neighbouring colours (any value), nothing else.
SCALE_TOLERANCE = 0.002


@pytest.mark.povray
@pytest.mark.parametrize("method, grid", [("multi-ortho", "square"), ("multi-ortho", "lenticular"),
                                          ("multi-ortho-views", "square")])
def test_same_scene_at_a_thousandth_one_and_a_thousand_gives_the_same_image(tmp_path, method, grid):
    reference = render_scaled(tmp_path, method, grid, 1.0)
    assert len(np.unique(reference.reshape(-1, 3), axis=0)) > 50, "test set-up: a blank render"
    for scale in (1e-3, 1e3):
        differ = np.abs(render_scaled(tmp_path, method, grid, scale) - reference).max(axis=-1) > 0
        assert differ.mean() <= SCALE_TOLERANCE, f"scale {scale:g}: {differ.mean():.4f} of pixels differ"


@pytest.mark.povray
def test_scale_comparison_fails_where_povray_loses_shadows(tmp_path):
    """Negative control, and POV-Ray's own limit: at 1e-4 the scene's features are
    ~1e-4 mm apart, inside POV-Ray's shadow tolerance, so shadows vanish.  That is
    the scene's scale, not the camera's (a plain 2D render loses them too)."""
    reference = render_scaled(tmp_path, "multi-ortho", "square", 1.0)
    differ = np.abs(render_scaled(tmp_path, "multi-ortho", "square", 1e-4) - reference).max(axis=-1) > 0
    assert differ.mean() > 10 * SCALE_TOLERANCE


@pytest.mark.povray
def test_micrometre_panel_sees_its_screen(tmp_path):
    """A 14 um wide panel (the demo scaled by 1e-6): the default clearance of four
    panel widths fell under POV-Ray's nearest intersection depth (1e-4 mm) and the
    image was black; the clearance floor keeps it exact."""
    scale = 1e-6
    la = scaled_array("square", scale)
    z0, period = 6 * scale, 2.5 * scale
    h3d = run_method("multi-ortho", load_scene(write_checker_plane(tmp_path, z0, period)), la, DRAFT).h3d
    expected, clear = point_oracle(la, z0, period, margin=1e-3 * period)
    assert_matches(h3d, expected, clear)


# -- pitch, pixels per lens and view angle ---------------------------------------------------

def array_for(grid: str, lenses: tuple[int, int], ppl: int, pitch: float, angle_deg: float,
              rows: int = 4) -> LensArray:
    """Lens array whose outermost pixel centre looks ``angle_deg`` off the axis."""
    s = pitch / ppl
    u_max = (ppl - 1) / 2 * s
    focal = u_max / math.tan(math.radians(angle_deg)) if u_max else pitch
    lx, ly = lenses
    if grid == "lenticular":
        return LensArray("lenticular", lx, rows, pitch, s, focal, Panel(lx * ppl, rows, s, s))
    return LensArray("square", lx, ly, pitch, pitch, focal, Panel(lx * ppl, ly * ppl, s, s))


CASES = {
    "10um-pitch": ("lenticular", (24, 1), 4, 0.01, 30.0),
    "10mm-pitch": ("square", (12, 8), 4, 10.0, 30.0),
    "1-ppl": ("square", (48, 32), 1, 0.1, 0.0),
    "200-ppl": ("lenticular", (2, 1), 200, 2.0, 45.0),
    "80-deg-square": ("square", (16, 12), 6, 0.6, 80.0),
    "80-deg-lenticular": ("lenticular", (16, 1), 8, 0.8, 80.0),
}


@pytest.mark.povray
@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("side", [1, -1], ids=["behind", "in-front"])
def test_extreme_arrays_trace_the_ray_of_every_pixel(tmp_path, case, side):
    grid, lenses, ppl, pitch, angle = CASES[case]
    la = array_for(grid, lenses, ppl, pitch, angle)
    z0 = side * 1.3 * la.focal               # hits spread over about one lens pitch per view step
    period = 0.37 * pitch
    h3d = run_method("multi-ortho", load_scene(write_checker_plane(tmp_path, z0, period)), la, DRAFT).h3d
    expected, clear = point_oracle(la, z0, period, margin=1e-3 * period)
    assert_matches(h3d, expected, clear)


@pytest.mark.povray
def test_80_degree_views_agree_between_both_bank_methods(tmp_path):
    la = array_for("square", (16, 12), 6, 0.6, 80.0)
    scene = load_scene(write_checker_plane(tmp_path, 0.3, 0.37 * 0.6))
    a = run_method("multi-ortho", scene, la, DRAFT).h3d
    b = run_method("multi-ortho-views", scene, la, DRAFT).h3d
    expected, clear = point_oracle(la, 0.3, 0.37 * 0.6, margin=1e-3 * 0.37 * 0.6)
    assert_matches(a, expected, clear)
    assert_matches(b, expected, clear)


# -- 4000 lenses in a row ------------------------------------------------------------------

LONG_ROW = array_for("lenticular", (4000, 1), 4, 0.4, 80.0, rows=2)
# POV-Ray keeps mesh vertices in float32: the sample grid of this row is off by at
# most ~2e-3 lens pitch (tests/test_geometry_properties.py); clear means 5e-3.
LONG_MARGIN = 5e-3 * LONG_ROW.pitch_x


@pytest.mark.povray
@pytest.mark.parametrize("method", ["multi-ortho", "multi-ortho-views"])
def test_4000_lenses_in_a_row_do_not_drift(tmp_path, method):
    """A checker of period 2.71 pitches 1.2 mm behind the screen: every lens sees a
    different phase, so a sample grid that wandered by a hundredth of a pitch
    anywhere along the row would flip pixels near the edges there."""
    la = LONG_ROW
    z0, period = 1.2, 2.71 * la.pitch_x
    h3d = run_method(method, load_scene(write_checker_plane(tmp_path, z0, period)), la, DRAFT).h3d
    expected, clear = point_oracle(la, z0, period, margin=LONG_MARGIN)
    assert_matches(h3d, expected, clear, least=1.0)
    # The same check fails for a grid that drifts by 0.05 pitch across the row.
    drifted, _ = point_oracle(la, z0, period, margin=LONG_MARGIN, drift=0.05)
    assert np.mean(classify(h3d)[clear] == drifted[clear]) < 0.999


# -- finite, round-tripping numbers ----------------------------------------------------------

_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])")
EXTREMES = [array_for(*CASES[name][:5]) for name in CASES] + [LONG_ROW]


# Pinhole writes one camera per lens: the 4000-lens row would be 4000 copies of one line.
# subpixel renders lenticular sheets only.
SCRIPT_CASES = [(m, i) for m in METHODS for i in range(len(EXTREMES))
                if not (m == "pinhole" and EXTREMES[i] is LONG_ROW)
                and not (m == "subpixel" and EXTREMES[i].grid != "lenticular")]


@pytest.mark.parametrize("method, index", SCRIPT_CASES)
def test_scripts_hold_only_finite_numbers(method, index):
    la = EXTREMES[index]
    # multi-ortho also with footprint samples (3x3 angular sub-views per pixel).
    samples = angular_grid(3) if method == "multi-ortho" and la.views else CENTRE
    try:
        batch = METHODS[method].plan(la, 4 * max(la.panel.size_mm), samples, **METHODS[method].options).batch
    except ConfigError as err:
        # Single-stage refuses lenslets no real index can make (45-80 degree views):
        # in one line, naming the focal length that works.
        assert method == "single-stage" and "lengthen focal to" in str(err), str(err)
        return
    script = build_script(batch, batch.shots, method=method, scene_path="/s.pov", add_assumed_gamma=True,
                          header=display_header(la))
    assert not re.search(r"\b(nan|inf|infinity)\b", script, re.I)
    numbers = [float(t) for t in _NUMBER.findall(script)]
    assert numbers and all(math.isfinite(x) for x in numbers)


ROUND_TRIP = [1e-300, 2.5e-9, 1 / 3 * 1e-5, -0.1, 2 / 3, 1.0000000000000002, 123456.789e3,
              -5.76e7, 9007199254740993.0, 1.5e20, 1e300]


@pytest.mark.povray
def test_povray_reads_our_numbers_back_exactly(tmp_path):
    """Each number as ``pov_number`` writes it (shortest repr, exponents like 1e-05)
    must parse to the same double as its 17-digit scientific form.  POV-Ray's ``!=``
    has an absolute tolerance (1e-10), so the check is on the ratio, scaled by 2**52:
    one unit in the last place apart gives 0.5 or 1."""
    def differ(a: str, b: str, label: str) -> str:
        return f'#if (abs({a} / {b} - 1) * 4503599627370496 > 0.25) #error "{label} read back wrong" #end'

    checks = "\n".join(differ(pov_number(x), f"{x:.17e}", pov_number(x)) for x in ROUND_TRIP)
    bad = differ(pov_number(0.1), "0.10000000000000002", "control")  # one ulp above 0.1
    for body, ok in ((checks, True), (bad, False)):
        script = f"#version 3.7;\n{body}\nbackground {{ rgb 1 }}\ncamera {{ location -z look_at 0 }}\n"
        job = PovrayJob(name="round trip", script=script, width=2, height=2, options=("-A",))
        if ok:
            run_jobs([job], processes=1)
        else:  # negative control: a value one ulp off is caught
            with pytest.raises(PovrayError, match="control"):
                run_jobs([job], processes=1)


# -- refusals --------------------------------------------------------------------------------

def test_clearance_beyond_povray_reach_is_refused_before_rendering(tmp_path):
    la = scaled_array("square", 1e6)      # a 14 km panel: the default clearance is 58 000 km
    out = tmp_path / "h3d.png"
    # multi-ortho's view bank starts whole steps of f x views (9e6 mm) out: past reach whatever the request
    with pytest.raises(ConfigError, match=r"POV-Ray can trace here; use method multi-ortho-views front_clearance"):
        render(write_checker_plane(tmp_path, 6e6, 2.5e6), la, out, settings=DRAFT)
    assert not out.exists() and not out.with_suffix(".json").exists()
    with pytest.raises(ConfigError, match=r"POV-Ray's 1e\+07 mm ray length.*front_clearance between 0\.01 and"):
        run_method("multi-ortho-views", load_scene(write_checker_plane(tmp_path, 6e6, 2.5e6)), la, DRAFT)
    with pytest.raises(ConfigError, match=f"under {MIN_FRONT_CLEARANCE:g} mm"):
        run_method("multi-ortho-views", load_scene(write_checker_plane(tmp_path, 1.0, 1.0)),
                   scaled_array("square", 1.0), RenderSettings(quality="draft", front_clearance=1e-3))


@pytest.mark.povray
def test_a_large_scale_ratio_is_checked_in_scene_units_and_its_advice_renders(tmp_path, monkeypatch):
    """Issue 22: at 1e6 scene units per mm the default clearance (four panel widths, 57.6 mm)
    is 5.8e7 scene units, past POV-Ray's 1e7 ray length.  Checked in mm it passed and the
    image came out black, exit 0; checked in scene units it is refused, and the clearance
    (or method) the refusal advises renders the analytic checker exactly."""
    la, units = scaled_array("square", 1.0), 1e6
    settings = replace(DRAFT, pose=tuple(DisplayPose(units_per_mm=units).matrix().ravel()))
    # 2 mm behind the screen: within the half of POV-Ray's ray length kept for the scene
    scene = load_scene(write_checker_plane(tmp_path, 2 * units, 1.5 * units))
    expected, clear = point_oracle(la, 2.0, 1.5, margin=1e-3 * 1.5)
    with pytest.raises(ConfigError, match="scene units") as refused:
        run_method("multi-ortho-views", scene, la, settings)
    advised = float(re.search(r"between \S+ and (\S+) mm", str(refused.value)).group(1))
    assert_matches(run_method("multi-ortho-views", scene, la, replace(settings, front_clearance=advised)).h3d,
                   expected, clear)
    # multi-ortho's view bank starts whole steps of f x views (9 mm) out, beyond reach here
    with pytest.raises(ConfigError, match="method multi-ortho-views") as refused:
        run_method("multi-ortho", scene, la, settings)
    advised = float(re.search(r"front_clearance (\S+) ", str(refused.value)).group(1))
    assert_matches(run_method("multi-ortho-views", scene, la, replace(settings, front_clearance=advised)).h3d,
                   expected, clear)
    # Negative control: the check in mm (one unit per mm) lets the default through, and it fails the oracle.
    monkeypatch.setattr(methods, "pose_units", lambda frame: 1.0)
    h3d = run_method("multi-ortho-views", scene, la, settings).h3d
    with pytest.raises(AssertionError, match="clear pixels match"):
        assert_matches(h3d, expected, clear)


# -- index of refraction close to 1 (single-stage lenslets) -------------------------

@pytest.mark.parametrize("ior", [1.001, 1.01, 1.1])
def test_conic_lenslet_close_to_ior_one_still_focuses_at_f(ior):
    from povh3d.geometry.optics import Lenslet
    from tests.support.oracles import trace_collimated

    lens = Lenslet("conic", "square", 0.8, 0.8, 1.5, ior)
    h = np.linspace(0.01, 0.999, 7) * lens.aperture_radius
    z, _ = trace_collimated(lens, h)
    np.testing.assert_allclose(z, 1.5, rtol=1e-6)
    assert all(np.isfinite(np.asarray(part, dtype=float)).all() for part in lens.quadric())
    assert np.isfinite(lens.thickness) and lens.thickness < 10 * 1.5 * 1.1


@pytest.mark.parametrize("ior", [1 + 1e-12, 1 + 1e-9, 1 + 1e-6, 1.0001])
def test_ior_too_close_to_one_is_refused_not_mistraced(ior):
    # Negative control for the refusal: at n - 1 = 1e-9 the conic's maths focused
    # collimated light at half the focal length (and the lens was 12.6 m deep).
    from povh3d.geometry.optics import Lenslet

    with pytest.raises(ConfigError, match=r"raise ior \(at least about 1\.00"):
        Lenslet("conic", "square", 0.8, 0.8, 1.5, ior)
