"""Tests of povh3d.povray.cluster on a local Dask cluster of worker processes.

The oracle is the local process pool: the same render through the cluster
must give the same pixels, and the same errors.  The fault tests at the end start
their own scheduler and workers (``dask scheduler``/``dask worker``, 127.0.0.1 only),
kill one of them by its pid, and kill them all when they end.
"""

from __future__ import annotations

import json

import os
import time
from pathlib import Path

import dask
import numpy as np
import pytest
from distributed import LocalCluster

from tests.support.render import render
from povh3d.povray import cluster as cluster_module
from povh3d.povray.cluster import DaskRunner
from povh3d.errors import ConfigError, PovrayError, PovrayNotFound, PovrayTimeout, RenderInterrupted
from povh3d.image.io import read_image, read_png, write_png
from povh3d.povray.process import JobResult, PovrayJob
from povh3d.renderer.methods.quality import RenderSettings
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


@pytest.mark.povray
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
    assert record["timings"]["shots"] >= 1
    # The cache key does not depend on where the frames were rendered:
    # frames the cluster rendered come from the cache in a local run.
    first = render(scene, lens, remote, method=method, settings=RenderSettings(scheduler=address))
    assert first["timings"]["povray_jobs"] >= 1
    again = render(scene, lens, local, method=method, settings=RenderSettings())
    assert again["timings"]["shots_from_cache"] == again["timings"]["shots"]
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
        cluster_module._CHECKED.clear()
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
    with pytest.raises(ConfigError, match="scheduler takes"):
        DaskRunner("tcp://host with space:1")


def test_animation_on_the_cluster(tmp_path: Path, address: str) -> None:
    from povh3d.renderer.animation import FrameRange, frame_path
    from tests.support.render import render_animation

    scene = tmp_path / "fade.pov"
    scene.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n"
                     "plane { z, 3 pigment { rgb clock } finish { emission 1 diffuse 0 ambient 0 } }\n")
    out = tmp_path / "f.png"
    report = render_animation(scene, square_array(2, 2, 2, 2), out, FrameRange(0, 2),
                              settings=RenderSettings(quality="draft", scheduler=address))
    assert report["rendered"] == 3
    assert [int(read_png(frame_path(out, n))[0, 0, 0]) for n in range(3)] == [0, 188, 255]
    # Rendered as clock sequences on the workers: frame 0's runs held every frame.
    jobs = [json.loads(frame_path(out, n).with_suffix(".json").read_text())["timings"]["povray_jobs"]
            for n in range(3)]
    assert jobs[0] >= 1 and jobs[1:] == [0, 0]


# --- When things go wrong: a cluster of processes this test starts on 127.0.0.1 and kills. ---

import contextlib
import signal
import socket
import subprocess
import sys
import threading

from povh3d.povray.process import run_jobs

DASK = str(Path(sys.executable).with_name("dask"))


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def children(pid: int) -> list[int]:
    try:
        return [int(c) for t in Path(f"/proc/{pid}/task").iterdir()
                for c in (t / "children").read_text().split()]
    except OSError:
        return []


def povray_in(folder: Path) -> list[int]:
    """Pids of POV-Ray processes working in `folder` (their job folders are below it), wherever
    their parent is: one a dead worker left behind is found too."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            with contextlib.suppress(OSError):
                if (entry / "comm").read_text().strip() == "povray" and \
                        os.readlink(entry / "cwd").startswith(str(folder)):
                    found.append(int(entry.name))
    return found


class SpawnedCluster:
    """``dask scheduler`` and ``dask worker`` processes (each with its nanny) on 127.0.0.1, started
    here and killed by their ids on exit; the workers' temporary folder is `tmp`."""

    def __init__(self, folder: Path, workers: int) -> None:
        self.tmp = folder / "worker-tmp"
        self.tmp.mkdir()
        self.address = f"tcp://127.0.0.1:{free_port()}"
        self.log = open(folder / "cluster.log", "wb")
        env = dict(os.environ, TMPDIR=str(self.tmp))
        self.scheduler = self._start([DASK, "scheduler", "--host", "127.0.0.1", "--port",
                                      self.address.rsplit(":", 1)[1], "--no-dashboard"], env)
        self.workers = [self._start([DASK, "worker", self.address, "--nthreads", "1", "--host", "127.0.0.1",
                                     "--no-dashboard", "--death-timeout", "15"], env)
                        for _ in range(workers)]

    def _start(self, command: list[str], env: dict[str, str]) -> subprocess.Popen[bytes]:
        return subprocess.Popen(command, env=env, stdout=self.log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)

    def wait_for_workers(self, count: int, seconds: float = 60) -> DaskRunner:
        deadline = time.monotonic() + seconds
        while True:
            try:
                runner = DaskRunner(self.address)
                if len(runner.client.scheduler_info()["workers"]) >= count:
                    return runner
            except ConfigError:
                pass
            assert time.monotonic() < deadline, (self.log.flush(), Path(self.log.name).read_text()[-3000:])
            time.sleep(0.3)

    def worker_process(self, nanny: subprocess.Popen[bytes]) -> int | None:
        """The worker process a nanny (``dask worker``) runs: the child of it that runs POV-Ray."""
        for pid in children(nanny.pid):
            if any(Path(f"/proc/{c}/comm").read_text().strip() == "povray" for c in children(pid)
                   if Path(f"/proc/{c}").exists()):
                return pid
        return None

    def close(self) -> None:
        client = cluster_module._CLIENTS.pop(self.address, None)
        cluster_module._CHECKED.pop(self.address, None)
        if client is not None:
            with contextlib.suppress(Exception):
                client.close(timeout=2)
        for process in [*self.workers, self.scheduler]:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)  # a group these tests started
            process.wait()
        self.log.close()


@contextlib.contextmanager
def spawned_cluster(folder: Path, workers: int):
    cluster = SpawnedCluster(folder, workers)
    try:
        yield cluster
    finally:
        cluster.close()


def busy_jobs(count: int, loops: int = 1_500_000) -> list[PovrayJob]:
    """Jobs that each parse for about a second, then render a lit sphere of their own colour."""
    head = ("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n"
            "camera { location <0, 0, -4> look_at 0 }\nlight_source { <-3, 4, -5>, rgb 1 }\n"
            f"#declare I = 0;\n#while (I < {loops}) #declare I = I + 1; #end\n")
    return [PovrayJob(f"job {n}", head + f"sphere {{ 0, 1 pigment {{ rgb <{n / count:.3f}, 0.5, "
                      f"{1 - n / count:.3f}> }} }}\n", 24, 24) for n in range(count)]


def rendered(run, jobs: list[PovrayJob], **kwargs) -> dict[str, np.ndarray]:
    images: dict[str, np.ndarray] = {}

    def keep(result: JobResult) -> None:
        assert result.job.name not in images  # each job handed over once
        images[result.job.name] = read_image(result.images[0])
        if "then" in kwargs:
            kwargs["then"](result)

    run(jobs, on_result=keep, **{k: v for k, v in kwargs.items() if k != "then"})
    return images


def kill_a_busy_worker(cluster: SpawnedCluster, seconds: float = 30) -> int:
    """Kill -9 a worker process while its POV-Ray runs; its pid."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        for nanny in cluster.workers:
            if (pid := cluster.worker_process(nanny)) is not None:
                os.kill(pid, signal.SIGKILL)
                return pid
        time.sleep(0.05)
    raise AssertionError("no worker ran POV-Ray")


@pytest.mark.povray
@pytest.mark.parametrize("workers", [2, 1], ids=["2-workers-one-killed", "1-worker-restarted-by-its-nanny"])
def test_a_worker_killed_mid_render(tmp_path: Path, workers: int) -> None:
    jobs = busy_jobs(6)
    local = rendered(lambda j, **k: run_jobs(j, processes=1, **k), jobs)
    killed: list[int] = []
    with spawned_cluster(tmp_path, workers) as cluster:
        runner = cluster.wait_for_workers(workers)
        started = time.monotonic()

        def kill_once(result: JobResult) -> None:
            if not killed:
                killed.append(kill_a_busy_worker(cluster))

        out: list = []

        def render_there() -> None:
            try:
                out.append(rendered(runner.run, jobs, then=kill_once))
            except BaseException as error:
                out.append(error)

        # In a thread, so that a render that hangs fails the test (its cluster is then killed).
        thread = threading.Thread(target=render_there, daemon=True)
        thread.start()
        thread.join(240)
        took = time.monotonic() - started
        assert out, f"the render did not finish within {took:.0f} s"
        if isinstance(out[0], BaseException):
            raise out[0]
        remote = out[0]
        assert killed and not Path(f"/proc/{killed[0]}").exists()
        assert sorted(remote) == sorted(local)
        for name in local:
            assert np.array_equal(remote[name], local[name]), name
        assert len({local[name].tobytes() for name in local}) == len(jobs)  # the oracle tells jobs apart
        # A task cancelled at the end (a copy the scheduler had started again) stops within a grace.
        deadline = time.monotonic() + 5
        while (povray_in(cluster.tmp) or list(cluster.tmp.glob("povh3d-job-*"))) and time.monotonic() < deadline:
            time.sleep(0.1)
        left = povray_in(cluster.tmp)
        folders = sorted(p.name for p in cluster.tmp.glob("povh3d-job-*"))
        settled = time.monotonic() - started - took
    print(f"cluster of {workers}, one killed: {took:.1f} s, settled {settled:.1f} s later")
    assert left == [] and folders == []


def test_a_killed_scheduler_stops_povray_on_the_worker(tmp_path: Path) -> None:
    jobs = busy_jobs(1, loops=60_000_000)  # about a minute
    with spawned_cluster(tmp_path, 1) as cluster:
        runner = cluster.wait_for_workers(1)
        failure: list[BaseException] = []
        failed: list[float] = []

        def run() -> None:
            try:
                runner.run(jobs)
            except BaseException as error:  # what the client sees when its scheduler dies
                failure.append(error)
                failed.append(time.monotonic())

        thread = threading.Thread(target=run, daemon=True)
        thread.start()
        deadline = time.monotonic() + 30
        while not povray_in(cluster.tmp) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert povray_in(cluster.tmp), "POV-Ray never started on the worker"
        os.kill(cluster.scheduler.pid, signal.SIGKILL)
        killed = time.monotonic()
        while povray_in(cluster.tmp) and time.monotonic() - killed < 30:
            time.sleep(0.05)
        stopped = time.monotonic() - killed
        thread.join(30)
        print(f"POV-Ray stopped {stopped:.1f} s after the scheduler died; client failed after "
              f"{failed[0] - killed if failed else float('nan'):.1f} s: {failure!r}")
        assert stopped < 5
        assert not thread.is_alive() and failure and isinstance(failure[0], PovrayError)
        assert "lost the Dask scheduler" in str(failure[0]) and failed[0] - killed < 15


@pytest.mark.parametrize("address", ["bogus", "closed", "tcp://bogus.invalid:8786", "tcp://127.0.0.1:70000"])
def test_no_scheduler_fails_in_one_line_within_seconds(tmp_path: Path, cli, address: str) -> None:
    if address == "closed":
        address = f"tcp://127.0.0.1:{free_port()}"  # nothing listens there any more
    scene = write_textured_scene(tmp_path)
    started = time.monotonic()
    result = cli("render", scene, "-o", tmp_path / "o.png", "-q", "--scheduler", address)
    took = time.monotonic() - started
    assert result.code == 2, result.err
    assert len(result.err.strip().splitlines()) == 1 and "Traceback" not in result.err, result.err
    assert "scheduler" in result.err
    assert took < 5, took
    assert sorted(p.name for p in tmp_path.iterdir()) == ["behind.pov"]


@pytest.mark.povray
def test_a_killed_client_stops_povray_on_the_worker(tmp_path: Path) -> None:
    with spawned_cluster(tmp_path, 1) as cluster:
        cluster.wait_for_workers(1)
        client_code = ("import sys\nfrom povh3d.povray.cluster import DaskRunner\n"
                       "from tests.povray.test_cluster import busy_jobs\n"
                       "DaskRunner(sys.argv[1]).run(busy_jobs(1, loops=60_000_000))\n")
        client = subprocess.Popen([sys.executable, "-c", client_code, cluster.address],
                                  cwd=Path(__file__).resolve().parents[2], stdout=cluster.log,
                                  stderr=subprocess.STDOUT, start_new_session=True)
        try:
            deadline = time.monotonic() + 60
            while not povray_in(cluster.tmp) and time.monotonic() < deadline:
                time.sleep(0.05)
            assert povray_in(cluster.tmp), "POV-Ray never started on the worker"
        finally:
            os.kill(client.pid, signal.SIGKILL)
            client.wait()
        killed = time.monotonic()
        while povray_in(cluster.tmp) and time.monotonic() - killed < 30:
            time.sleep(0.05)
        stopped = time.monotonic() - killed
        print(f"POV-Ray stopped {stopped:.1f} s after the client died")
        assert stopped < 5
        deadline = time.monotonic() + 5
        while list(cluster.tmp.glob("povh3d-job-*")) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert list(cluster.tmp.glob("povh3d-job-*")) == []


@pytest.mark.povray
@pytest.mark.parametrize("resubmits", [cluster_module.RESUBMITS, 0], ids=["resubmitted", "control-none"])
def test_jobs_the_scheduler_forgot_are_submitted_again(tmp_path: Path, address: str, resubmits: int,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    # The input files' task cancelled behind the runner's back (as when the scheduler forgets
    # data that died with its workers) takes every job not yet done with it.
    from distributed import Future

    monkeypatch.setattr(cluster_module, "RESUBMITS", resubmits)
    jobs = busy_jobs(4, loops=300_000)
    local = rendered(lambda j, **k: run_jobs(j, processes=1, **k), jobs)
    runner = DaskRunner(address)
    forgot: list[str] = []

    def forget_files(result: JobResult) -> None:
        if not forgot:
            keys = runner.client.run_on_scheduler(
                lambda dask_scheduler: [str(k) for k in dask_scheduler.tasks if str(k).startswith("_hold")])
            forgot.extend(keys)
            runner.client.cancel([Future(key, runner.client) for key in keys], force=True)

    if resubmits == 0:
        with pytest.raises(PovrayError, match="lost 1 times"):
            rendered(runner.run, jobs, then=forget_files)
        return
    remote = rendered(runner.run, jobs, then=forget_files)
    assert forgot
    assert sorted(remote) == sorted(local)
    for name in local:
        assert np.array_equal(remote[name], local[name]), name
    assert wait_no_povray() == []
