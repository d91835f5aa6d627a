"""Watching running POV-Ray children without polling: sleep until one exits
(Linux pidfds), and read how far each has got from its verbose log."""

from __future__ import annotations

import math
import os
import select
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .log import parse_progress

#: How often ``run_jobs`` reports the running jobs' progress, and checks for a stop, s.
PROGRESS_SECONDS = 0.25
STOP_CHECK_SECONDS = 0.1
#: Sleep of the fallback without pidfds (not Linux, or Linux before 5.3), s.
FALLBACK_SECONDS = 0.02


def sleep_until_exit(pids: Sequence[int], seconds: float | None) -> None:
    """Sleep until one of the child processes `pids` exits or `seconds` pass (None: no limit).

    The children must not have been reaped yet (a zombie still has its pidfd).
    Ctrl-C interrupts the sleep with a KeyboardInterrupt, as ``time.sleep`` does.
    """
    fds: list[int] = []
    try:
        try:
            for pid in pids:
                fds.append(os.pidfd_open(pid))
        except (AttributeError, OSError):  # no pidfd_open here: short sleeps
            time.sleep(FALLBACK_SECONDS if seconds is None else min(seconds, FALLBACK_SECONDS))
            return
        poller = select.poll()
        for fd in fds:
            poller.register(fd, select.POLLIN)  # readable once the process has exited
        poller.poll(None if seconds is None else max(0, math.ceil(seconds * 1000)))
    finally:
        for fd in fds:
            os.close(fd)


@dataclass
class LogProgress:
    """How many frames a running job has rendered, from its growing ``+V`` log.

    Each call reads only what was appended since the last, and only whole lines.
    """

    path: Path
    frames: int
    read: int = 0
    frame: int = 1
    share: float = 0.0

    def frames_rendered(self) -> float:
        """Frames rendered so far, the current one counted by its share of pixels."""
        try:
            with open(self.path, "rb") as f:
                f.seek(self.read)
                data = f.read()
        except OSError:
            data = b""
        end = max(data.rfind(b"\r"), data.rfind(b"\n")) + 1
        if end:
            self.read += end
            self.frame, self.share = parse_progress(data[:end].decode("utf-8", "replace"), self.frame, self.share)
        return min(float(self.frames), self.frame - 1 + self.share)
