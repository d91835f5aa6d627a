"""Running the ``povh3d`` command line from the tests: in this process (the ``cli``
fixture of tests/conftest.py) or, where a real process is needed, as a subprocess."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from povh3d.cli.main import main

REPO = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Result:
    """What a run of the command line left: exit code, stdout, stderr."""

    code: int
    out: str
    err: str


def run_in_process(*args: Any) -> Result:
    """``povh3d ARGS`` through ``povh3d.cli.main.main``, its exit and output captured."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = main([str(a) for a in args])
        except SystemExit as exc:  # as the interpreter turns SystemExit into an exit status
            if exc.code is None or isinstance(exc.code, int):
                code = exc.code or 0
            else:
                print(exc.code, file=sys.stderr)
                code = 1
    return Result(code, out.getvalue(), err.getvalue())


def cli_command(*args: Any) -> list[str]:
    """The command line of ``povh3d ARGS`` as a separate Python process."""
    return [sys.executable, "-m", "povh3d.cli", *map(str, args)]


def run_subprocess(*args: Any, env: dict[str, str] | None = None, cwd: str | Path = REPO,
                   timeout: float | None = None) -> Result:
    """``python -m povh3d.cli ARGS`` in a child process (``env`` added to this one's)."""
    done = subprocess.run(cli_command(*args), capture_output=True, text=True, timeout=timeout, check=False,
                          env={**os.environ, **(env or {})}, cwd=cwd)
    return Result(done.returncode, done.stdout, done.stderr)


def one_error_line(result: Result, code: int | None = None) -> str:
    """The one ``povh3d: error:`` line a failed run printed (and no traceback); checks the exit
    code is ``code`` (any non-zero one by default)."""
    if code is None:
        assert result.code != 0, result
    else:
        assert result.code == code, result.err
    lines = [line for line in result.err.splitlines() if line.strip()]
    assert len(lines) == 1, result.err
    assert lines[0].startswith("povh3d: error: ")
    assert "Traceback" not in result.err
    return lines[0]
