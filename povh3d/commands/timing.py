"""Whole povh3d commands, timed from interpreter start to exit (``povh3d bench``)."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from ..errors import PovrayError
from ..povray.process import run_command


def time_povh3d(args: Sequence[object], timeout: float | None = None) -> float:
    """Wall seconds of ``python -m povh3d ARGS`` in a fresh interpreter (start-up, render, PNG, exit)."""
    code, seconds, stderr = run_command([sys.executable, "-m", "povh3d", *map(str, args)], timeout=timeout)
    if code != 0:
        last = stderr.strip().splitlines()[-1] if stderr.strip() else "no message"
        raise PovrayError(f"povh3d {' '.join(map(str, args[:1]))} failed (exit {code}): {last}")
    return seconds
