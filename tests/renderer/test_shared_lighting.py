"""One radiosity solution for every view of a still (``renderer.shots.lighting``).

The oracle is POV-Ray's own spread: ``multi-ortho`` traces the very same rays as the views of
``multi-ortho-views`` (one mesh-camera image instead of one orthographic render a view), and its
lighting differs from the independent views' as one realization of radiosity from another
(docs/methods.md, "Radiosity through the mesh camera").  A view lit by the shared solution must
differ from its independent render by no more than that; a solution computed with a radiosity
``count`` of 3 (the negative control) differs by far more.  That the later runs load rather than
compute is read from POV-Ray's statistics: the samples each of their frames computes, against an
independent frame's.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from povh3d.image.interleave import extract
from povh3d.image.metrics import psnr
from povh3d.povray.job import PovrayJob
from povh3d.povray.log import parse_radiosity
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.renderer.methods.registry import METHODS, display_header
from povh3d.renderer.shots.batch import ShotBatch
from povh3d.renderer.shots.lighting import SharedLighting, loading_header, shared_lighting
from povh3d.renderer.shots.shots import render_shots
from povh3d.scene.scene import load_scene
from tests.support.arrays import square_array

# A closed white room (red and green side walls) lit by one light, a yellow ball on its floor: the
# walls take light bounced off each other, which radiosity samples.  The room reaches behind the plane
# where the views' rays start (30 mm out).
ROOM = """#version 3.7;
global_settings {{ assumed_gamma 1 radiosity {{ {radiosity} }} }}
box {{ <-8, -6, -40>, <8, 6, 6> inverse pigment {{ rgb 1 }} finish {{ ambient 0 diffuse 0.8 }} }}
box {{ <-8, -6, 0>, <-7.9, 6, 6> pigment {{ rgb <1, 0.1, 0.1> }} finish {{ ambient 0 diffuse 0.8 }} }}
box {{ <7.9, -6, 0>, <8, 6, 6> pigment {{ rgb <0.1, 1, 0.1> }} finish {{ ambient 0 diffuse 0.8 }} }}
sphere {{ <1, -4, 3>, 2 pigment {{ rgb <1, 0.8, 0.2> }} finish {{ ambient 0 diffuse 0.8 }} }}
light_source {{ <0, 5.5, 3> rgb 1 }}
"""
GOOD = "count 100 pretrace_start 0.08 pretrace_end 0.02"
BAD = "count 3 nearest_count 1 error_bound 1.8 pretrace_start 0.08 pretrace_end 0.02"
LA = square_array(lx=24, ly=18, nx=4, ny=4)      # 16 views of 24 x 18 pixels
CLEARANCE = 30.0
VIEWS = 16


def _scene(folder, radiosity: str, name: str):
    path = folder / name
    path.write_text(ROOM.format(radiosity=radiosity))
    return load_scene(path)


def _render(scene, method: str, **settings):
    plan = METHODS[method].plan(LA, CLEARANCE, np.zeros((1, 4)))
    images, stats = render_shots(scene, plan.batch, RenderSettings(quality="draft", **{"use_cache": False, **settings}),
                                  method=method, header=display_header(LA))
    return plan, images, stats


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    folder = tmp_path_factory.mktemp("room")
    good, bad = _scene(folder, GOOD, "good.pov"), _scene(folder, BAD, "bad.pov")
    _, independent, independent_stats = _render(good, "multi-ortho-views", shared_lighting=False)
    _, shared, shared_stats = _render(good, "multi-ortho-views")
    _, wrong, _ = _render(bad, "multi-ortho-views")
    plan, bank, _ = _render(good, "multi-ortho")
    mesh_views = extract(plan.assemble(bank), (4, 4)).reshape(VIEWS, *independent[0].shape)
    return dict(independent=independent, independent_stats=independent_stats, shared=shared,
                shared_stats=shared_stats, wrong=wrong, mesh_views=mesh_views, folder=folder, good=good)


def _psnrs(views, reference) -> np.ndarray:
    return np.array([psnr(a[..., :3], b[..., :3]) for a, b in zip(views, reference)])


@pytest.mark.povray
def test_shared_views_within_pov_rays_own_spread(renders):
    """Every view lit by the shared solution is as close to its independent render as POV-Ray's own
    render of the same rays (the mesh camera's view) is, at the worst (measured: 43.7 dB at the
    least against 38.3 with the centre view's solution alone), and the sidecar says which shot computed it."""
    spread = _psnrs(renders["mesh_views"], renders["independent"]).min()
    shared = _psnrs(renders["shared"], renders["independent"])
    assert 25.0 < spread < 60.0, f"test set-up: the spread {spread:.1f} dB is no spread"
    assert shared.min() >= spread, (shared.min(), spread)
    assert renders["shared_stats"].lighting["saving_shots"] == [2 * 4 + 2, 0, 3, 12, 15]   # centre, corners
    assert renders["shared_stats"].as_record()["shared_lighting"]["loading_shots"] == VIEWS - 5


@pytest.mark.povray
def test_a_wrong_solution_fails_the_oracle(renders):
    """Negative control: views lit by a solution of a radiosity count of 3 fall outside the spread
    (measured: 34.2 dB at the least against 38.4; 20.6 with the centre view's solution alone)."""
    spread = _psnrs(renders["mesh_views"], renders["independent"]).min()
    assert _psnrs(renders["wrong"], renders["independent"]).min() < spread - 2.0


@pytest.mark.povray
def test_later_runs_load_rather_than_compute(renders):
    """POV-Ray's statistics: an independent view computes its own samples (about 150), a view that
    loads the solution a few at most (where the saving views saw too little), its pretrace a single
    pixel; the saving run (five views) computes more than one independent view and less than five."""
    independent = renders["independent_stats"].radiosity_samples / VIEWS
    lighting = renders["shared_stats"].lighting
    assert renders["independent_stats"].lighting is None
    assert independent > 50, "test set-up: the independent views compute few samples"
    assert lighting["samples_computed_per_loading_shot"] * 10 < independent
    assert independent < lighting["samples_computed"] < len(lighting["saving_shots"]) * independent
    assert lighting["loading_pretrace_seconds"] <= lighting["pretrace_seconds"] + 0.05


@pytest.mark.povray
def test_shared_and_independent_shots_are_cached_apart(renders, tmp_path):
    """The cache key of a shot lit by the shared solution says so: after a shared render, an
    independent one finds only the saving shot (an independent render itself) in the cache."""
    cache = {"use_cache": True, "cache_dir": tmp_path}
    _, first, stats = _render(renders["good"], "multi-ortho-views", **cache)
    assert stats.cached == 0
    _, again, stats = _render(renders["good"], "multi-ortho-views", **cache)
    assert stats.cached == VIEWS and all(np.array_equal(a, b) for a, b in zip(first, again))
    _, _, stats = _render(renders["good"], "multi-ortho-views", shared_lighting=False, **cache)
    assert stats.cached == 1


def test_keys_name_the_saving_shot():
    keys = SharedLighting(savers=(1, 2)).keyed(["a", "b", "c"])
    assert keys[1] == "b" and keys[0] != "a" and keys[2] != "c" and len(set(keys)) == 3
    assert SharedLighting(savers=(1, 0)).keyed(["a", "b", "c"])[2] != keys[2]  # another solution, another key


def test_loading_header_keeps_the_quality_settings():
    header = loading_header({"focal": 1.5, "global_settings": {"max_trace_level": "10", "radiosity": "{ count 9 }"}})
    assert header["global_settings"] == {"max_trace_level": "10", "radiosity":
                                         "{ count 9 pretrace_start 1 pretrace_end 1 always_sample off }"}
    assert loading_header({})["global_settings"] == {"radiosity": "{ pretrace_start 1 pretrace_end 1 always_sample off }"}


def test_kept_files_stay_inside_the_job_folder():
    with pytest.raises(Exception, match="keep_files"):
        PovrayJob(name="x", script="", width=4, height=4, keep_files=(("../out.rad", "/tmp/out.rad"),))


def test_radiosity_statistics_are_read_from_the_log():
    log = ("Radiosity samples calculated:              138 (0.46 %)\n"
           "  Radiosity Time:   0 hours  0 minutes  0 seconds (0.250 seconds)\n"
           "Radiosity samples calculated:               12 (0.10 %)\n")
    assert parse_radiosity(log) == (150, 0.25)
    assert parse_radiosity("Trace Time: 0 hours 0 minutes 1 seconds (1.0 seconds)") is None


def test_only_batches_that_name_their_lighting_shots_share(tmp_path):
    """The passes (whose frames must each light themselves: the depth pass's fog pairs) name none."""
    lit, unlit = _scene(tmp_path, GOOD, "lit.pov"), tmp_path / "unlit.pov"
    unlit.write_text("#version 3.7;\nsphere { 0, 1 pigment { rgb 1 } }\nlight_source { <0, 5, -5> rgb 1 }\n")
    batch = ShotBatch("x.pov.j2", {}, [{}, {}, {}], 4, 4, lighting_shots=(1, 0))
    settings = RenderSettings(quality="draft")
    assert shared_lighting(lit, batch, settings, True) == SharedLighting((1, 0))
    assert shared_lighting(lit, replace(batch, lighting_shots=()), settings, True) is None
    assert shared_lighting(lit, batch, replace(settings, shared_lighting=False), True) is None
    assert shared_lighting(lit, batch, settings, False) is None          # a cluster
    assert shared_lighting(load_scene(unlit), batch, settings, True) is None
    assert shared_lighting(lit, replace(batch, shots=[{}]), settings, True) is None


@pytest.mark.povray
def test_a_radiosity_block_not_in_force_stays_off(tmp_path):
    """A scene whose radiosity block sits under an ``#if`` that is false: the saving run reports no
    radiosity, so the other runs get no radiosity block of povh3d's (which would turn radiosity on,
    brightening the walls): every view equals its independent render to the bit."""
    scene = _scene(tmp_path, GOOD, "off.pov")
    scene.path.write_text(scene.path.read_text().replace("radiosity {", "#if (0) radiosity {").replace(
        "} }\nbox", "} #end }\nbox", 1))
    scene = load_scene(scene.path)
    assert "radiosity" in scene.features
    _, shared, stats = _render(scene, "multi-ortho-views")
    _, independent, _ = _render(scene, "multi-ortho-views", shared_lighting=False)
    assert stats.lighting is None
    assert all(np.array_equal(a, b) for a, b in zip(shared, independent))


@pytest.mark.povray
def test_a_kept_file_leaves_the_job_folder(tmp_path):
    """What a job writes in its folder (the only place the sandbox lets it write) reaches its
    destination before the folder goes; a file it did not write stays missing, for the caller to notice."""
    from povh3d.povray.process import run_jobs

    script = ('#version 3.7;\n#fopen F "solution.txt" write\n#write (F, "42\\n")\n#fclose F\n'
              "sphere { 0, 1 pigment { rgb 1 } }\nlight_source { <0, 5, -5> rgb 1 }\ncamera { location -3*z }\n")
    kept, unwritten = tmp_path / "kept.txt", tmp_path / "unwritten.txt"
    job = PovrayJob(name="keep", script=script, width=4, height=3,
                    keep_files=(("solution.txt", str(kept)), ("other.txt", str(unwritten))))
    run_jobs([job], processes=1, workdir=tmp_path)
    assert kept.read_text() == "42\n" and not unwritten.exists()
