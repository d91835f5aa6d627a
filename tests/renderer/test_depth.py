"""The depth pass against analytic depths: a plane and a sphere, native and through a frame."""

from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest

from povh3d.renderer.passes.depth import depth_pass
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.geometry.pose import DisplayPose
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.scene.scene import load_scene

pytestmark = pytest.mark.povray  # every test here starts POV-Ray

SCENE = """#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
#ifndef (T) #declare T = transform {{ scale 1 }} #end
light_source {{ <-40, 60, -80> rgb 1 transform T }}
sphere {{ <0, 0, 0>, 6 pigment {{ rgb <0.9, 0.4, 0.1> }} transform T }}
plane {{ -z, -{far} pigment {{ checker rgb 0.9 rgb 0 scale 3 }} transform T }}
"""


def array() -> LensArray:
    return LensArray(grid="square", lenses_x=40, lenses_y=30, pitch_x=0.8, pitch_y=0.8, focal=1.5,
                     panel=Panel(320, 240, 0.1, 0.1))


def expected(shape: tuple[int, int], width: float, height: float, far: float) -> tuple[np.ndarray, np.ndarray]:
    h, w = shape
    x = ((np.arange(w) + 0.5) / w - 0.5) * width
    y = (0.5 - (np.arange(h) + 0.5) / h) * height
    xx, yy = np.meshgrid(x, y)
    r2 = xx ** 2 + yy ** 2
    z = np.where(r2 < 36, -np.sqrt(np.clip(36 - r2, 0, None)), far)
    return z, np.abs(np.sqrt(r2) - 6) > 0.3   # away from the silhouette


@pytest.mark.parametrize("moved", [False, True])
def test_depth_of_a_sphere_before_a_plane(tmp_path, moved):
    far = 5.0
    scene = tmp_path / "s.pov"
    text = SCENE.format(far=far)
    settings = RenderSettings()
    units = 1.0
    if moved:  # the same scene moved and scaled, measured through the same map as a frame
        text = "#declare T = transform { rotate <10, 30, 0> scale 40 translate <500, 20, -70> }\n" + text
        ax, ay = np.radians([10, 30])
        rx = np.array([[1, 0, 0], [0, np.cos(ax), np.sin(ax)], [0, -np.sin(ax), np.cos(ax)]])
        ry = np.array([[np.cos(ay), 0, -np.sin(ay)], [0, 1, 0], [np.sin(ay), 0, np.cos(ay)]])
        r = rx @ ry
        frame = DisplayPose((500, 20, -70), r[0], r[1], r[2], 40.0, "explicit")
        settings = RenderSettings(pose=tuple(frame.matrix().ravel()))
        units = 40.0
    scene.write_text(text)
    a = array()
    depth = depth_pass(load_scene(scene), a, settings, 4 * 32.0, units)
    z, clean = expected(depth.z.shape, depth.width_mm, depth.height_mm, far)
    ok = clean & np.isfinite(depth.z)
    assert ok.mean() > 0.9
    assert np.abs(depth.z - z)[ok].max() < 0.02      # mm
    s = depth.summary(12.0)
    h, w = z.shape
    middle = z[h // 4:h - h // 4, w // 4:w - w // 4]
    assert s["near_mm"] == pytest.approx(np.percentile(middle, 5), abs=0.05)
    assert s["far_mm"] == pytest.approx(np.percentile(middle, 95), abs=0.05)
    assert s["within_budget"]
    assert not depth.summary(8.0)["within_budget"]   # negative control: a tighter budget


def test_a_viewpoint_inside_a_solid_is_measured_on_the_hollow_copy(tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE.format(far=5.0).replace("plane { -z, -5", "plane { z, 5"))
    depth = depth_pass(load_scene(scene), array(), RenderSettings(), 128.0, 1.0)
    assert depth.hollow_copy and depth.unmeasured == 0.0 and np.isfinite(depth.z).mean() > 0.9


def test_view_depth_maps_against_ray_sphere_and_plane(tmp_path):
    """Every view's depth map: the distance along its rays (through the lens centres) to the sphere or plane."""
    from povh3d.renderer.passes.depth import view_depth_maps

    far = 5.0
    scene = tmp_path / "s.pov"
    scene.write_text(SCENE.format(far=far))
    a = LensArray(grid="square", lenses_x=24, lenses_y=18, pitch_x=1.2, pitch_y=1.2, focal=2.0,
                  panel=Panel(96, 72, 0.3, 0.3))
    maps = view_depth_maps(load_scene(scene), a, RenderSettings(), 40.0, 1.0)
    ny, nx = a.require_views()
    assert maps.shape == (ny, nx, 18, 24)
    cx = (np.arange(24) + 0.5 - 12) * 1.2
    cy = (9 - np.arange(18) - 0.5) * 1.2
    c = np.stack([*np.meshgrid(cx, cy), np.zeros((18, 24))], axis=-1)
    worst = 0.0
    for l, k in [(0, 0), (ny // 2, nx // 2), (ny - 1, 1)]:
        d = np.array([(k + 0.5 - nx / 2) * 0.3 / 2.0, (ny / 2 - l - 0.5) * 0.3 / 2.0, 1.0])
        d /= np.linalg.norm(d)
        # sphere |c + t d| = 6: t = -(c.d) - sqrt((c.d)^2 - |c|^2 + 36), the nearer root
        cd = c @ d
        disc = cd ** 2 - (c ** 2).sum(-1) + 36
        t_sphere = np.where(disc > 0, -cd - np.sqrt(np.clip(disc, 0, None)), np.inf)
        t_plane = (far - c[..., 2]) / d[2]
        expected = np.minimum(t_sphere, t_plane)
        clean = (np.abs(disc) > 1.0) & np.isfinite(maps[l, k])
        assert clean.mean() > 0.8
        worst = max(worst, float(np.abs(maps[l, k] - expected)[clean].max()))
    assert worst < 0.02   # mm


# Issue 21: the viewpoint inside a solid (a backdrop plane, a closed room) and bright surfaces.
# Every depth below is analytic: the pass looks along +z from z = -128 mm, so a face at z = Z
# reads Z; the sphere of SCENE reads -sqrt(36 - r^2).
INSIDE = {
    # plane { z, 10 }: its inside is z < 10, the side that holds the viewer
    "backdrop plane": ("plane {{ z, 10 pigment {{ rgb 0.5 }} {hollow} }}", 10.0),
    # a room: a box round the field and the ray starts, its back wall at z = 12
    "closed room": ("box {{ <-60, -60, -300>, <60, 60, 12> pigment {{ rgb 0.5 }} {hollow} }}", 12.0),
}
BASE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
light_source { <-40, 60, -80> rgb 1 }
"""
SPHERE = "sphere { <0, 0, 0>, 6 pigment { rgb <0.9, 0.4, 0.1> } }\n"


def measure(tmp_path, text: str):
    scene = tmp_path / "s.pov"
    scene.write_text(BASE + text)
    return depth_pass(load_scene(scene), array(), RenderSettings(), 128.0, 1.0)


@pytest.mark.parametrize("kind", sorted(INSIDE))
def test_inside_a_solid_is_measured_on_the_hollow_copy(tmp_path, kind):
    """The viewer inside a non-hollow solid (issue 38): POV-Ray applies no fog there, so the pass is
    made again on a copy whose top-level objects are hollow, and reads the analytic depth."""
    solid, back = INSIDE[kind]
    depth = measure(tmp_path, SPHERE + solid.format(hollow=""))
    z, clean = expected(depth.z.shape, depth.width_mm, depth.height_mm, back)
    ok = clean & np.isfinite(depth.z)
    assert depth.hollow_copy and depth.unmeasured == 0.0 and ok.mean() > 0.9
    assert np.abs(depth.z - z)[ok].max() < 0.02      # mm
    s = depth.summary(40.0)
    assert "blind" not in s and s["empty"] is False and "hollow" in s["measured_on"]


@pytest.mark.parametrize("kind", sorted(INSIDE))
def test_a_solid_the_copy_cannot_reach_is_blind_and_says_so(tmp_path, kind):
    """Negative control: the solid comes from an include in another folder, which the copy does not
    rewrite (the user's files are never touched): still blind, with the cause and the fix in one line."""
    solid, _ = INSIDE[kind]
    other, folder = tmp_path / "lib", tmp_path / "scene"
    other.mkdir()
    folder.mkdir()
    (other / "solid.inc").write_text(solid.format(hollow=""))
    scene = folder / "s.pov"
    scene.write_text(BASE + SPHERE + '#include "solid.inc"\n')
    depth = depth_pass(load_scene(scene, (other,)), array(), RenderSettings(), 128.0, 1.0)
    assert depth.unmeasured > 0.9 and not np.isfinite(depth.z).any() and not depth.hollow_copy
    s = depth.summary(12.0)
    assert s["empty"] is False and s["blind"] is True
    assert "inside a solid" in s["reason"] and "'hollow'" in s["reason"] and "\n" not in s["reason"]


@pytest.mark.parametrize("kind", sorted(INSIDE))
def test_the_fix_named_measures_the_analytic_depth(tmp_path, kind):
    """The same scene with the solid 'hollow' (the fix the message names): the sphere before the
    backdrop or the room's back wall, each at its analytic depth."""
    solid, back = INSIDE[kind]
    depth = measure(tmp_path, SPHERE + solid.format(hollow="hollow"))
    z, clean = expected(depth.z.shape, depth.width_mm, depth.height_mm, back)
    ok = clean & np.isfinite(depth.z)
    assert ok.mean() > 0.9 and depth.unmeasured == 0.0
    assert np.abs(depth.z - z)[ok].max() < 0.02      # mm
    s = depth.summary(40.0)
    assert "blind" not in s and s["empty"] is False
    assert s["field_far_mm"] == pytest.approx(back, abs=0.05)


def test_an_emissive_red_surface_is_measured(tmp_path):
    """A red slab brighter than 1 in red (ambient 1 plus its light) at z = 3 .. 4: red clips in the
    fog-1 render, green and blue measure it.  Before issue 21 every such pixel was NaN."""
    slab = "box { <-8, -6, 3>, <8, 6, 4> pigment { rgb <1, 0, 0> } finish { ambient 1 diffuse 0.6 } }\n"
    depth = measure(tmp_path, slab)
    h, w = depth.z.shape
    x = ((np.arange(w) + 0.5) / w - 0.5) * depth.width_mm
    y = (0.5 - (np.arange(h) + 0.5) / h) * depth.height_mm
    inside = (np.abs(x)[None, :] < 7.8) & (np.abs(y)[:, None] < 5.8)
    assert np.isfinite(depth.z[inside]).all()
    assert np.abs(depth.z[inside] - 3.0).max() < 0.02     # mm
    assert not np.isfinite(depth.z[~inside & (np.abs(x)[None, :] > 8.2)]).any()   # nothing hit beside it
    s = depth.summary(12.0)
    assert s["near_mm"] == pytest.approx(3.0, abs=0.02) and s["saturated_fraction"] == 0.0


def test_a_surface_bright_in_every_channel_is_reported_not_empty(tmp_path):
    """Negative control of the channel rule: a white slab brighter than 1 everywhere cannot be measured
    by fog; the pass says so (saturated), it does not guess a depth nor call the scene empty."""
    slab = "box { <-14, -10, 3>, <14, 10, 4> pigment { rgb 1 } finish { ambient 2 } }\n"
    depth = measure(tmp_path, slab)
    s = depth.summary(12.0)
    assert not np.isfinite(depth.z).any()
    assert s["saturated"] is True and s["empty"] is False and "brighter than 1" in s["reason"]
    assert s["saturated_fraction"] > 0.5


def test_nothing_there_is_still_empty(tmp_path):
    """Negative control of the blind rule: a scene with nothing in the field is empty, not blind."""
    s = measure(tmp_path, "sphere { <0, 0, 100>, 1 pigment { rgb 1 } translate <500, 0, 0> }\n").summary(12.0)
    assert s["empty"] is True and "blind" not in s and "reason" not in s


# The depth passes need POV-Ray's quality 9 for fog, which turns on the scene's radiosity and photons
# too; the passes turn them down (LIGHTING_OFF).  Before, advanced/diffuse_back.pov's camera-and-depth
# run took minutes (its pretrace goes down to 0.005), and a surface lit by radiosity read wrong: its
# sample rays cross the fog, so its colour differs between the two fog frames.
LIT = """global_settings {{ radiosity {{ pretrace_start 0.08 pretrace_end 0.02 count 60 nearest_count 5
  error_bound 0.5 recursion_limit 1 }} photons {{ count 20000 }} }}
sky_sphere {{ pigment {{ rgb <0.6, 0.7, 1> }} }}
sphere {{ <0, 0, 0>, 6 pigment {{ rgb <0.9, 0.4, 0.1> }} finish {{ reflection 0.3 }} photons {{ target reflection on }} }}
plane {{ -z, -{far} pigment {{ checker rgb 0.9 rgb 0.1 scale 3 }} }}
camera {{ location <0, 0, -60> look_at 0 angle 40 }}
"""
_SAMPLES = re.compile(r"Radiosity samples calculated:\s+(\d+)")
_RAYS = re.compile(r"Radiosity sample rays shot:\s+(\d+)")
_PHOTONS = re.compile(r"Number of photons shot:\s+(\d+)")


def _lighting_work(log: str) -> tuple[float, int]:
    """From a run's statistics: radiosity rays a sample (its ``count``; 0 without radiosity) and photons shot."""
    samples, rays, photons = (sum(map(int, r.findall(log))) for r in (_SAMPLES, _RAYS, _PHOTONS))
    return (rays / samples if samples else 0.0, photons)


def _turned_down(work: tuple[float, int]) -> bool:
    """LIGHTING_OFF's work: POV-Ray's least rays a sample (5), a photon a frame (a run has a few)."""
    return work[0] <= 5 and work[1] <= 10


@pytest.fixture
def povray_logs(monkeypatch):
    """Every POV-Ray run's (job name, log) while the test runs."""
    import povh3d.renderer.shots.shots as frames
    import povh3d.povray.process as process

    logs: list[tuple[str, str]] = []
    original = process.run_jobs

    def run_jobs(jobs, *, on_result=None, **kwargs):
        def keep(result):
            logs.append((result.job.name, result.log))
            if on_result is not None:
                on_result(result)
        return original(jobs, on_result=keep, **kwargs)

    monkeypatch.setattr(process, "run_jobs", run_jobs)
    monkeypatch.setattr(frames, "run_jobs", run_jobs)
    return logs


def test_povray_honours_the_later_lighting_settings(tmp_path):
    """The oracle: POV-Ray itself, on the scene alone and with LIGHTING_OFF's block after it (how the
    passes write it); the statistics count the radiosity samples and photons it traced."""
    from povh3d.renderer.passes.depth import LIGHTING_OFF

    scene = tmp_path / "lit.pov"
    scene.write_text(BASE + LIT.format(far=5.0))
    later = tmp_path / "later.pov"
    later.write_text(f'#include "{scene.name}"\nglobal_settings {{ '
                     + " ".join(f"{k} {v}" for k, v in LIGHTING_OFF.items()) + " }\n")

    def work(path):
        done = subprocess.run(["povray", f"+I{path.name}", "-D", "+Q9", "-A", "+W48", "+H36", "+WT1", "+Oout.png"],
                              cwd=tmp_path, capture_output=True, text=True, errors="replace",
                              check=True)
        return _lighting_work(done.stdout + done.stderr)

    rays, photons = work(scene)
    assert rays > 30 and photons > 5000       # the scene's own (count 60): the negative control
    rays, photons = work(later)
    assert _turned_down((rays, photons)) and photons == 1


def _lit_scene(tmp_path, lit_by: str, far: float):
    """LIT lit by the light of BASE, or by radiosity alone: no light source, a sky of 2."""
    base, text = BASE, LIT.format(far=far)
    if lit_by == "the sky alone":
        base, text = base.replace("light_source { <-40, 60, -80> rgb 1 }", ""), text.replace("rgb <0.6, 0.7, 1>", "rgb 2")
    scene = tmp_path / "lit.pov"
    scene.write_text(base + text)
    return scene


@pytest.mark.parametrize("lit_by", ["a light", "the sky alone"])
def test_the_depth_pass_turns_the_lighting_down_and_measures_the_analytic_depth(tmp_path, povray_logs, lit_by):
    """A few radiosity samples and photons, and the analytic depth of a sphere before a plane.  Lit by
    the sky alone, the scene's own radiosity (or any radiosity of full brightness) read the sphere and
    the plane up to 3 mm off, on 55 % of the field: its sample rays cross the fog."""
    far = 5.0
    scene = _lit_scene(tmp_path, lit_by, far)
    depth = depth_pass(load_scene(scene), array(), RenderSettings(use_cache=False), 128.0, 1.0)
    z, clean = expected(depth.z.shape, depth.width_mm, depth.height_mm, far)
    ok = clean & np.isfinite(depth.z)
    assert ok.mean() > 0.9 and np.abs(depth.z - z)[ok].max() < 0.02      # mm
    assert povray_logs and all(_turned_down(_lighting_work(log)) for _, log in povray_logs)


def test_the_scene_cameras_depth_run_turns_the_lighting_down(tmp_path, povray_logs, cli):
    """The render's camera-and-depth run (templates/camera_depth.pov.j2) writes the same settings."""
    scene = _lit_scene(tmp_path, "a light", 5.0)
    result = cli("render", scene, "--preset", "demo", "--quality", "draft", "--no-cache", "-q", "--depth-report",
                 "-o", tmp_path / "h3d.png")   # --depth-report: a plain render makes no depth pass
    assert result.code == 0, result.err
    runs = dict((name, _lighting_work(log)) for name, log in povray_logs)
    assert _turned_down(runs["scene camera and depth"])
    # negative control: the view renders keep the scene's own lighting
    assert any(rays > 30 and photons > 5000 for name, (rays, photons) in runs.items()
               if name != "scene camera and depth"), runs


# Lighting POV-Ray samples at random per render thread: at two threads, which take the pixels in another
# order in each frame, a surface's colour differs between the two fog frames.  Each: a sphere of 6 before
# a plane at z = 5 (``expected``).
RANDOM_PER_THREAD = {
    # its shadow's edge on the plane read 7-10 mm off in every pass at two threads
    "jittered area light": ("light_source { <-40, 60, -80> rgb 1 area_light 20*x, 20*y, 5, 5 jitter }\n"
                            + SPHERE + "plane { -z, -5 pigment { checker rgb 0.9 rgb 0 scale 3 } }\n"),
    # the sphere and plane read 20-24 mm off in about half the passes at two threads
    "subsurface scattering": (
        "global_settings { mm_per_unit 40 subsurface { samples 40, 4 } }\n"
        "sphere { <0, 0, 0>, 6 pigment { rgb <0.9, 0.4, 0.1> } finish { subsurface { translucency <0.46, 0.38, 0.33> } } }\n"
        "plane { -z, -5 pigment { checker rgb 0.9 rgb 0 scale 3 } finish { subsurface { translucency 0.5 } } }\n"),
}


@pytest.mark.parametrize("kind", sorted(RANDOM_PER_THREAD))
def test_lighting_sampled_at_random_is_measured_exactly(tmp_path, kind):
    """The pass runs at one thread (``PASS_THREADS``), so both fog frames draw the same samples, and turns
    subsurface scattering off (``LIGHTING_OFF``).  Four passes, each asked for two threads: a pass that
    is right only by the threads' luck fails one of them."""
    far = 5.0
    scene = tmp_path / "s.pov"
    scene.write_text(BASE + RANDOM_PER_THREAD[kind])
    for _ in range(4):
        depth = depth_pass(load_scene(scene), array(), RenderSettings(use_cache=False, threads=2), 128.0, 1.0)
        z, clean = expected(depth.z.shape, depth.width_mm, depth.height_mm, far)
        ok = clean & np.isfinite(depth.z)
        assert ok.mean() > 0.9 and np.abs(depth.z - z)[ok].max() < 0.02      # mm
