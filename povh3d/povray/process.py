"""Every POV-Ray process povh3d starts: finding the binary and running jobs
(``job.PovrayJob``: what one run is, and its command line).

This is the only module that starts processes.  Each job gets a fresh
temporary folder that is the child's working folder and holds the scene, the
output images, the console log and a private ``HOME``.  The private ``HOME``
holds a ``povray.conf`` that permits reading the job's include folders, so
POV-Ray's file I/O security allows them on builds that enforce it (Debian's
3.7.0.10 reads the setting but, through an upstream bug, enforces nothing),
and the log does not start with "cannot open the user configuration file".
Because POV-Ray does not enforce it, each child is also confined by the
kernel (``sandbox.py``, Linux Landlock): it reads only POV-Ray's own files
and the job's inputs, and writes only in its folder.
A side effect: a user's own ``~/.povray/3.7/povray.ini`` is not read, which
keeps renders reproducible.

Children run in their own session, so a Ctrl-C in the terminal reaches only
Python, which then stops them; on Linux they also die with Python.  Their
output goes to a log file, so no pipe can fill up and block them.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from . import limits, sandbox
from ..errors import (ConfigError, OutputError, PovrayError, PovrayNotFound, PovrayTimeout, RenderCancelled,
                      RenderInterrupted, warn)
from .job import (LOG_FILE, SCENE_FILE, JobResult, PovrayJob, ascii_paths, build_command, collect_images,
                  expected_images, frame_image, original_names, povray_conf)
from ..system import INSTALL_HINT, deferred_signals, find_povray, owned_prefix, sweep_orphans
from .log import denied_note, describe_exit, parse_error, tail
from .version_memo import remembered
from .watch import PROGRESS_SECONDS, STOP_CHECK_SECONDS, JobWatch, sleep_until_exit

_DENIED = re.compile(r"Cannot (open|find)")
# POV-Ray takes about 0.6 s to act on SIGTERM; after this, SIGKILL.
_GRACE_SECONDS = 1.0
#: Signals POV-Ray 3.7 dies of by its own fault, not ours: it aborts (SIGABRT) about once in some
#: thousands of runs on a loaded machine, at random, with nothing in its log.  The render is
#: deterministic, so a job lost that way is run once more; a second loss is the error.
_CRASH_SIGNALS = frozenset({signal.SIGABRT, signal.SIGSEGV, signal.SIGBUS, signal.SIGFPE, signal.SIGILL})


def povray_version(binary: str | None = None) -> str:
    """POV-Ray's version, e.g. ``"3.7.0.10.unofficial"``; asked once per binary."""
    return _version(binary or find_povray())


#: The version of each binary asked in this process (``_version``): asked once, and no probe for it.
_VERSIONS: dict[str, str] = {}


def _version(binary: str) -> str:
    if binary in _VERSIONS:
        return _VERSIONS[binary]
    command = [binary, "--version"]
    probe = _PROBES.pop(binary, None)   # started as the command started (``probe_version_early``)
    try:
        if probe is not None:
            output, _ = probe.communicate(timeout=30)
            returncode = probe.returncode
        else:
            done = subprocess.run(command, capture_output=True, text=True,
                                  errors="replace", timeout=30, check=False)
            output, returncode = done.stdout + done.stderr, done.returncode  # POV-Ray 3.7 prints it on stderr
    except OSError as error:
        raise PovrayNotFound(f"Cannot run {binary}: {error.strerror}; "
                             f"{INSTALL_HINT}.") from None
    except subprocess.TimeoutExpired:
        if probe is not None:
            probe.kill()
            probe.communicate()
        raise PovrayError(f"{' '.join(command)} did not answer within 30 s.",
                          command=command) from None
    match = re.search(r"^POV-Ray (\d+\.\d+\S*)", output, re.MULTILINE)
    if match is None:
        raise PovrayError(f"{' '.join(command)} did not report a POV-Ray version.",
                          command=command, returncode=returncode,
                          log_tail=tail(output))
    _VERSIONS[binary] = match[1]
    return match[1]


#: ``povray --version`` runs started early (``probe_version_early``), by binary, until ``_version`` takes them.
_PROBES: dict[str, subprocess.Popen[str]] = {}


def probe_version_early(binary: str, folder: str | Path) -> None:
    """Start ``binary --version`` now, where neither this process nor the memory in ``folder``
    (``version_memo``) knows the answer: the probe's 0.2 s (nearly all of it POV-Ray waiting) then pass
    beside povh3d's own start-up instead of before its first render, and ``povray_version`` takes the
    answer.  ``stop_probes`` (and the exit) stop a probe nobody took."""
    if binary in _VERSIONS or binary in _PROBES or remembered(binary, folder) is not None:
        return
    try:
        _PROBES[binary] = subprocess.Popen([binary, "--version"], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                           stderr=subprocess.STDOUT, text=True, errors="replace")
    except OSError:
        return   # asked again, the usual way, where the error is said
    if len(_PROBES) == 1:
        atexit.register(stop_probes)


def stop_probes() -> None:
    """Stop and reap every probe nobody took (a command that failed before it rendered)."""
    for probe in _PROBES.values():
        if probe.poll() is None:
            probe.kill()
        probe.wait()
        if probe.stdout is not None:
            probe.stdout.close()
    _PROBES.clear()


@dataclass(eq=False)
class _Child:
    """A started job: its folder, command and process."""

    index: int
    job: PovrayJob
    folder: Path
    command: list[str]
    process: subprocess.Popen[bytes]
    started: float
    watch: JobWatch  # its log and images; `early` once stopped with its images complete
    ended: float | None = field(default=None)

    @property
    def log(self) -> str:
        path = self.folder / LOG_FILE
        return path.read_text(encoding="utf-8", errors="replace") if path.exists() else ""


@functools.cache
def shared_libraries(binary: str) -> tuple[str, ...]:
    """The files of the shared libraries `binary` loads, as ``ldd`` resolves them; () for a script."""
    try:
        with open(binary, "rb") as fh:
            if fh.read(4) != b"\x7fELF":
                return ()
        done = subprocess.run(["ldd", binary], capture_output=True, text=True, timeout=20, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return ()
    found = re.findall(r"(?:=>\s*|^\s*)(/\S+)\s+\(0x", done.stdout, re.MULTILINE)
    return tuple(dict.fromkeys(p for path in found for p in (path, os.path.realpath(path))))


def run_jobs(jobs: Sequence[PovrayJob], *, processes: int,
             on_result: Callable[[JobResult], None] | None = None,
             on_progress: Callable[[int, int], None] | None = None,
             binary: str | None = None, workdir: str | Path | None = None,
             should_stop: Callable[[], bool] | None = None,
             on_running: Callable[[dict[int, float]], None] | None = None,
             on_frame: Callable[[PovrayJob, int, Path], None] | None = None) -> list[float]:
    """Render jobs with at most `processes` POV-Ray children at once.

    Parameters
    ----------
    jobs : sequence of PovrayJob
        Started in this order.
    processes : int
        Most children running at the same time.
    on_result : callable, optional
        Called with each `JobResult` as its job finishes, in this thread, while
        the job's images exist (deleted when it returns).
    on_progress : callable, optional
        Called as ``on_progress(done, total)`` after each job, in this thread.
    binary : str, optional
        POV-Ray executable; `find_povray` by default.
    workdir : str or Path, optional
        Folder for the jobs' temporary folders; the system's by default.
    should_stop : callable, optional
        Polled while children run; True stops them all and raises
        `RenderInterrupted` (a cancelled task on a Dask worker).
    on_running : callable, optional
        Called every ``PROGRESS_SECONDS`` with ``{job index: frames rendered}`` (``watch.LogProgress``).
    on_frame : callable, optional
        ``on_frame(job, frame index (0-based), image)`` as soon as a frame of a running job is complete
        (``JobWatch.finished_frames``; `on_running` then omits it); `on_result` still gets every image.

    Returns
    -------
    list of float
        Wall time of each job, s, in job order.

    Raises
    ------
    PovrayError
        A job failed (non-zero exit, missing image); the message names the
        job and quotes POV-Ray's error.
    PovrayTimeout
        A job ran longer than its timeout.
    RenderInterrupted
        Ctrl-C (a KeyboardInterrupt, also one raised by a callback).

    Notes
    -----
    Before any exception leaves, including one from a callback, the first
    failure stops every child (SIGTERM to its process group, SIGKILL after a
    second), no further job starts and every temporary folder is deleted.
    """
    if not isinstance(processes, int) or processes < 1:
        raise ConfigError(f"processes must be a positive integer, got {processes!r}.")
    jobs = list(jobs)
    if not jobs:
        return []
    binary = binary or find_povray()
    seconds = [0.0] * len(jobs)
    pending = deque(enumerate(jobs))
    running: list[_Child] = []
    rerun: dict[int, int] = {}  # job index -> frames its crashed run had handed over (``_CRASH_SIGNALS``)
    done = 0
    try:
        while pending or running:
            while pending and len(running) < processes:
                index, job = pending.popleft()
                _start(index, job, binary, workdir, running, handed=rerun.get(index, 0))
            for child in _wait_for_exits(running, should_stop, on_running, on_frame):
                running.remove(child)
                if child.index not in rerun and _crashed(child):
                    rerun[child.index] = child.watch.handed
                    warn(f"{child.job.name}: {describe_exit(child.process.returncode, '')} (a fault of "
                         "POV-Ray's own, not of the scene); running it once more")
                    _discard(child)
                    pending.appendleft((child.index, child.job))
                    continue
                seconds[child.index] = _finish(child, on_result)
                done += 1
                if on_progress is not None:
                    on_progress(done, len(jobs))
    except KeyboardInterrupt:
        raise RenderInterrupted("Rendering interrupted; every POV-Ray process "
                                "was stopped.") from None
    finally:
        _stop(running)
        for child in running:
            child.watch.close()
            shutil.rmtree(child.folder, ignore_errors=True)
    return seconds


def _start(index: int, job: PovrayJob, binary: str, workdir: str | Path | None,
           running: list[_Child], handed: int = 0) -> None:
    """Start `job` in a fresh folder and add it to `running`; its frames up to `handed` (1-based)
    were handed over by an earlier run of it and are not reported again."""
    folder = _make_folder(workdir)
    registered = False  # once True, run_jobs owns the folder and the child
    try:
        run = ascii_paths(job, folder)  # what POV-Ray is given; results stay the caller's `job`'s
        command = build_command(run, binary)
        env = _prepare(folder, run)
        with open(folder / LOG_FILE, "wb") as log, sandbox.confinement(binary, _inputs(run), folder, shared_libraries) as fd, \
                deferred_signals():
            process = _spawn(command, folder, env, log, fd)
            watch = JobWatch(folder / LOG_FILE, job.frames, functools.partial(collect_images, folder, job),
                             functools.partial(frame_image, folder, job))
            watch.handed = handed
            running.append(_Child(index, job, folder, command, process, time.monotonic(), watch))
            registered = True
    except BaseException:
        if not registered:
            shutil.rmtree(folder, ignore_errors=True)
        raise


def _inputs(job: PovrayJob) -> tuple[str, ...]:
    """What the job's POV-Ray may read besides its own files: the scene's files, else its include folders."""
    return job.read_files if job.read_files is not None else tuple(os.path.abspath(d) for d in job.include_dirs)


def _spawn(command: list[str], folder: Path, env: dict[str, str],
           log: BinaryIO, ruleset_fd: int | None = None) -> subprocess.Popen[bytes]:
    try:
        return subprocess.Popen(
            command, cwd=folder, env=env, stdin=subprocess.DEVNULL, stdout=log,
            stderr=subprocess.STDOUT, start_new_session=True,
            preexec_fn=functools.partial(_child_setup, os.getpid(), ruleset_fd, limits.address_space(command)))
    except OSError as error:
        raise PovrayNotFound(f"Cannot run POV-Ray at {command[0]}: "
                             f"{error.strerror}; {INSTALL_HINT}.") from None


def _child_setup(parent: int, ruleset_fd: int | None, address_space: int | None) -> None:
    limits.set_address_space(address_space)  # POV-Ray's own memory limit (``limits``)
    sandbox.child_setup(parent, ruleset_fd)


JOB_PREFIX = "povh3d-"  # job folders: povh3d-<owner pid>-<random>
_SWEPT: set[str] = set()


def _make_folder(workdir: str | Path | None) -> Path:
    # Job folders name their owner's pid; those of a killed povh3d are swept once per folder.
    base = str(workdir or tempfile.gettempdir())
    if base not in _SWEPT:
        _SWEPT.add(base)
        sweep_orphans(base, JOB_PREFIX)
    try:
        return Path(tempfile.mkdtemp(prefix=owned_prefix(JOB_PREFIX), dir=workdir))
    except OSError as error:
        raise OutputError(f"Cannot create a temporary folder in "
                          f"{workdir or tempfile.gettempdir()}: {error.strerror}.") from None


def _prepare(folder: Path, job: PovrayJob) -> dict[str, str]:
    """Write the scene and a private HOME into `folder`; the child's environment."""
    home = folder / "home"
    conf = home / ".povray" / "3.7" / "povray.conf"
    read_dirs = [os.path.abspath(path) for path in job.include_dirs]
    try:
        (folder / SCENE_FILE).write_text(job.script, encoding="utf-8")
        conf.parent.mkdir(parents=True)
        conf.write_text(povray_conf(read_dirs, str(folder)))
    except OSError as error:
        raise full_disk(folder, 1 << 20, job.name) or \
            OutputError(f"Cannot write the scene into {folder}: {error.strerror}.") from None
    return dict(os.environ, HOME=str(home))


def _wait_for_exits(running: list[_Child], should_stop: Callable[[], bool] | None = None,
                    on_running: Callable[[dict[int, float]], None] | None = None,
                    on_frame: Callable[[PovrayJob, int, Path], None] | None = None) -> list[_Child]:
    """Wait until a child exits (woken by it, not polling); the exited ones.  Raises on a timeout or a stop."""
    while True:
        if should_stop is not None and should_stop():  # cancelled: nothing of theirs is kept, so no grace
            _signal_groups(running, signal.SIGKILL)  # (POV-Ray takes ~0.6 s to act on SIGTERM)
            raise RenderCancelled("Rendering cancelled; every POV-Ray process was stopped.")
        for child in running:
            frame_image = child.watch.frame_image  # None: a single image, no frames reported
            if on_frame is not None and frame_image is not None:
                for number in child.watch.finished_frames():
                    on_frame(child.job, number - 1, frame_image(number))
            if child.process.poll() is None and child.watch.images_done():
                _signal_groups([child], signal.SIGKILL)  # only its shutdown is left (JobWatch)
                child.watch.early = child.process.wait() is not None
        now = time.monotonic()
        exited = [child for child in running if child.process.poll() is not None]
        for child in exited:
            child.ended = now
        if exited:
            return exited
        timed = [(child, child.job.timeout) for child in running if child.job.timeout is not None]
        wake = [child.started + timeout - now for child, timeout in timed]
        if any(left < 0 for left in wake):
            raise _timeout(timed[[left < 0 for left in wake].index(True)][0])
        if should_stop is not None:
            wake.append(STOP_CHECK_SECONDS)
        if on_running is not None:
            on_running({c.index: c.watch.progress.frames_rendered() - c.watch.handed for c in running})
            wake.append(PROGRESS_SECONDS)
        wake += [child.watch.recheck for child in running if child.watch.written or child.watch.awaiting_log]
        sleep_until_exit([c.process.pid for c in running], min(wake, default=None), [c.watch.fd for c in running])


def _finish(child: _Child, on_result: Callable[[JobResult], None] | None) -> float:
    """Check an exited child, hand over its result, delete its folder."""
    try:
        seconds = (child.ended or time.monotonic()) - child.started
        log = child.log
        images = collect_images(child.folder, child.job)
        if (child.process.returncode != 0 and not child.watch.early) or images is None:
            raise full_disk(child.folder, _image_bytes(child.job), child.job.name) or _failure(child, log)
        _keep(child)
        if on_result is not None:
            on_result(JobResult(child.job, images, seconds, log))
        return seconds
    finally:
        child.watch.close()
        shutil.rmtree(child.folder, ignore_errors=True)


def _crashed(child: _Child) -> bool:
    """Whether the child died of a fault of POV-Ray's own (``_CRASH_SIGNALS``), not stopped by us
    once its images were complete, and with no error of the scene's in its log."""
    code = child.process.returncode
    return (code is not None and code < 0 and -code in _CRASH_SIGNALS and not child.watch.early
            and parse_error(child.log) is None)


def _discard(child: _Child) -> None:
    """Forget an exited child's run: its watch and its folder."""
    child.watch.close()
    shutil.rmtree(child.folder, ignore_errors=True)


def _image_bytes(job: PovrayJob) -> int:
    """What a job's images may take on disk at most (16-bit RGBA, uncompressed)."""
    return 8 * job.width * job.height * max(1, job.frames)


def full_disk(folder: Path, need: int, name: str) -> OutputError | None:
    """The error to give for a failure in ``folder`` when its disk has less than ``need`` bytes (and 1 MiB)
    free: POV-Ray says only "Frontend halted render", or an image is cut short; None when there is room."""
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return None
    if free >= max(need, 1 << 20):
        return None
    return OutputError(f"{name}: the disk of {str(folder.parent)!r} is full ({free / 2**20:.3g} MiB free); free "
                       "space there, or set TMPDIR to a folder on a disk with room")


def _keep(child: _Child) -> None:
    """Move the files the job keeps (``PovrayJob.keep_files``) out of its folder before it is deleted;
    one POV-Ray did not write stays missing at its destination (the caller's to notice)."""
    for name, destination in child.job.keep_files:
        if not (child.folder / name).is_file():
            continue
        try:
            shutil.move(str(child.folder / name), destination)
        except OSError as error:
            raise OutputError(f"{child.job.name}: cannot keep {name} POV-Ray wrote, in {destination}: "
                              f"{error.strerror}.") from None


def _failure(child: _Child, log: str) -> PovrayError:
    code = child.process.returncode
    reason = parse_error(log)
    if reason is None and code != 0:
        reason = describe_exit(code, log)
    elif reason is None:
        reason = f"POV-Ray finished without writing {expected_images(child.job)}"
    if code == 126 and not log.strip():
        reason = "the POV-Ray process could not enter its sandbox (Landlock); set POVH3D_SANDBOX=off to run unconfined"
    elif _DENIED.search(reason):
        reason += denied_note(reason, child.job.include_dirs, log, sandbox.confines())
    return PovrayError(f"{child.job.name}: {original_names(reason, child.folder)}", command=child.command,
                       returncode=code, log_tail=tail(log))


def _timeout(child: _Child) -> PovrayTimeout:
    return PovrayTimeout(f"{child.job.name}: POV-Ray did not finish within "
                         f"{child.job.timeout:g} s (the job's timeout).",
                         command=child.command, log_tail=tail(child.log))


def _stop(children: list[_Child]) -> None:
    """Stop every live child: SIGTERM, then SIGKILL after a grace; reap them."""
    live = [child for child in children if child.process.poll() is None]
    _signal_groups(live, signal.SIGTERM)
    deadline = time.monotonic() + _GRACE_SECONDS
    try:
        while time.monotonic() < deadline and any(c.process.poll() is None for c in live):
            sleep_until_exit([c.process.pid for c in live if c.process.poll() is None], deadline - time.monotonic())
    except KeyboardInterrupt:
        pass  # a second Ctrl-C: no more grace
    _signal_groups([c for c in live if c.process.poll() is None], signal.SIGKILL)
    for child in live:
        child.process.wait()


def _signal_groups(children: list[_Child], signum: signal.Signals) -> None:
    for child in children:
        # Each child leads its own session, so its group id is its pid.
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(child.process.pid, signum)



def run_command(argv: Sequence[str], *, timeout: float | None = None) -> tuple[int, float, str]:
    """Run ``argv`` (a povh3d command the bench times) to its exit: ``(exit code, wall s, stderr)``."""
    start = time.perf_counter()
    try:
        done = subprocess.run(list(argv), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                              timeout=timeout, check=False)
    except subprocess.TimeoutExpired as exc:
        raise PovrayTimeout(f"{' '.join(map(str, argv[:4]))} ... took over {timeout:g} s") from exc
    return done.returncode, time.perf_counter() - start, done.stderr or ""
