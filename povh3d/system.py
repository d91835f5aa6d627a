"""What this machine offers the renderer: the cores this process may use, its memory, the cache
folder and the POV-Ray binary (looked up here alone)."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import threading
from collections.abc import Iterator
from pathlib import Path
from functools import cache


@cache
def cpu_count() -> int:
    """Cores this process may run on (its affinity), asked once."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


#: POV-Ray threads a process may run on a cluster's worker, whose cores this machine cannot count.
MAX_REMOTE_THREADS = 512


def thread_limit(remote: bool = False) -> int:
    """The most POV-Ray threads a process may run: this machine's cores (more only share them, each
    thread with its own buffers), or ``MAX_REMOTE_THREADS`` on a cluster."""
    return MAX_REMOTE_THREADS if remote else cpu_count()


# -- temporary folders that name their owner -------------------------------------------------------
# A temporary folder povh3d makes (a POV-Ray job's, an animation's staging folder)
# carries the pid of the process that owns it: ``PREFIX<pid>-<random>``.  The
# owner removes it on exit; when the owner was killed (kill -9, a power cut), the
# next povh3d run finds it by name and removes it once no process has that pid.
# A folder whose pid was reused by another process is removed after STALE_SECONDS.
STALE_SECONDS = 7 * 24 * 3600


def owned_prefix(prefix: str) -> str:
    """``prefix`` + this process's pid + ``-``: the name start of a folder this process owns."""
    return f"{prefix}{os.getpid()}-"


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, another user's
        return True
    return True


def sweep_orphans(folder: str | os.PathLike[str], prefix: str) -> list[str]:
    """Remove ``prefix<pid>-*`` folders in ``folder`` left by a povh3d process that is gone.

    Only folders of this user whose owner pid is not running (or that are older
    than ``STALE_SECONDS``) are removed; the folders removed are returned.  Never
    raises: a folder that cannot be listed or removed is left.
    """
    import re
    import shutil
    import time

    pattern = re.compile(re.escape(prefix) + r"(\d+)-")
    removed: list[str] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    now = time.time()
    for entry in entries:
        match = pattern.match(entry.name)
        if not match or not entry.is_dir(follow_symlinks=False):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if info.st_uid != os.getuid():
            continue
        pid = int(match[1])
        if pid == os.getpid():
            continue
        if not _pid_alive(pid) or now - info.st_mtime > STALE_SECONDS:
            shutil.rmtree(entry.path, ignore_errors=True)
            removed.append(entry.path)
    return removed


def available_memory() -> int | None:
    """Bytes of memory available to new allocations (Linux ``MemAvailable``), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def default_cache_dir() -> Path:
    """``$POVH3D_CACHE``, else ``$XDG_CACHE_HOME/povh3d``, else ``~/.cache/povh3d``."""
    if os.environ.get("POVH3D_CACHE"):
        return Path(os.environ["POVH3D_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME")
    if not base:
        try:
            base = str(Path.home() / ".cache")
        except RuntimeError:  # no HOME and no password entry: an unusable cache, not a crash
            base = os.path.join(os.sep, "nonexistent-home", ".cache")
    return Path(base) / "povh3d"


# -- the POV-Ray binary: looked up here alone (the renderer runs it, the output cache keys on it) --------
#: Environment variable naming the POV-Ray executable to use.
ENV_VAR = "POVH3D_POVRAY"
INSTALL_HINT = ("install it with 'sudo apt-get install -y povray' (Debian/Ubuntu) "
                f"or set {ENV_VAR}=/path/to/povray")


def find_povray() -> str:
    """Path of the POV-Ray executable.

    ``$POVH3D_POVRAY`` if set (a path or a command name), else ``povray`` on
    ``PATH``.

    Raises
    ------
    PovrayNotFound
        With a one-line hint on installing it.
    """
    from .errors import PovrayNotFound  # here: system.py stays a leaf of the import graph

    configured = os.environ.get(ENV_VAR)
    if configured:
        found = shutil.which(configured)
        if found is None:
            raise PovrayNotFound(f"{ENV_VAR}={configured} is not an executable "
                                 f"program; {INSTALL_HINT}.")
        return found
    found = shutil.which("povray")
    if found is None:
        raise PovrayNotFound(f"POV-Ray was not found on PATH; {INSTALL_HINT}.")
    return found


def binary_key(binary: str) -> str | None:
    """``"path|size|mtime_ns"`` of the file ``binary`` resolves to (its version follows); None if unreadable."""
    try:
        path = os.path.realpath(binary)
        stat = os.stat(path)
    except OSError:
        return None
    return f"{path}|{stat.st_size}|{stat.st_mtime_ns}"


LIMIT_ENV = "POVH3D_MAX_MEMORY"   # ``--max-memory``, kept here for every part of the run
_SIZE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([kmgt]?)i?b?\s*$", re.I)
_UNITS = {"": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}


def parse_size(text: str) -> int:
    """``"4G"``, ``"512M"``, ``"2.5GiB"``, ``"1000000"`` (bytes) -> bytes; a ConfigError otherwise."""
    from .errors import ConfigError, param

    match = _SIZE.match(str(text))
    if not match or float(match[1]) <= 0:
        raise ConfigError(f"{param('max_memory')} takes a size such as 4G or 512M, got {text!r}")
    return int(float(match[1]) * _UNITS[match[2].lower()])


def memory_limit() -> int | None:
    """The user's limit in bytes (``--max-memory`` / ``POVH3D_MAX_MEMORY``), or None."""
    text = os.environ.get(LIMIT_ENV)
    return parse_size(text) if text else None


def memory_budget() -> int | None:
    """Bytes a run may use: the smaller of the user's limit and the memory available (None: unknown)."""
    known = [b for b in (memory_limit(), available_memory()) if b is not None]
    return min(known) if known else None


@contextlib.contextmanager
def deferred_signals() -> Iterator[None]:
    """Hold Ctrl-C (and SIGTERM, SIGHUP where Python handles them) for the block: a signal that
    comes meanwhile is handled when it ends.  Used where an interrupt in between would leave a
    state nobody knows of: a child started but not recorded (``povray.process``), a new image
    beside its old sidecar (``image.io``).  Python raises it only in the main thread, where the
    handlers may be swapped; elsewhere there is nothing to hold.  An ignored
    signal stays ignored.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    held = [s for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP) if callable(signal.getsignal(s))]
    previous = {s: signal.signal(s, lambda signum, frame: caught.append(signum)) for s in held}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if caught:
            handler = previous[signal.Signals(caught[0])]
            if callable(handler):  # always: only signals with a handler function were held
                handler(caught[0], None)  # e.g. the default SIGINT handler raises KeyboardInterrupt
