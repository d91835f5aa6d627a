"""File access of a POV-Ray child, restricted by the kernel (Linux Landlock).

A scene is a program: ``#include``, ``#fopen`` and image maps can read any
file the user can, and ``#write`` can write any.  POV-Ray's own guard, the
``[File I/O Security]`` section of ``povray.conf``, is not enforced by POV-Ray
3.7.0.x on Unix (checked against 3.7.0.10, Debian's build): its conf parser
compares each line with ``!=`` where it means ``==`` (``vfe/unix/unixoptions.cpp``,
upstream issue POV-Ray/povray#158, FS#326), so ``restricted`` is read as
"unset" wherever the file lies (``/etc/povray/3.7/povray.conf`` or
``$HOME/.povray/3.7/povray.conf``), and ``read+write`` paths are only ever
added as read paths.  ``tests/povray/test_sandbox.py`` shows both: with the conf in
place and no Landlock, a scene still reads ``/etc/passwd`` and writes
outside its folder.

So povh3d restricts the child itself.  Before ``exec`` the child calls
``landlock_restrict_self`` with a ruleset built by the parent from a
`Policy`: read (and run) what POV-Ray needs to start (``/usr``, ``/lib*``,
``/etc/povray``, the loader cache, the program itself but never the folder
around it) and the scene's own files; read and
write the job's folder; nothing else.  Landlock also forbids TCP ``bind`` and
``connect`` on kernels that support it (ABI 4).  The rules survive ``exec``
and bind the child and everything it starts.  Work done in the child
between ``fork`` and ``exec`` is two system calls; everything that
allocates happens in the parent.

``POVH3D_SANDBOX``: ``auto`` (default; restrict where the kernel has
Landlock), ``require`` (fail when it has not) or ``off``.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import platform
import re
import signal
import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError, OutputError

if TYPE_CHECKING:
    from ..scene.scene import Scene

__all__ = ["Policy", "Ruleset", "landlock_abi", "sandbox_mode", "system_read_paths",
           "build_ruleset", "restrict_self", "describe", "files_within", "scene_inputs"]

ENV_VAR = "POVH3D_SANDBOX"
MODES = ("auto", "require", "off")

# Landlock system calls: the same numbers on every Linux architecture
# (they were added after the syscall tables were unified).
_SYS_CREATE_RULESET, _SYS_ADD_RULE, _SYS_RESTRICT_SELF = 444, 445, 446
_CREATE_RULESET_VERSION = 1
_RULE_PATH_BENEATH, _RULE_NET_PORT = 1, 2
_PR_SET_NO_NEW_PRIVS = 38

# Filesystem rights (include/uapi/linux/landlock.h) and the ABI that added them.
_EXECUTE, _WRITE_FILE, _READ_FILE, _READ_DIR = 1 << 0, 1 << 1, 1 << 2, 1 << 3
_REMOVE_DIR, _REMOVE_FILE, _MAKE_CHAR, _MAKE_DIR = 1 << 4, 1 << 5, 1 << 6, 1 << 7
_MAKE_REG, _MAKE_SOCK, _MAKE_FIFO, _MAKE_BLOCK, _MAKE_SYM = (1 << 8, 1 << 9, 1 << 10,
                                                            1 << 11, 1 << 12)
_REFER, _TRUNCATE, _IOCTL_DEV = 1 << 13, 1 << 14, 1 << 15
_FS_BY_ABI = {1: (1 << 13) - 1, 2: (1 << 14) - 1, 3: (1 << 15) - 1, 4: (1 << 15) - 1,
              5: (1 << 16) - 1}
_NET_BIND_TCP, _NET_CONNECT_TCP = 1 << 0, 1 << 1

_FILE_ONLY = _EXECUTE | _WRITE_FILE | _READ_FILE | _TRUNCATE | _IOCTL_DEV
_READ = _EXECUTE | _READ_FILE | _READ_DIR
_WRITE = (_READ | _WRITE_FILE | _REMOVE_DIR | _REMOVE_FILE | _MAKE_DIR | _MAKE_REG
          | _MAKE_SYM | _REFER | _TRUNCATE)

_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None


def _libc() -> ctypes.CDLL:
    """libc where Landlock was found (``landlock_abi() > 0``, so Linux and never None)."""
    if _LIBC is None:
        raise OutputError("Landlock needs Linux's C library; this system has none")
    return _LIBC

_PR_SET_PDEATHSIG = 1


class _RulesetAttr(ctypes.Structure):
    _fields_ = [("handled_access_fs", ctypes.c_uint64),
                ("handled_access_net", ctypes.c_uint64)]


class _PathBeneathAttr(ctypes.Structure):
    _pack_ = 1  # __attribute__((packed)) in the kernel header
    _fields_ = [("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32)]


@dataclass(frozen=True)
class Policy:
    """What one POV-Ray run may touch.

    Parameters
    ----------
    read : tuple of str
        Absolute files or folders (with everything below) it may read and run.
    write : tuple of str
        Absolute folders it may read, create, write and delete in.
    """

    read: tuple[str, ...]
    write: tuple[str, ...]

    def __post_init__(self) -> None:
        for name in ("read", "write"):
            paths = tuple(str(p) for p in getattr(self, name))
            relative = [p for p in paths if not os.path.isabs(p)]
            if relative:
                raise ConfigError(f"sandbox {name} paths must be absolute, got {relative[0]!r}")
            object.__setattr__(self, name, paths)


@cache
def landlock_abi() -> int:
    """The kernel's Landlock ABI version; 0 where there is none (not Linux, disabled)."""
    if _LIBC is None or platform.machine() not in ("x86_64", "aarch64", "arm64", "riscv64"):
        return 0
    version = _LIBC.syscall(_SYS_CREATE_RULESET, None, ctypes.c_size_t(0),
                            ctypes.c_uint32(_CREATE_RULESET_VERSION))
    return max(0, int(version))


def sandbox_mode() -> str:
    """``$POVH3D_SANDBOX`` checked: ``auto``, ``require`` or ``off``."""
    mode = os.environ.get(ENV_VAR, "auto").strip().lower() or "auto"
    if mode not in MODES:
        raise ConfigError(f"{ENV_VAR}={mode!r} is not one of {', '.join(MODES)}")
    return mode


def confines() -> bool:
    """Whether POV-Ray runs here can read only the files a scene was found to read."""
    return sandbox_mode() != "off" and landlock_abi() > 0


def describe() -> str:
    """One line for sidecars: how POV-Ray runs are confined here."""
    mode, abi = sandbox_mode(), landlock_abi()
    if mode == "off":
        return f"off ({ENV_VAR}=off)"
    return f"landlock ABI {abi}" if abi else "none (the kernel has no Landlock)"


# Read-only system software: the loader, libc, a wrapper's shell, POV-Ray's Debian tree.
_SYSTEM_DIRS = ("/usr", "/lib", "/lib64", "/lib32", "/bin")
_SYSTEM_FILES = ("/etc/povray", "/etc/ld.so.cache", "/etc/ld.so.conf", "/etc/ld.so.conf.d",
                 "/dev/null", "/dev/urandom",
                 "/sys/devices/system/cpu")  # glibc's CPU count for POV-Ray's threads
_LIBRARY_PATH = re.compile(r"^\s*(?:Library_Path\s*=|[+]L)\s*(.+?)\s*(?:;.*)?$", re.IGNORECASE)


def system_read_paths(binary: str,
                      libraries: Callable[[str], tuple[str, ...]] | None = None) -> tuple[str, ...]:
    """What POV-Ray reads to start and to find its own include files and fonts.

    The system's software (``/usr``, the ``/lib*`` links, ``/bin``), the loader's
    cache, ``/etc/povray``; the program itself (`binary` and the file it links to)
    and, when it lies elsewhere, the shared libraries it loads (``ldd``) and its
    prefix's ``share/povray-3.7``; the ``Library_Path`` folders of its
    ``povray.ini``.  Never the folder around the program: for ``~/bin/povray``
    that would be the whole home, for ``/opt/povray`` all of ``/``.  A wrapper
    script must ``exec`` a POV-Ray under ``/usr``; point ``POVH3D_POVRAY`` at the
    program itself otherwise.  ``libraries`` lists the files a program loads
    (``process.shared_libraries``: only the process module starts programs).
    """
    real = os.path.realpath(binary)
    prefix = os.path.dirname(os.path.dirname(real))  # /usr/bin/povray -> /usr
    candidates = [*_SYSTEM_DIRS, *_SYSTEM_FILES, os.path.abspath(binary), real,
                  os.path.join(prefix, "share", "povray-3.7"), os.path.join(prefix, "etc", "povray")]
    if libraries is not None and not _under(real, _SYSTEM_DIRS):  # a system program's are in the system's folders
        candidates += [lib for lib in libraries(real) if not _under(lib, _SYSTEM_DIRS)]
    for ini in ("/etc/povray/3.7/povray.ini", os.path.join(prefix, "etc", "povray", "3.7", "povray.ini")):
        candidates += _library_paths(ini)
    return tuple(dict.fromkeys(p for p in candidates if os.path.exists(p) and not _too_wide(p)))


def _under(path: str, folders: Iterable[str]) -> bool:
    return any(os.path.commonpath([path, folder]) == folder for folder in folders)


def _too_wide(path: str) -> bool:
    """A folder that holds ``/`` 's children or a home: never readable as a whole."""
    real = os.path.realpath(path)
    if not os.path.isdir(real) or _under(real, _SYSTEM_DIRS):
        return False
    homes = {os.path.realpath(os.path.expanduser("~")), "/home", "/root", "/tmp", "/var", "/etc",
             "/opt", "/srv", "/mnt", "/media", "/run"}
    return real == "/" or any(_under(home, [real]) for home in homes if home)


def _library_paths(ini: str) -> list[str]:
    """The ``Library_Path`` folders a ``povray.ini`` names (POV-Ray's include files and fonts)."""
    try:
        lines = Path(ini).read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return []
    folders = [match[1].strip("\"'") for line in lines if (match := _LIBRARY_PATH.match(line))]
    return [folder for folder in folders if os.path.isabs(folder)]


def files_within(files: Iterable[str | os.PathLike[str]],
                 folders: Iterable[str | os.PathLike[str]]) -> tuple[str, ...]:
    """The `files` that lie inside one of `folders` (absolute, resolved).

    A scene's file list holds every existing file its string literals name,
    ``"/etc/passwd"`` too; only those in the scene's own folders are its inputs.
    """
    roots = [os.path.realpath(folder) for folder in folders]
    kept = []
    for file in files:
        real = os.path.realpath(file)
        if any(os.path.commonpath([real, root]) == root for root in roots):
            kept.append(real)
    return tuple(kept)


def scene_inputs(scene: Scene) -> dict[str, Any]:
    """The `PovrayJob` fields through which a job reads `scene`: its include folders, its
    allow-list (`files_within`), and links to the files it names with non-ASCII characters."""
    return {"include_dirs": tuple(str(d) for d in scene.include_dirs),
            "read_files": files_within(scene.files, scene.include_dirs),
            "links": tuple((name, str(file)) for name, file in scene.ascii_names)}


class Ruleset:
    """A Landlock ruleset file descriptor built in the parent; close it after the spawn."""

    def __init__(self, fd: int) -> None:
        self.fd = fd

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def __enter__(self) -> Ruleset:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def build_ruleset(policy: Policy) -> Ruleset | None:
    """The kernel ruleset for `policy`; None when the sandbox is off or unavailable.

    Raises
    ------
    ConfigError
        ``POVH3D_SANDBOX=require`` on a kernel without Landlock.
    OutputError
        The kernel refused the ruleset.
    """
    mode, abi = sandbox_mode(), landlock_abi()
    if mode == "off":
        return None
    if abi == 0:
        if mode == "require":
            raise ConfigError(f"{ENV_VAR}=require but this kernel has no Landlock (Linux 5.13+ "
                              "with landlock in the lsm= list); use a newer kernel or unset it")
        return None
    handled = _FS_BY_ABI.get(abi, _FS_BY_ABI[5])
    attr = _RulesetAttr(handled, (_NET_BIND_TCP | _NET_CONNECT_TCP) if abi >= 4 else 0)
    size = ctypes.sizeof(attr) if abi >= 4 else ctypes.sizeof(ctypes.c_uint64)
    fd = _libc().syscall(_SYS_CREATE_RULESET, ctypes.byref(attr), ctypes.c_size_t(size),
                       ctypes.c_uint32(0))
    if fd < 0:
        raise OutputError(f"the kernel refused a Landlock ruleset: {os.strerror(ctypes.get_errno())}")
    ruleset = Ruleset(fd)
    try:
        _add_rules(fd, policy.read, _READ & handled)
        _add_rules(fd, policy.write, _WRITE & handled)
    except BaseException:
        ruleset.close()
        raise
    return ruleset


def _add_rules(fd: int, paths: Iterable[str], access: int) -> None:
    for path in paths:
        try:
            target = os.open(path, os.O_PATH | os.O_CLOEXEC)
        except FileNotFoundError:
            continue  # nothing there to allow
        except OSError as error:
            raise OutputError(f"cannot open {path!r} for the sandbox: {error.strerror}") from None
        try:
            # A file takes only the rights that apply to files.
            allowed = access if os.path.isdir(path) else access & _FILE_ONLY
            rule = _PathBeneathAttr(allowed, target)
            if _libc().syscall(_SYS_ADD_RULE, ctypes.c_int(fd), ctypes.c_int(_RULE_PATH_BENEATH),
                             ctypes.byref(rule), ctypes.c_uint32(0)) != 0:
                raise OutputError(f"the kernel refused a Landlock rule for {path!r}: "
                                  f"{os.strerror(ctypes.get_errno())}")
        finally:
            os.close(target)


def restrict_self(fd: int) -> None:
    """Run in the child before ``exec``: confine it to the ruleset `fd`.

    Two system calls and no allocation that could deadlock after a fork; on
    failure the child exits (code 126) rather than run unconfined.
    """
    if _LIBC is None or _LIBC.prctl(_PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0 or \
            _LIBC.syscall(_SYS_RESTRICT_SELF, fd, 0) != 0:
        os._exit(126)


@contextlib.contextmanager
def confinement(binary: str, inputs: Iterable[str], folder: Path,
                libraries: Callable[[str], tuple[str, ...]] | None = None) -> Iterator[int | None]:
    """The Landlock ruleset fd for a POV-Ray child while it starts (None: unconfined):
    it may read POV-Ray's own files (``system_read_paths``) and ``inputs``, and write only in ``folder``."""
    ruleset = build_ruleset(Policy(system_read_paths(binary, libraries) + tuple(inputs), (str(folder),)))
    try:
        yield None if ruleset is None else ruleset.fd
    finally:
        if ruleset is not None:
            ruleset.close()


def child_setup(parent: int, ruleset_fd: int | None = None) -> None:
    """Run in the child before exec: die with the parent (Linux), enter the sandbox."""
    if _LIBC is not None:
        _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        if os.getppid() != parent:  # the parent died before prctl took effect
            os._exit(1)
    if ruleset_fd is not None:
        restrict_self(ruleset_fd)
