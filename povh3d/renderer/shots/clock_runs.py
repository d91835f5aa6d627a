"""Animation frames as POV-Ray clock sequences: which runs render the shots of frames ``n..last``.

POV-Ray renders a clock sequence in one process, paying its start-up once
(about 0.2 s a frame after it, against 0.35 s for a run per frame).  When an
animation frame's batch is rendered (``renderer.shots.shots``), the same shots of the
later frames of the request are rendered with it: shot ``j`` of frames ``a..b``
is one POV-Ray run of those frames of the whole animation (``povray.job.ClockRun``:
``+KFI/+KFF/+KI/+KF`` of the request, the subset ``+SF a +EF b``), so POV-Ray
gives each frame the clock it gives it in the whole animation, bit for bit the
``+K`` of that frame's own still.  The runs are as few as the cores allow.

A run's ``--timeout`` is its frames' together.  When a run fails, the rest of
the request goes frame by frame (``SequenceLedger.failed``): the frames already
written are in the cache, and the error names the frame that fails.

Without the image cache (``--no-cache``) the later frames' images are held in
memory until their frame takes them.

Only a scene that reads ``clock`` alone qualifies: ``frame_number``,
``clock_delta`` and the rest differ between a frame rendered alone and inside
a sequence.  A batch whose shots share runs (``shots_per_job > 1``, e.g. a
depth pass or a bank of camera meshes) keeps its own runs per frame: its
template reads ``frame_number`` as its shot index.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ...errors import ConfigError

#: The animation words a sequence leaves exactly as a frame rendered alone sees them.
SEQUENCE_SAFE_WORDS = frozenset(("clock",))


def povray_clock(n: int, first: int, last: int, start: float, end: float) -> float:
    """The clock POV-Ray 3.7 gives frame ``n`` of ``+KFI first +KFF last +KI start +KF end``
    (``AnimationProcessing``: ``delta * (n - first) + start``, delta in double); POV-Ray then
    rounds it to single precision, as it does a still's ``+K``."""
    if last == first:
        return float(start)
    delta = float(end - start) / float(last - first)
    return delta * float(n - first) + float(start)


@dataclass
class SequenceLedger:
    """What the sequences of one request share, from frame to frame.

    ``stored``: the shots their runs rendered for later frames, by cache key: None when stored in
    the image cache, else the image itself (no cache: held until its frame takes it); a later
    frame counts them as rendered by this request.  ``failed``: a run failed, so the rest of the
    request goes frame by frame and an error names the frame that fails."""

    stored: dict[str, Any] = field(default_factory=dict)
    failed: bool = False


@dataclass(frozen=True)
class ClockSequence:
    """An animation of frames ``first..last`` (clock ``clock_start..clock_end``) being rendered from
    ``frame`` on: the frames the engine may render alongside ``frame``."""

    first: int
    last: int
    clock_start: float
    clock_end: float
    frame: int
    ledger: SequenceLedger = field(default_factory=lambda: SequenceLedger(), compare=False, repr=False)

    @property
    def stored(self) -> dict[str, Any]:
        return self.ledger.stored

    def __post_init__(self) -> None:
        if not 0 <= self.first <= self.frame <= self.last:
            raise ConfigError(f"clock sequence: frame {self.frame} must lie in {self.first}..{self.last}")

    def clock(self, n: int) -> float:
        return povray_clock(n, self.first, self.last, self.clock_start, self.clock_end)

    @property
    def later(self) -> range:
        return range(self.frame + 1, self.last + 1)

    def position(self, n: int) -> int:
        """POV-Ray's frame number of animation frame ``n`` in a run numbered 1..len (``+KFI1``)."""
        return n - self.first + 1

    @property
    def total(self) -> int:
        return self.last - self.first + 1


def plan_runs(lanes: dict[int, list[int]], processes: int) -> list[tuple[int, list[int]]]:
    """Runs ``(shot, frames)`` covering ``lanes`` (shot -> the frames missing it, ascending): each
    run a stretch of consecutive frames, the longest split until there are ``processes`` runs."""
    runs: list[tuple[int, list[int]]] = []
    for shot, frames in lanes.items():
        start = 0
        for i in range(1, len(frames) + 1):
            if i == len(frames) or frames[i] != frames[i - 1] + 1:
                runs.append((shot, frames[start:i]))
                start = i
    while runs and len(runs) < processes:
        longest = max(range(len(runs)), key=lambda i: len(runs[i][1]))
        shot, frames = runs[longest]
        if len(frames) < 2:
            break
        half = (len(frames) + 1) // 2
        runs[longest:longest + 1] = [(shot, frames[:half]), (shot, frames[half:])]
    return runs
