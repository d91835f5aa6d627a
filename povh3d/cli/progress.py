"""One status line on a terminal while a command works: share done, count, time left.

The line is redrawn in place (carriage return, erase to the end of the line)
at most every ``interval`` seconds and erased when the command ends, so the
result line that follows stands alone.  The time left is the time so far
scaled by the share still to do; a new total (a new phase, such as the
``--quality auto`` probe before the render) starts its own clock.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}" if seconds >= 3600 \
        else f"{seconds // 60}:{seconds % 60:02d}"


def status_text(done: float, total: float, elapsed: float, unit: str = "shots", width: int = 20) -> str:
    """The status line for `done` of `total` after `elapsed` seconds (no escape codes).

    >>> status_text(0.5, 2, 10.0)
    'povh3d:  25% |#####               | 0/2 shots  0:10, about 0:30 left'
    """
    share = min(1.0, max(0.0, done / total)) if total > 0 else 0.0
    filled = int(share * width)
    left = f"about {_clock(elapsed * (1 - share) / share)} left" if share > 0 else "estimating time left"
    return (f"povh3d: {100 * share:3.0f}% |{'#' * filled}{' ' * (width - filled)}| "
            f"{int(done + 1e-9)}/{int(total)} {unit}  {_clock(elapsed)}, {left}")


class StatusLine:
    """Progress on `stream`; call it as ``status(done, total)``, then ``close()``."""

    def __init__(self, stream: TextIO = sys.stderr, unit: str = "shots", interval: float = 0.1) -> None:
        self.stream, self.unit, self.interval = stream, unit, interval
        self.start = time.monotonic()
        self.shown = -float("inf")
        self.drawn = False
        self.total, self.done = 0.0, 0.0

    def __call__(self, done: float, total: float) -> None:
        now = time.monotonic()
        if (total, done) < (self.total, self.done) or total != self.total:  # a new phase: its own clock
            self.start, self.shown = now, -float("inf")
        self.total, self.done = total, done
        if now - self.shown < self.interval and done < total:
            return
        self.shown = now
        self.stream.write("\r" + status_text(done, total, now - self.start, self.unit) + "\033[K")
        self.stream.flush()
        self.drawn = True

    def close(self) -> None:
        if self.drawn:
            self.stream.write("\r\033[K")
            self.stream.flush()
