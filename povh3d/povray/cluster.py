"""POV-Ray jobs on a Dask distributed cluster: the only module that talks to Dask.

``render --scheduler tcp://HOST:8786`` hands the same `PovrayJob` list that
runs locally to `DaskRunner`.  Each job travels with its input files (the
scene, its includes, image maps: the job's ``read_files``), sent once to
every worker with ``scatter``.  A worker lays them out under a private
folder, mirroring their absolute paths, points the job's include folders
and allow-list there, renders it with ``povray.run_jobs`` (so the worker's
POV-Ray runs in the same sandbox, with the same timeout) and returns the
PNG files as bytes.  No shell sees a path: files are bytes in messages.

A scene on a cluster must name its files relative to its folder or an
``--include`` folder (``#include "part.inc"``); an absolute path is the
worker's, and only POV-Ray's own include files are there for sure.

Errors come back as they would locally: a `PovrayError` raised on a worker
reaches the caller with POV-Ray's message; Ctrl-C, or any failure, cancels
every future, and a worker stops the POV-Ray process of a cancelled task.
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import tempfile
import threading
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from ..errors import ConfigError, InputError, PovrayError, PovrayNotFound, Povh3dError, RenderInterrupted
from .format import pov_string
from .job import JobResult, PovrayJob
from .process import find_povray, povray_version, run_jobs

__all__ = ["DaskRunner", "connect", "job_files"]

_CLIENTS: dict[str, Any] = {}
_CHECKED: dict[str, tuple[frozenset[str], str]] = {}  # address -> (workers, POV-Ray version)
_LOCK = threading.Lock()
_MIRROR = "files"  # the worker's copy of path /a/b is ROOT/files/a/b


@dataclasses.dataclass(frozen=True)
class _Files:
    """Input files by absolute path; a class, so ``scatter`` sends it as one object."""

    data: dict[str, bytes]


def connect(address: str) -> Any:
    """A `distributed.Client` for `address`, made once per process.

    Raises
    ------
    ConfigError
        The address is malformed, nothing answers there, or no worker joins.
    """
    if not address or any(c.isspace() for c in address):
        raise ConfigError(f"--scheduler takes an address like tcp://HOST:8786, got {address!r}")
    with _LOCK:
        client = _CLIENTS.get(address)
        if client is not None and client.status == "running":
            return client
        from ..extras import require

        require("distributed", "cluster", "--scheduler (a Dask cluster)")
        from distributed import Client

        try:
            client = Client(address, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as error:
            raise ConfigError(f"cannot reach the Dask scheduler at {address} ({error}); start one "
                              f"with 'dask scheduler' and check the address") from None
        try:
            client.wait_for_workers(1, timeout=30)
        except (TimeoutError, OSError):
            client.close()
            raise ConfigError(f"the Dask scheduler at {address} has no workers; start some with "
                              f"'dask worker {address}' on machines with POV-Ray") from None
        _CLIENTS[address] = client
        return client


def _worker_povray() -> tuple[bool, str]:
    """On a worker: ``(True, version)`` or ``(False, why not)``."""
    try:
        return True, povray_version(find_povray())
    except Povh3dError as error:
        return False, str(error)


def job_files(job: PovrayJob) -> list[str]:
    """Absolute paths of the files `job` reads: its allow-list, else its include folders' files."""
    if job.read_files is not None:
        return [p for p in job.read_files if os.path.isfile(p)]
    found = []
    for folder in job.include_dirs:
        for base, _, names in os.walk(os.path.abspath(folder)):
            found += [os.path.join(base, name) for name in names]
    return found


def _read_all(paths: Iterable[str]) -> _Files:
    data = {}
    for path in sorted(set(paths)):
        try:
            data[path] = Path(path).read_bytes()
        except OSError as error:
            raise InputError(f"cannot read {path!r} to send it to the cluster: {error.strerror}") from None
    return _Files(data)


def _on_worker(job: PovrayJob, files: _Files) -> tuple[list[bytes], float, str]:
    """Render `job` on this worker from its shipped files; the images as PNG bytes."""
    root = tempfile.mkdtemp(prefix="povh3d-job-")
    try:
        def here(path: str) -> str:
            return os.path.join(root, _MIRROR, os.path.abspath(path).lstrip(os.sep))

        for path, data in files.data.items():
            target = Path(here(path))
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        script = job.script
        for path in files.data:  # the generated script names the scene by its path
            script = script.replace(pov_string(path), pov_string(here(path)))
        local = dataclasses.replace(
            job, script=script,
            include_dirs=tuple(here(d) for d in job.include_dirs),
            read_files=None if job.read_files is None else tuple(here(p) for p in job.read_files),
            links=tuple((name, here(target)) for name, target in job.links))
        for folder in local.include_dirs:
            os.makedirs(folder, exist_ok=True)
        out: list[tuple[list[bytes], float, str]] = []

        def keep(result: JobResult) -> None:
            out.append(([p.read_bytes() for p in result.images], result.seconds, result.log))

        run_jobs([local], processes=1, on_result=keep, workdir=root,
                 should_stop=_cancelled_here())
        return out[0]
    except PovrayNotFound as error:
        raise PovrayNotFound(f"Dask worker {_worker_address()}: {error}") from None
    finally:
        shutil.rmtree(root, ignore_errors=True)


def _worker_address() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return "?"


def _cancelled_here() -> Callable[[], bool] | None:
    """On a worker: whether the client cancelled the task running in this thread."""
    try:
        from distributed import get_worker

        worker = get_worker()
        key = worker.get_current_task()
        tasks = worker.state.tasks
    except (ImportError, ValueError, AttributeError):
        return None

    def cancelled() -> bool:
        state = tasks.get(key)
        return state is None or state.state in ("cancelled", "released", "forgotten")

    return cancelled


class DaskRunner:
    """Runs `PovrayJob` lists on the Dask cluster at `address` (``render.LocalRunner``'s twin).

    Connecting checks every worker: each must run POV-Ray, all the same
    version (it is part of the cache key).
    """

    def __init__(self, address: str) -> None:
        self.address = address
        self.client = connect(address)
        workers = frozenset(self.client.scheduler_info().get("workers", {}))
        known = _CHECKED.get(address)
        if known is not None and known[0] == workers:  # the same workers as last time
            self.version, self.workers = known[1], len(workers)
            return
        answers = self.client.run(_worker_povray)
        missing = {w: why for w, (ok, why) in answers.items() if not ok}
        if missing:
            worker, why = sorted(missing.items())[0]
            raise PovrayNotFound(f"Dask worker {worker} cannot run POV-Ray: {why}")
        versions = {version for _, version in answers.values()}
        if len(versions) != 1:
            raise ConfigError(f"the Dask workers run different POV-Ray versions "
                              f"({', '.join(sorted(versions))}); install one version on all")
        self.version = versions.pop()
        self.workers = len(answers)
        _CHECKED[address] = (frozenset(answers), self.version)

    def run(self, jobs: Sequence[PovrayJob], *, processes: int = 1,
            on_result: Callable[[JobResult], None] | None = None,
            on_progress: Callable[[int, int], None] | None = None) -> list[float]:
        """Render `jobs` on the cluster; like ``povray.run_jobs`` (``processes`` is the cluster's)."""
        from distributed import as_completed
        from distributed.scheduler import KilledWorker

        jobs = list(jobs)
        if not jobs:
            return []
        [files] = self.client.scatter([_read_all(p for job in jobs for p in job_files(job))],
                                      broadcast=True, hash=False)
        futures = [self.client.submit(_on_worker, job, files, pure=False, retries=0)
                   for job in jobs]
        index = {future.key: i for i, future in enumerate(futures)}
        seconds = [0.0] * len(jobs)
        done = 0
        folder = Path(tempfile.mkdtemp(prefix="povh3d-dask-"))
        try:
            for future in as_completed(futures, loop=self.client.loop):
                i = index[future.key]
                try:
                    images, seconds[i], log = future.result()
                except Povh3dError:
                    raise
                except KilledWorker:
                    raise PovrayError(f"{jobs[i].name}: the Dask worker running it died "
                                      "(out of memory? killed?); see the worker's log") from None
                except Exception as error:  # anything else a worker raised
                    raise PovrayError(f"{jobs[i].name}: failed on a Dask worker: "
                                      f"{type(error).__name__}: {error}") from None
                paths = []
                for n, data in enumerate(images):
                    path = folder / f"job{i}_{n}.png"
                    path.write_bytes(data)
                    paths.append(path)
                try:
                    if on_result is not None:
                        on_result(JobResult(jobs[i], tuple(paths), seconds[i], log))
                finally:
                    for path in paths:
                        path.unlink(missing_ok=True)
                done += 1
                if on_progress is not None:
                    on_progress(done, len(jobs))
        except KeyboardInterrupt:
            raise RenderInterrupted("Rendering interrupted; the cluster's jobs were cancelled.") from None
        finally:
            # Cancelling a finished future is harmless; a running one is stopped on its worker.
            self.client.cancel(futures + [files], force=True)
            shutil.rmtree(folder, ignore_errors=True)
        return seconds
