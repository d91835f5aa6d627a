"""POV-Ray jobs on a Dask distributed cluster: the only module that talks to Dask.

``render --scheduler tcp://HOST:8786`` hands the same `PovrayJob` list that
runs locally to `DaskRunner`.  Each job travels with its input files (the
scene, its includes, image maps: the job's ``read_files``), sent once to
every worker with ``scatter``.  A worker lays them out under a private
folder, mirroring their absolute paths, points the job's include folders
and allow-list there, renders it with ``povray.run_jobs`` (so the worker's
POV-Ray runs in the same sandbox, with the same timeout) and returns the
image files as bytes.  No shell sees a path: files are bytes in messages.

A scene on a cluster must name its files relative to its folder or an
``--include`` folder (``#include "part.inc"``); an absolute path is the
worker's, and only POV-Ray's own include files are there for sure.

Errors come back as they would locally: a `PovrayError` raised on a worker
reaches the caller with POV-Ray's message; Ctrl-C, or any failure, cancels
every future, and a worker stops the POV-Ray process of a cancelled task.

When things go wrong: the input files travel as a task of their own (not
``scatter``ed data, which dies with the last worker that holds it), so the
scheduler can run it again on a worker that comes back; a job a dead worker
took with it is run again (the scheduler does that, and a job it gave up on is
submitted again, up to `RESUBMITS` times).  A worker stops its POV-Ray as soon
as it loses its scheduler (it is closing) or the task is cancelled (the client
went).  Each task's folder (``povh3d-job-PID-*`` in the worker's temporary
folder) is removed when it ends, and those of a killed worker by the next task
on that machine.  An address is checked, its port tried with a short timeout,
and Dask's handshake read with a deadline, before Dask is asked: no answer is one
line within `CONNECT_SECONDS`, a server that is not Dask's within `HANDSHAKE_SECONDS`
more.
"""

from __future__ import annotations

import dataclasses
import os
import re
import shutil
import socket
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from ..errors import (
    ConfigError, InputError, Povh3dError, PovrayError, PovrayNotFound, RenderInterrupted, param,
)
from ..scene.format import pov_string
from .job import JobResult, PovrayJob
from .process import find_povray, povray_version, run_jobs
from ..system import owned_prefix, sweep_orphans

__all__ = ["DaskRunner", "check_address", "connect", "job_files"]

_CLIENTS: dict[str, Any] = {}
_CHECKED: dict[str, tuple[frozenset[str], str]] = {}  # address -> (workers, POV-Ray version)
_LOCK = threading.Lock()
_MIRROR = "files"  # the worker's copy of path /a/b is ROOT/files/a/b
TASK_PREFIX = "povh3d-job-"  # a task's folder on a worker: povh3d-job-<worker pid>-<random>
#: Seconds to wait for a scheduler to answer (name lookup, TCP connect, Dask's handshake).
CONNECT_SECONDS = 4.0
#: Times a job lost with a dead worker is submitted again before the render fails.
RESUBMITS = 3
_ADDRESS = re.compile(r"(?:(tcp|tls)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(\d{1,5})")


@dataclasses.dataclass(frozen=True)
class _Files:
    """Input files by absolute path; a class, so ``scatter`` sends it as one object."""

    data: dict[str, bytes]


def check_address(address: str) -> tuple[str, str, int]:
    """``(address with its scheme, host, port)`` of a scheduler address such as ``tcp://HOST:8786``.

    Raises
    ------
    ConfigError
        Not of that form (``bogus``, no port, a port above 65535).
    """
    match = _ADDRESS.fullmatch(address or "")
    if match is None or not 0 < int(match[3]) < 65536:
        raise ConfigError(f"{param('scheduler')} takes an address like tcp://HOST:8786, got {address!r}")
    scheme = match[1] or "tcp"
    return f"{scheme}://{match[2]}:{match[3]}", match[2].strip("[]"), int(match[3])


def _answers(host: str, port: int, seconds: float) -> str | None:
    """None when something accepts TCP connections at ``host:port`` within `seconds`, else why not.

    The name lookup runs in a thread of its own: ``getaddrinfo`` has no timeout.
    """
    outcome: list[str | None] = []

    def probe() -> None:
        try:
            with socket.create_connection((host, port), timeout=seconds):
                outcome.append(None)
        except socket.gaierror as error:
            outcome.append(f"unknown host {host!r}: {error.strerror}")
        except OSError as error:
            outcome.append(error.strerror or type(error).__name__)

    thread = threading.Thread(target=probe, daemon=True, name="povh3d-scheduler-probe")
    thread.start()
    thread.join(seconds)
    return outcome[0] if outcome else f"no answer within {seconds:g} s"


#: Seconds a server that accepts TCP connections has to send Dask's handshake.
HANDSHAKE_SECONDS = 5.0
#: A key of the handshake a Dask server sends first, on every connection (distributed/comm/core.py).
_HANDSHAKE_KEY = b"pickle-protocol"


def _handshake(host: str, port: int, seconds: float) -> str | None:
    """None when the server at ``host:port`` opens with Dask's handshake within ``seconds``, else what it
    did instead.  A Dask server writes its handshake (an 8-byte length, then msgpack naming
    ``pickle-protocol``) as soon as it accepts, before it reads: a mute server or another protocol
    would leave Dask's own client waiting far past its timeout, where this read has a deadline."""
    deadline = time.monotonic() + seconds
    try:
        with socket.create_connection((host, port), timeout=seconds) as sock:
            data = b""
            while len(data) < 8 or len(data) < min(8 + int.from_bytes(data[:8], "little"), 1 << 16):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError
                sock.settimeout(left)
                chunk = sock.recv(1 << 16)
                if not chunk:
                    break
                data += chunk
                if len(data) >= 8 and int.from_bytes(data[:8], "little") > 1 << 20:
                    break   # no handshake is a megabyte: another protocol's bytes (HTTP, SSH)
    except TimeoutError:
        return f"it accepts connections but says nothing within {seconds:g} s" if not data else \
            "it answered, but not as a Dask scheduler"
    except OSError as error:
        return error.strerror or type(error).__name__
    return None if _HANDSHAKE_KEY in data else "it answered, but not as a Dask scheduler"


def connect(address: str) -> Any:
    """A `distributed.Client` for `address`, made once per process.

    Raises
    ------
    ConfigError
        The address is malformed, nothing answers there within `CONNECT_SECONDS`,
        or no worker joins.
    """
    address, host, port = check_address(address)
    with _LOCK:
        client = _CLIENTS.get(address)
        if client is not None and client.status == "running":
            return client
        from ..extras import require

        require("distributed", "cluster", f"{param('scheduler')} (a Dask cluster)")
        import dask
        from distributed import Client

        hint = "start one with 'dask scheduler' and check the address"
        why = _answers(host, port, CONNECT_SECONDS)
        if why is not None:
            raise ConfigError(f"cannot reach the Dask scheduler at {address} ({why}); {hint}")
        if address.startswith("tcp://") and (why := _handshake(host, port, HANDSHAKE_SECONDS)) is not None:
            raise ConfigError(f"the server at {address} is not a Dask scheduler ({why}); check the address and "
                              "port, and start one with 'dask scheduler'")
        if address.startswith("tls://") and not dask.config.get("distributed.comm.tls.ca-file", None):
            # distributed would fail on its missing SSLContext with a TypeError, and leave a client
            # whose clean-up prints a traceback at exit
            raise ConfigError(f"{param('scheduler')} {address} needs Dask's TLS settings (distributed.comm.tls: ca-file, "
                              "client cert and key, in the Dask config or DASK_DISTRIBUTED__COMM__TLS__*); set "
                              "them, or use tcp://")
        try:
            with dask.config.set({"distributed.comm.timeouts.connect": f"{CONNECT_SECONDS}s"}):
                client = Client(address, set_as_default=False, timeout=CONNECT_SECONDS)
        except (OSError, TimeoutError, ValueError) as error:
            raise ConfigError(f"cannot reach the Dask scheduler at {address} "
                              f"({type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}); "
                              f"{hint}") from None
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


def _gone(answer: object) -> bool:
    """A worker's answer to a broadcast that says it died (its connection closed); another error
    raised on a worker is raised here."""
    if isinstance(answer, OSError):  # distributed's CommClosedError, a refused connection
        return True
    if isinstance(answer, BaseException):
        raise answer
    return False


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


def _hold(files: _Files) -> _Files:
    """A task whose result is `files`: unlike scattered data, the scheduler can run it again."""
    return files


def _on_worker(job: PovrayJob, files: _Files) -> tuple[list[bytes], float, str]:
    """Render `job` on this worker from its shipped files; the images' bytes (``PovrayJob.image_suffix``)."""
    sweep_orphans(tempfile.gettempdir(), TASK_PREFIX)  # the folders of a worker killed on this machine
    root = tempfile.mkdtemp(prefix=owned_prefix(TASK_PREFIX))
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
    """On a worker: whether the task running in this thread is no longer wanted: the client
    cancelled it or went away, or the worker lost its scheduler (then it closes, and nobody
    would take the images)."""
    try:
        from distributed import get_worker
        from distributed.core import Status

        worker = get_worker()
        key = worker.get_current_task()
        tasks = worker.state.tasks
    except (ImportError, ValueError, AttributeError):
        return None
    working = (Status.running, Status.paused, Status.closing_gracefully)

    def cancelled() -> bool:
        state = tasks.get(key)
        stream = getattr(worker, "batched_stream", None)
        return (state is None or state.state in ("cancelled", "released", "forgotten")
                or worker.status not in working or (stream is not None and bool(stream.closed())))

    return cancelled


class DaskRunner:
    """Runs `PovrayJob` lists on the Dask cluster at `address` (``render.LocalRunner``'s twin).

    Connecting checks every worker: each must run POV-Ray, all the same
    version (it is part of the cache key).
    """

    def __init__(self, address: str) -> None:
        self.address = check_address(address)[0]
        self.client = connect(address)
        workers = frozenset(self.client.scheduler_info().get("workers", {}))
        known = _CHECKED.get(address)
        if known is not None and known[0] == workers:  # the same workers as last time
            self.version, self.workers = known[1], len(workers)
            return
        # A worker killed since the scheduler last heard of it answers with a closed connection (the
        # second batch of a render whose worker died in the first): it is gone, not a failure.
        answers = {worker: answer for worker, answer in self.client.run(_worker_povray, on_error="return").items()
                   if not _gone(answer)}
        if not answers:
            raise ConfigError(f"no Dask worker at {address} answered; start some with 'dask worker {address}'")
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

    def _submit_files(self, files: _Files) -> Any:
        with warnings.catch_warnings():  # the files are the graph's bulk by design
            warnings.filterwarnings("ignore", message="Sending large graph")
            return self.client.submit(_hold, files, pure=False)

    def run(self, jobs: Sequence[PovrayJob], *, processes: int = 1,
            on_result: Callable[[JobResult], None] | None = None,
            on_progress: Callable[[int, int], None] | None = None) -> list[float]:
        """Render `jobs` on the cluster; like ``povray.run_jobs`` (``processes`` is the cluster's)."""
        from distributed import as_completed
        from distributed.scheduler import KilledWorker
        from distributed.utils import CancelledError

        jobs = list(jobs)
        if not jobs:
            return []
        shipped = _read_all(p for job in jobs for p in job_files(job))
        files = self._submit_files(shipped)
        futures = [self.client.submit(_on_worker, job, files, pure=False, retries=0) for job in jobs]
        index = {future.key: i for i, future in enumerate(futures)}
        lost = [0] * len(jobs)
        seconds = [0.0] * len(jobs)
        done = 0
        folder = Path(tempfile.mkdtemp(prefix="povh3d-dask-"))
        try:
            waiting = as_completed(futures, loop=self.client.loop)
            for future in waiting:
                i = index[future.key]
                try:
                    images, seconds[i], log = future.result()
                except Povh3dError:
                    raise
                except KilledWorker:
                    raise PovrayError(f"{jobs[i].name}: the Dask workers running it died "
                                      "(out of memory? killed?); see the workers' logs") from None
                except CancelledError:
                    if self.client.status != "running":  # the scheduler went: its workers stop
                        _CLIENTS.pop(self.address, None)
                        raise PovrayError(f"{jobs[i].name}: lost the Dask scheduler at {self.address} "
                                          "(its workers stop their POV-Ray); start it again and "
                                          "render again") from None
                    # Its worker died and the scheduler forgot it (or its input files): again.
                    lost[i] += 1
                    if lost[i] > RESUBMITS:
                        raise PovrayError(f"{jobs[i].name}: lost {lost[i]} times with the Dask "
                                          "workers running it; see the workers' logs") from None
                    if files.status in ("cancelled", "lost", "error"):
                        futures.append(files)  # cancelled with the others at the end
                        files = self._submit_files(shipped)
                    again = self.client.submit(_on_worker, jobs[i], files, pure=False, retries=0)
                    index[again.key] = i
                    futures.append(again)
                    waiting.add(again)
                    continue
                except Exception as error:  # anything else a worker raised
                    raise PovrayError(f"{jobs[i].name}: failed on a Dask worker: "
                                      f"{type(error).__name__}: {error}") from None
                paths = []
                for n, data in enumerate(images):
                    path = folder / f"job{i}_{n}{jobs[i].image_suffix}"
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
