"""Which tests start POV-Ray: the ``povray`` marker and the guard of the fast subset.

A test marked ``povray`` starts POV-Ray or the povh3d command as a child process;
``pytest --fast`` (``make test-fast``) leaves those out and, for the rest, makes every
such start fail at once and fails the test in its teardown, so that a test that starts
POV-Ray without the mark is seen in the fast subset rather than slowing it down."""

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


@contextmanager
def forbid_povray() -> Iterator[list[str]]:
    """Within: a child that :func:`is_povray_start` raises RuntimeError instead of starting; the
    list yielded collects the command lines refused (the caller fails the test when it is not empty,
    as code under test may swallow the error)."""
    refused: list[str] = []
    real = subprocess.Popen._execute_child  # the one place Popen, run and check_output start a child

    def guarded(self, args, executable, *rest, **kwargs):  # type: ignore[no-untyped-def]
        if is_povray_start(args, executable):
            line = " ".join(_program(args, executable))
            refused.append(line)
            raise RuntimeError(f"{line[:120]!r} {HINT}")
        return real(self, args, executable, *rest, **kwargs)

    subprocess.Popen._execute_child = guarded  # type: ignore[method-assign]
    try:
        yield refused
    finally:
        subprocess.Popen._execute_child = real  # type: ignore[method-assign]


def record(path: str | Path, nodeid: str) -> None:
    """Append ``nodeid`` to the file ``path`` (``$POVH3D_TEST_RECORD``: which tests to mark)."""
    with open(path, "a", encoding="utf-8") as out:
        out.write(nodeid + "\n")
