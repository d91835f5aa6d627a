"""Animations: one H3D image per value of POV-Ray's ``clock``.

Frame numbers and clock values follow POV-Ray's own animation options, not
cyclic: ``--frames A:B`` is ``+KFI A +KFF B`` (frames A..B, both included) and
``--clock KI:KF`` (default ``0:1``) is ``+KI KI +KF KF``, so frame ``n`` gets

    clock(n) = KI + (KF - KI) * (n - A) / (B - A)       (KI when A == B)

computed from ``n`` itself, never by adding steps, in POV-Ray's own arithmetic
(``renderer.shots.clock_runs.povray_clock``), so a frame's clock is the one POV-Ray's
2D animation of the same range gives it.  Frame ``n`` is written as
``OUT_nnnn.png`` (at least four digits) with its sidecar.

Every frame is rendered by the same function as a still (``renderer.render``), so a
mapping, a mesh model, a method's options and the quality apply alike.  POV-Ray's
own frame machinery is taken: povh3d renders a batch of cameras as the frames of
one POV-Ray run (the shots of an ``renderer.shots.batch.ShotBatch``); a scene that reads
``frame_number``, ``clock_delta`` and the like gets each shot in a run of its own,
where they have a still's values (``renderer.shots.shots``).  A scene animates with
``clock``, which povh3d sets to the same value in every run of a frame.

A scene that reads only ``clock`` is rendered as POV-Ray clock sequences: when
frame ``n`` is rendered, the engine renders the same shots of frames ``n..last``
in as few POV-Ray runs as the cores allow (``renderer.shots.clock_runs``), storing each
image in the cache as POV-Ray writes it; the later frames then come from the
cache.  A run stopped part way keeps every finished image, so a second run
renders only the missing ones.

Frames whose scene does not change are not rendered again: a scene whose files
(and the POV-Ray include files they name) never mention the clock looks the same
at every clock value (``Scene.uses_clock``), so the first frame is rendered and
the others are copies of it.  A scene that reads the clock gets one cache entry
per clock value, so a second run, or a longer range sharing frames with an
earlier run, renders only new clock values.
"""

from __future__ import annotations

import re
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .shots.clock_runs import ClockSequence, SequenceLedger, povray_clock
from .methods.quality import Progress
from ..errors import ConfigError, OutputError, PovrayError, param, raw_message
from ..image.io import read_png, write_sidecar
from ..image.sidecar import AnimationRecord, Sidecar
from ..jsontext import JSONValue
from ..image.video import write_video
from ..system import owned_prefix, sweep_orphans
from .records import write_image
from .passes.beside import BesidePass

_RANGE = re.compile(r"^\s*(\d+)\s*:\s*(\d+)\s*$")


@dataclass(frozen=True)
class FrameRange:
    """Frames ``first..last`` (both included) and the clock range they span.

    Attributes
    ----------
    first, last : int          POV-Ray's ``+KFI`` and ``+KFF``, ``0 <= first <= last``
    clock_start, clock_end : float   POV-Ray's ``+KI`` and ``+KF``
    """

    first: int
    last: int
    clock_start: float = 0.0
    clock_end: float = 1.0

    def __post_init__(self) -> None:
        for name in ("first", "last"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                raise ConfigError(f"{param('frames')}: {name} frame must be a whole number >= 0, got {value!r}")
        if self.last < self.first:
            raise ConfigError(f"{param('frames')} {self.first}:{self.last} is reversed (no frames); "
                              f"write FIRST:LAST with FIRST <= LAST, e.g. {self.last}:{self.first}")
        for name in ("clock_start", "clock_end"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or value != value or abs(value) == float("inf"):
                raise ConfigError(f"{param('clock')}: {name} must be a finite number, got {value!r}")

    @property
    def numbers(self) -> range:
        return range(self.first, self.last + 1)

    def __len__(self) -> int:
        return self.last - self.first + 1

    def clock(self, n: int) -> float:
        """POV-Ray's clock at frame `n` (non-cyclic animation), computed as POV-Ray does."""
        if not self.first <= n <= self.last:
            raise ConfigError(f"frame {n} is outside {self.first}:{self.last}")
        return povray_clock(n, self.first, self.last, self.clock_start, self.clock_end)

    def sequence(self, n: int, ledger: SequenceLedger) -> ClockSequence:
        """Frames ``n..last`` as the clock sequence the engine may render in few POV-Ray runs
        (``ledger``: what the request's sequences share)."""
        return ClockSequence(self.first, self.last, float(self.clock_start), float(self.clock_end), n, ledger)


#: The most frames one render may hold.
MAX_FRAMES = 100_000


def parse_frames(text: str) -> tuple[int, int]:
    """``'0:47'`` -> ``(0, 47)``; a ConfigError naming the rule otherwise."""
    match = _RANGE.match(text or "")
    if not match:
        raise ConfigError(f"{param('frames')} takes FIRST:LAST with whole numbers, e.g. 0:47, got {text!r}")
    first, last = int(match[1]), int(match[2])
    if last - first + 1 > MAX_FRAMES:   # a range typed wrong runs for days, one frame file each
        raise ConfigError(f"{param('frames')} {text} is {last - first + 1} frames, over {MAX_FRAMES} (an hour at 24 fps is "
                          f"86400); render the animation in parts, e.g. {param('frames')} {first}:{first + 9999}")
    return first, last


def parse_clock(text: str) -> tuple[float, float]:
    """``'0:2.5'`` -> ``(0.0, 2.5)``."""
    parts = (text or "").split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        start, end = float(parts[0]), float(parts[1])
    except ValueError:
        raise ConfigError(f"{param('clock')} takes START:END numbers, e.g. 0:1, got {text!r}") from None
    return start, end


def frame_path(output: str | Path, n: int, digits: int = 4) -> Path:
    """``OUT.png`` -> ``OUT_0007.png`` for frame 7."""
    output = Path(output)
    return output.with_name(f"{output.stem}_{n:0{digits}d}{output.suffix}")




@dataclass
class RenderedImage:
    """One rendered image and its sidecar record, as written for a still or an animation frame."""

    image: np.ndarray                   # (H, W, C) uint8 or uint16
    record: Sidecar
    views: np.ndarray | None = None     # (Ny, Nx, Ly, Lx, C) when asked for
    from_cache: bool = False            # every shot came from the cache
    depth: BesidePass[np.ndarray] | None = None   # the depth pass run beside the render (``outputs.steps``)


ImageRenderer = Callable[..., RenderedImage]  # (clock, progress, sequence=ClockSequence or None)
#: Files made from a frame beside it (a Looking Glass quilt, its native image): ``(staged frame path,
#: frame) -> (the frame's record with their entries, the files written beside it)``.
Companions = Callable[[Path, RenderedImage], tuple[Sidecar, list[Path]]]


def render_sequence(frames: FrameRange, output: Path, render_image: ImageRenderer, *, uses_clock: bool,
                    progress: Progress | None = None, video: Path | None = None,
                    fps: float = 24.0, companions: Companions | None = None) -> dict[str, JSONValue]:
    """Render frames ``frames.first..last`` as ``OUT_nnnn.png``, each by ``render_image(clock, progress)``.

    The frames are made in a hidden folder beside `output` and moved into
    place only when every one is done, so a failure leaves no partial
    sequence (and no video).  A scene that does not read the clock is rendered
    once (clock None) and copied.  ``companions`` writes files made from each
    frame beside it (a Looking Glass preset: its quilt and native image), moved
    into place with it; the video then shows each frame's first companion (the quilt).

    Returns
    -------
    dict
        ``frames`` (the paths), ``rendered`` (frames POV-Ray ran for),
        ``from_cache`` (frames wholly from the image cache),
        ``copied`` (frames that are copies of an identical frame),
        ``scene_uses_clock``, ``video`` (its path or None), ``seconds``.
    """
    digits = max(4, len(str(frames.last)))
    folder = output.parent if str(output.parent) else Path(".")
    prefix = f".{output.stem}-frames-"
    sweep_orphans(folder, prefix)  # staging folders of a killed run (system.sweep_orphans)
    try:
        staging = Path(tempfile.mkdtemp(prefix=owned_prefix(prefix), dir=folder))
    except OSError as error:
        raise OutputError(f"cannot write into {str(folder)!r}: {error.strerror}") from None

    total = len(frames)
    start = time.perf_counter()
    counts = {"rendered": 0, "from_cache": 0, "copied": 0}
    report: dict[str, JSONValue] = {"frames": [], "rendered": 0, "from_cache": 0, "copied": 0,
                              "scene_uses_clock": uses_clock, "video": None}
    scale = [1]  # camera frames per animation frame, learnt from the first render
    ledger = SequenceLedger()  # what the clock sequences of this request share
    shown = [0.0]  # the furthest progress reported: a clock sequence reports later frames early
    first: tuple[RenderedImage, Path] | None = None
    made: dict[int, list[Path]] = {}   # each frame's companions, staged
    try:
        for index, n in enumerate(frames.numbers):
            staged = frame_path(staging / output.name, n, digits)
            info = AnimationRecord(frame=n, clock=frames.clock(n), frames=(frames.first, frames.last),
                                   clock_range=(frames.clock_start, frames.clock_end), scene_uses_clock=uses_clock)
            if uses_clock or first is None:
                try:
                    frame = render_image(frames.clock(n) if uses_clock else None,
                                         _frame_progress(progress, index, total, scale, shown),
                                         sequence=frames.sequence(n, ledger) if uses_clock else None)
                except PovrayError as exc:  # name the animation frame, not only POV-Ray's camera batch
                    raise type(exc)(f"animation frame {n} (clock {frames.clock(n):g}), {raw_message(exc)}", command=exc.command,
                                    returncode=exc.returncode, log_tail=exc.log_tail) from None
                counts["from_cache" if frame.from_cache else "rendered"] += 1
                record, made[n] = companions(staged, frame) if companions else (frame.record, [])
                write_image(staged, frame.image, record.with_(animation=info))
                first = first or (frame, staged)
            else:
                # The scene cannot tell this clock from the first: same pixels.
                record, made[n] = companions(staged, first[0]) if companions else (first[0].record, [])
                shutil.copyfile(first[1], staged)
                write_sidecar(staged, record.with_(animation=info))
                counts["copied"] += 1
            if progress is not None:
                shown[0] = max(shown[0], (index + 1) * scale[0])
                progress(shown[0], total * scale[0])
        finals = [frame_path(output, n, digits) for n in frames.numbers]
        for n, final in zip(frames.numbers, finals):
            staged = frame_path(staging / output.name, n, digits)
            # image first, sidecar last (image.io: a new sidecar never describes an old image)
            staged.replace(final)
            staged.with_suffix(".json").replace(final.with_suffix(".json"))
            for companion in made.get(n, []):
                companion.replace(final.with_name(companion.name))
                if companion.with_suffix(".json").exists():
                    companion.with_suffix(".json").replace(final.with_name(companion.with_suffix(".json").name))
        report.update(counts, frames=[str(p) for p in finals])
        shown_frames = finals
        if made:
            report["companions"] = [[str(final.with_name(p.name)) for p in made[n]]
                                    for n, final in zip(frames.numbers, finals)]
            if all(made.values()):
                shown_frames = [final.with_name(made[n][0].name) for n, final in zip(frames.numbers, finals)]
        if video is not None:
            write_video(_Frames(shown_frames), video, fps=fps)
            report["video"] = str(video)
        report["seconds"] = round(time.perf_counter() - start, 4)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return report


class _Frames(Sequence):
    """The frames' files as images, read one at a time as the video writer takes them."""

    def __init__(self, paths: list[Path]) -> None:
        self.paths = paths

    def __len__(self) -> int:
        return len(self.paths)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        return read_png(self.paths[index])


def _frame_progress(progress: Progress | None, index: int, total: int, scale: list[int],
                    shown: list[float]) -> Progress | None:
    """Progress of frame `index` as a share of the whole animation (in camera frames); a clock
    sequence reports more than the frame's own shots (the later frames' as well)."""
    if progress is None:
        return None

    def update(done: float, per_frame: int) -> None:
        scale[0] = max(1, per_frame)
        shown[0] = max(shown[0], index * scale[0] + done)
        progress(shown[0], total * scale[0])

    return update
