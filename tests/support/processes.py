"""Which tests start POV-Ray: the ``povray`` marker and the guard of the fast subset.

A test marked ``povray`` starts POV-Ray or the povh3d command as a child process;
``pytest --fast`` (``make test-fast``) leaves those out and, for the rest, makes every
such start fail at once and fails the test that tried (tests/conftest.py), so that a test
that starts POV-Ray without the mark is seen in the fast subset rather than slowing it down.
Other programs (a fake ``POVH3D_POVRAY`` script under another name, say) still run."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

MARK = "povray"
HINT = (f"started in the fast subset (pytest --fast): mark the test @pytest.mark.{MARK} "
        f"(or its module pytestmark) so that only 'make test' runs it")


def _real(path: str | None) -> str | None:
    return os.path.realpath(path) if path else None


def _program(args: str | bytes | Sequence, executable: str | bytes | None) -> list[str]:
    if isinstance(args, (str, bytes, os.PathLike)):
        args = [args]
    words = [os.fsdecode(a) for a in args]
    if executable is not None:
        words[0] = os.fsdecode(executable)
    return words


def is_povray_start(args: str | bytes | Sequence, executable: str | bytes | None = None) -> bool:
    """True when ``args`` starts the POV-Ray binary, or Python running povh3d."""
    words = _program(args, executable)
    if not words:
        return False
    found = shutil.which(words[0]) or words[0]
    program = _real(found)
    if program == _real(shutil.which("povray")) or os.path.basename(found) == "povray":
        return True
    python = program is not None and program in {_real(sys.executable), _real(shutil.which("python3"))}
    return python and any("povh3d" in w for w in words[1:])


_EXECS = ("execv", "execve", "execvp", "execvpe")


@contextmanager
def forbid_povray(log: Path | None = None) -> Iterator[list[str]]:
    """Within: a child that :func:`is_povray_start` raises RuntimeError instead of starting; the
    list yielded collects the command lines refused (the caller fails the test when it is not empty,
    as code under test may swallow the error).

    A forked child (``pty.fork``, ``os.fork``) that execs POV-Ray or povh3d is ended instead with
    exit status 70, and its command line appended to the file ``log``, which the parent reads."""
    refused: list[str] = []
    real = subprocess.Popen._execute_child  # the one place Popen, run and check_output start a child
    real_execs = {name: getattr(os, name) for name in _EXECS}

    def guarded(self, args, executable, *rest, **kwargs):  # type: ignore[no-untyped-def]
        if is_povray_start(args, executable):
            line = " ".join(_program(args, executable))
            refused.append(line)
            raise RuntimeError(f"{line[:120]!r} {HINT}")
        return real(self, args, executable, *rest, **kwargs)

    def exec_guard(name: str):  # type: ignore[no-untyped-def]
        def guarded_exec(path, args, *rest):  # type: ignore[no-untyped-def]
            if is_povray_start(args, path):
                if log is not None:
                    with open(log, "a", encoding="utf-8") as out:
                        out.write(" ".join(_program(args, path)) + "\n")
                os._exit(70)  # in a forked copy of pytest: never go on running the tests here
            return real_execs[name](path, args, *rest)
        return guarded_exec

    subprocess.Popen._execute_child = guarded  # type: ignore[method-assign]
    for name in _EXECS:
        setattr(os, name, exec_guard(name))
    try:
        yield refused
    finally:
        subprocess.Popen._execute_child = real  # type: ignore[method-assign]
        for name, function in real_execs.items():
            setattr(os, name, function)


def refused_in_children(log: Path) -> list[str]:
    """The command lines forked children were refused (see :func:`forbid_povray`), read once."""
    try:
        lines = log.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        return []
    log.unlink()
    return lines


def record(path: str | Path, nodeid: str) -> None:
    """Append ``nodeid`` to the file ``path`` (``$POVH3D_TEST_RECORD``: which tests to mark)."""
    with open(path, "a", encoding="utf-8") as out:
        out.write(nodeid + "\n")
