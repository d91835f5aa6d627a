"""Tests of povh3d.dask_backend on a local Dask cluster of worker processes.

The oracle is the local process pool: the same render through the cluster
must give the same pixels, and the same errors.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import dask
import numpy as np
import pytest
from distributed import LocalCluster

from tests.support.render import render
from povh3d.povray import cluster as dask_backend
from povh3d.povray.cluster import DaskRunner
from povh3d.errors import ConfigError, PovrayError, PovrayNotFound, PovrayTimeout, RenderInterrupted
from povh3d.image.io import read_png, write_png
from povh3d.povray.process import JobResult, PovrayJob
from povh3d.engine.quality import RenderSettings
from tests.support.arrays import square_array
from tests.support.scenes import write_textured_scene


@pytest.fixture(scope="module")
def cluster():
    with LocalCluster(n_workers=3, threads_per_worker=1, processes=True,
                      dashboard_address=None) as local:
        yield local


@pytest.fixture
def address(cluster) -> str:
    return cluster.scheduler_address


def descendants_named(name: str) -> list[int]:
    """Pids of processes called `name` below this one (the cluster's workers' children too)."""
    parents: dict[int, int] = {}
    names: dict[int, str] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            names[int(entry.name)] = stat[stat.index("(") + 1:stat.rindex(")")]
            parents[int(entry.name)] = int(stat[stat.rindex(")") + 2:].split()[1])
    me = os.getpid()

    def below(pid: int) -> bool:
        while pid > 1:
            pid = parents.get(pid, 0)
            if pid == me:
                return True
        return False

    return [pid for pid, comm in names.items() if comm == name and below(pid)]


def wait_no_povray(seconds: float = 8.0) -> list[int]:
    deadline = time.monotonic() + seconds
    while (left := descendants_named("povray")) and time.monotonic() < deadline:
        time.sleep(0.1)
    return left


def scene_with_files(folder: Path) -> Path:
    """A scene that reads an include in a subfolder and an image map beside it."""
    scene = write_textured_scene(folder)
    (folder / "parts").mkdir()
    (folder / "parts" / "tint.inc").write_text("#declare Tint = rgb <0.9, 0.2, 0.4>;\n")
    write_png(folder / "tex.png", np.array([[[0, 200, 0], [200, 0, 200]]], np.uint8))
    with scene.open("a") as fh:
        fh.write('#include "parts/tint.inc"\n'
                 'sphere { <1, 1.5, 2>, 0.8 pigment { Tint } }\n'
                 'box { <-3, -2, 2>, <-2, -1, 2.5> pigment { image_map { png "tex.png" } } }\n')
    return scene


@pytest.mark.parametrize("method", ["multi-ortho", "multi-ortho-views"])
def test_same_pixels_as_the_local_pool(tmp_path: Path, address: str, method: str) -> None:
    scene = scene_with_files(tmp_path)
    lens = square_array(6, 4, 3, 3)
    local = tmp_path / "local.png"
    remote = tmp_path / "remote.png"
    render(scene, lens, local, method=method, settings=RenderSettings(quality="normal", use_cache=False))
    record = render(scene, lens, remote, method=method,
                    settings=RenderSettings(quality="normal", use_cache=False, scheduler=address))
    a, b = read_png(local), read_png(remote)
    assert np.array_equal(a, b)
    assert a.std() > 10  # not a blank image: the shipped files were found
    assert record["timings"]["frames"] >= 1
    # The cache key does not depend on where the frames were rendered:
    # frames the cluster rendered come from the cache in a local run.
    first = render(scene, lens, remote, method=method, settings=RenderSettings(scheduler=address))
    assert first["timings"]["povray_jobs"] >= 1
    again = render(scene, lens, local, method=method, settings=RenderSettings())
    assert again["timings"]["frames_from_cache"] == again["timings"]["frames"]
    assert again["timings"]["povray_jobs"] == 0


def test_povray_error_comes_back_with_its_message(tmp_path: Path, address: str) -> None:
    scene = tmp_path / "broken.pov"
    scene.write_text("#version 3.7;\nsphere { 0, 1 pigment { rgb 1 }\n")
    with pytest.raises(PovrayError, match="No matching } in 'sphere'|Parse Error"):
        render(scene, square_array(2, 2, 2, 2), tmp_path / "o.png",
               settings=RenderSettings(quality="draft", scheduler=address))
    assert not (tmp_path / "o.png").exists()


def test_sandbox_applies_on_workers(tmp_path: Path, address: str) -> None:
    scene = tmp_path / "peek.pov"
    scene.write_text('#version 3.7;\n#fopen F "/etc/passwd" read\nplane { z, 1 pigment { rgb 1 } }\n')
    with pytest.raises(PovrayError, match="Cannot open user file /etc/passwd"):
        render(scene, square_array(2, 2, 2, 2), tmp_path / "o.png",
               settings=RenderSettings(quality="draft", scheduler=address))


def test_timeout_on_a_worker(tmp_path: Path, address: str) -> None:
    scene = tmp_path / "slow.pov"
    scene.write_text("#version 3.7;\n#declare I = 0;\n#while (1) #declare I = I + 1; #end\n")
    with pytest.raises(PovrayTimeout, match="did not finish within 1 s"):
        render(scene, square_array(2, 2, 2, 2), tmp_path / "o.png",
               settings=RenderSettings(quality="draft", scheduler=address, timeout=1))
    assert wait_no_povray() == []


def test_interrupt_cancels_running_jobs(tmp_path: Path, address: str) -> None:
    head = "#version 3.7;\ncamera { orthographic location -z look_at 0 }\n"
    fast = PovrayJob("fast", head + "plane { z, 1 pigment { rgb 1 } }\n", 2, 2)
    slow = [PovrayJob(f"slow {i}", head + "#while (1) #end\n", 2, 2, timeout=120) for i in range(2)]
    runner = DaskRunner(address)

    def interrupt(result: JobResult) -> None:
        assert result.job.name == "fast" and result.images[0].is_file()
        # The slow jobs are running on the other workers by now.
        deadline = time.monotonic() + 10
        while len(descendants_named("povray")) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        raise KeyboardInterrupt

    started = time.monotonic()
    with pytest.raises(RenderInterrupted, match="cancelled"):
        runner.run([fast, *slow], on_result=interrupt)
    assert wait_no_povray() == []  # the workers stopped their POV-Ray processes
    assert time.monotonic() - started < 30


def test_worker_without_povray(address: str, cluster) -> None:
    runner = DaskRunner(address)
    # A builtin travels by name; os.environ's methods would carry a copy of it.
    runner.client.run(exec, "import os; os.environ['POVH3D_POVRAY'] = '/nonexistent/povray'")
    try:
        # The workers were checked already: the task itself reports it ...
        with pytest.raises(PovrayNotFound, match=r"Dask worker tcp://\S+: POVH3D_POVRAY="
                                                 r"/nonexistent/povray is not an executable"):
            runner.run([PovrayJob("j", "#version 3.7;\n", 2, 2)])
        # ... and a first connection checks every worker before any job.
        dask_backend._CHECKED.clear()
        with pytest.raises(PovrayNotFound, match=r"Dask worker tcp://.* cannot run POV-Ray: "
                                                 r"POVH3D_POVRAY=/nonexistent/povray"):
            DaskRunner(address)
    finally:
        runner.client.run(exec, "import os; os.environ.pop('POVH3D_POVRAY', None)")
    assert DaskRunner(address).workers == 3


def test_unreachable_scheduler(tmp_path: Path, cli) -> None:
    scene = write_textured_scene(tmp_path)
    out = tmp_path / "o.png"
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        result = cli("render", scene, "-o", out, "-q", "--scheduler", "tcp://127.0.0.1:9")
    assert result.code == 2
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in result.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["behind.pov"]
    with pytest.raises(ConfigError, match="--scheduler takes"):
        DaskRunner("tcp://host with space:1")


def test_animation_on_the_cluster(tmp_path: Path, address: str) -> None:
    from povh3d.app.animation import FrameRange, frame_path
    from tests.support.render import render_animation

    scene = tmp_path / "fade.pov"
    scene.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n"
                     "plane { z, 3 pigment { rgb clock } finish { emission 1 diffuse 0 ambient 0 } }\n")
    out = tmp_path / "f.png"
    report = render_animation(scene, square_array(2, 2, 2, 2), out, FrameRange(0, 2),
                              settings=RenderSettings(quality="draft", scheduler=address))
    assert report["rendered"] == 3
    assert [int(read_png(frame_path(out, n))[0, 0, 0]) for n in range(3)] == [0, 188, 255]
