"""How ``multi-ortho-views`` spreads its views over POV-Ray runs (issue 37).

The premise, checked on POV-Ray: a run idles at every frame change (about 0.24 s, with next to no
CPU), so the same frames in several shorter runs side by side take less wall time than in one run,
which is why the views go in runs of a few frames, many runs a core (docs/benchmarks.md, "The
fallback's runs").
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from povh3d.povray.process import PovrayJob, run_jobs
from povh3d.renderer.methods import registry
from tests.support.arrays import square_array

TINY = "#version 3.7;\nsphere { 0, 1 pigment { rgb 1 } }\nlight_source { <0, 5, -5> rgb 1 }\ncamera { location -3*z }\n"


def _wall(tmp_path, frames: int, runs: int) -> float:
    jobs = [PovrayJob(name=f"tiny {i}", script=TINY, width=4, height=3, frames=frames, threads=1) for i in range(runs)]
    start = time.perf_counter()
    run_jobs(jobs, processes=runs, workdir=tmp_path)
    return time.perf_counter() - start


@pytest.mark.povray
def test_frames_idle_so_short_runs_side_by_side_are_faster(tmp_path):
    """16 frames of a 4x3 image: one run idles through every frame change (over 0.12 s each,
    measured 0.24); four runs of four frames side by side overlap those waits (the control of the
    same work in one run)."""
    one_run = _wall(tmp_path, 16, 1)
    four_runs = _wall(tmp_path, 4, 4)
    assert one_run > 16 * 0.12
    assert four_runs < 0.75 * one_run, (four_runs, one_run)


@pytest.mark.parametrize("cores, views, per_job, processes", [
    (2, (8, 8), 4, 16),      # demo's 64 views on this machine: 16 runs of 4
    (16, (8, 8), 1, 64),     # a view a run where the cores allow it
    (2, (2, 2), 1, 4),       # (which lets an animation's frames go in clock sequences)
    (2, (32, 32), 64, 16),   # many views: at most 8 runs a core
])
def test_views_go_in_runs_of_a_few_frames(monkeypatch, cores, views, per_job, processes):
    monkeypatch.setattr(registry, "cpu_count", lambda: cores)
    ny, nx = views
    la = square_array(lx=4, ly=3, nx=nx, ny=ny)
    batch = registry.METHODS["multi-ortho-views"].plan(la, 30.0, np.zeros((1, 4))).batch
    assert (batch.shots_per_job, batch.processes) == (per_job, processes)
    assert len(batch.shots) <= batch.shots_per_job * batch.processes
    assert batch.lighting_shots == registry.centre_and_corners(ny, nx)
    assert batch.lighting_shots[0] == (ny // 2) * nx + nx // 2
