"""Watching running POV-Ray children without polling: sleep until one exits
(Linux pidfds), and read how far each has got from its verbose log."""

from __future__ import annotations

import ctypes
import math
import os
import select
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from ..image.ppm import ppm_layout
from .log import parse_progress

#: How often ``run_jobs`` reports the running jobs' progress, and checks for a stop, s.
PROGRESS_SECONDS = 0.25
STOP_CHECK_SECONDS = 0.1
#: Sleep of the fallback without pidfds (not Linux, or Linux before 5.3), s.
FALLBACK_SECONDS = 0.02


_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None
_IN_CLOSE_WRITE = 0x8
_IN_NONBLOCK, _IN_CLOEXEC = os.O_NONBLOCK, os.O_CLOEXEC
_PNG_END = b"IEND\xaeB`\x82"  # the last chunk of every PNG, with its CRC
_PPM_HEAD = 1024  # POV-Ray's PPM header: P6, four comment lines, size and maxval (about 130 bytes)


_POLL_MAX_MS = 2**31 - 1


def sleep_until_exit(pids: Sequence[int], seconds: float | None, fds: Sequence[int | None] = ()) -> None:
    """Sleep until one of the child processes `pids` exits, one of `fds` is readable, or
    `seconds` pass (None: no limit).

    The children must not have been reaped yet (a zombie still has its pidfd).
    Ctrl-C interrupts the sleep with a KeyboardInterrupt, as ``time.sleep`` does.
    """
    pidfds: list[int] = []
    try:
        try:
            for pid in pids:
                pidfds.append(os.pidfd_open(pid))
        except (AttributeError, OSError):  # no pidfd_open here: short sleeps
            time.sleep(FALLBACK_SECONDS if seconds is None else min(seconds, FALLBACK_SECONDS))
            return
        poller = select.poll()
        for fd in [*pidfds, *(fd for fd in fds if fd is not None)]:
            poller.register(fd, select.POLLIN)  # a pidfd is readable once its process has exited
        # poll() takes a C int of milliseconds (24.8 days): a longer limit wakes then, and the caller waits again
        poller.poll(None if seconds is None else min(max(0, math.ceil(seconds * 1000)), _POLL_MAX_MS))
    finally:
        for fd in pidfds:
            os.close(fd)


class JobWatch:
    """A running job's folder, watched (Linux inotify) for its images being written.

    `log` is the job's log in that folder, `images` returns its images in
    frame order, or None until all are there (``job.collect_images``), and
    `frame_image` where frame n (1-based) is written (``job.frame_image``).

    ``finished_frames`` tells which frames are complete while the job still
    runs, so the runner can hand each one over (to the image cache) as soon as
    POV-Ray has written it: a run stopped part way keeps every finished frame.

    POV-Ray spends about 0.3 s after writing its last image shutting its threads
    down (timed waits, then a 100 ms sleep) before it exits.  ``images_done``
    tells when every image of the job is complete, so the runner can take them
    and stop the child without waiting for that.  `fd` is readable when a file
    in the folder was closed after writing; None where inotify is missing (the
    runner then waits for the exit as before).
    """

    def __init__(self, log: Path, frames: int, images: Callable[[], Sequence[Path] | None],
                 frame_image: Callable[[int], Path] | None = None) -> None:
        self.frames, self.images, self.frame_image = frames, images, frame_image
        self.handed = 0  # frames 1..handed were reported by finished_frames
        self.waiting: float | None = None  # since when a written frame awaits the log's confirmation
        self.progress = LogProgress(log, frames)
        folder = log.parent
        self.fd: int | None = None
        self.early = False  # set by the runner when it stopped the child after its images
        self.written = False  # every image complete (the log may lag)
        self.checks = 0
        if _LIBC is not None and hasattr(_LIBC, "inotify_init1"):
            fd = _LIBC.inotify_init1(_IN_NONBLOCK | _IN_CLOEXEC)
            if fd >= 0 and _LIBC.inotify_add_watch(fd, os.fsencode(folder), _IN_CLOSE_WRITE) >= 0:
                self.fd = fd
            elif fd >= 0:
                os.close(fd)

    #: While the images are written but the log does not yet report every pixel (POV-Ray
    #: logs its last count just after the image), the runner looks again this often, s.
    recheck = 0.005

    def images_done(self) -> bool:
        """Whether every image is complete and the log reports every pixel of the last frame."""
        if self.fd is None:
            return False
        if not self.written and self._drain():
            images = self.images()
            self.written = images is not None and all(complete_image(path) for path in images)
        if not self.written:
            return False
        self.progress.frames_rendered()
        if self.progress.frame == self.frames and self.progress.share >= 1.0:
            return True
        self.checks += 1
        if self.checks * self.recheck > 0.2:  # no confirmation: wait for the exit as usual
            self.written = False
            self.close()
        return False

    def finished_frames(self) -> list[int]:
        """The frames (1-based, in order) newly known complete since the last call.

        POV-Ray 3.7 writes a frame's image in one go once the frame is traced
        (open, write, close), then logs the frame's last pixel count and starts
        the next frame.  A frame is complete when its file is whole
        (``complete_image``) and the log has reached its last pixel or a later
        frame, so a file still being written is never reported.
        """
        if self.frame_image is None:
            return []
        self.progress.frames_rendered()
        state = self.progress.frame, self.progress.share
        done = []
        while self.handed < self.frames:
            number = self.handed + 1
            if not complete_image(self.frame_image(number)):
                break
            if not (state[0] > number or (state[0] == number and state[1] >= 1.0)):
                # Written; the log follows within milliseconds (``awaiting_log``).
                self.waiting = time.monotonic() if self.waiting is None else self.waiting
                break
            self.handed, self.waiting = number, None
            done.append(number)
        return done

    @property
    def awaiting_log(self) -> bool:
        """A frame is written and its confirmation in the log is due any moment: look again
        soon (``recheck``), for half a second at most (then at the next event, or the job's end)."""
        return self.waiting is not None and time.monotonic() - self.waiting < 0.5

    def _drain(self) -> bool:
        if self.fd is None:  # closed: nothing to read
            return False
        events = False
        while True:
            try:
                events = bool(os.read(self.fd, 65536)) or events
            except BlockingIOError:
                return events
            except OSError:
                return False

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def complete_image(path: Path) -> bool:
    """Whether POV-Ray has written all of `path`: a PPM as long as its header says, a PNG
    ending with its end chunk (POV-Ray writes both in one go, the pixels last)."""
    try:
        with open(path, "rb") as f:
            if path.suffix == ".ppm":
                head = f.read(_PPM_HEAD)
                layout = ppm_layout(head)
                return layout is not None and os.fstat(f.fileno()).st_size == layout.size
            f.seek(-len(_PNG_END), os.SEEK_END)
            return f.read() == _PNG_END
    except OSError:
        return False


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
