"""Animations: one H3D image per value of POV-Ray's ``clock``.

Frame numbers and clock values follow POV-Ray's own animation options, not
cyclic: ``--frames A:B`` is ``+KFI A +KFF B`` (frames A..B, both included) and
``--clock KI:KF`` (default ``0:1``) is ``+KI KI +KF KF``, so frame ``n`` gets

    clock(n) = KI + (KF - KI) * (n - A) / (B - A)       (KI when A == B)

computed from ``n`` itself, never by adding steps.  Frame ``n`` is written as
``OUT_nnnn.png`` (at least four digits) with its sidecar.

POV-Ray's own frame machinery is taken: povh3d renders a batch of cameras as
the frames of one POV-Ray run (``render.FrameBatch``), so inside a scene
``frame_number`` and ``clock_delta`` belong to that batch.  A scene animates
with ``clock``, which povh3d sets to the same value in every run of a frame.

Frames whose scene does not change are not rendered again.  A scene whose
files (and the POV-Ray include files they name) never mention ``clock`` or
the other animation identifiers looks the same at every clock value: the
clock is then left out of the POV-Ray run and of the cache key, the first
frame is rendered and the others are copies of it.  A scene that reads the
clock gets one cache entry per clock value, so a second run, or a longer
range sharing frames with an earlier run, renders only new clock values.
"""

from __future__ import annotations

import dataclasses
import re
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import ConfigError, OutputError
from .geometry import LensArray
from .imageio import read_png, write_sidecar
from .render import AUTO, Progress, RenderSettings
from .scene import Scene, load_scene

__all__ = ["FrameRange", "parse_frames", "parse_clock", "scene_uses_clock", "frame_path",
           "render_animation"]

# Every identifier through which a scene can see the animation.
_CLOCK_WORDS = re.compile(r"\b(clock|clock_delta|clock_on|frame_number|initial_frame|"
                          r"final_frame|initial_clock|final_clock)\b")
_COMMENTS = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_STRING = re.compile(r'"([^"\n]{1,400})"')
_RANGE = re.compile(r"^\s*(\d+)\s*:\s*(\d+)\s*$")
_TEXT_SUFFIXES = (".pov", ".inc", ".mcr", ".ini")


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
                raise ConfigError(f"--frames: {name} frame must be a whole number >= 0, got {value!r}")
        if self.last < self.first:
            raise ConfigError(f"--frames {self.first}:{self.last} is reversed (no frames); "
                              f"write FIRST:LAST with FIRST <= LAST, e.g. {self.last}:{self.first}")
        for name in ("clock_start", "clock_end"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or value != value or abs(value) == float("inf"):
                raise ConfigError(f"--clock: {name} must be a finite number, got {value!r}")

    @property
    def numbers(self) -> range:
        return range(self.first, self.last + 1)

    def __len__(self) -> int:
        return self.last - self.first + 1

    def clock(self, n: int) -> float:
        """POV-Ray's clock at frame `n` (non-cyclic animation)."""
        if not self.first <= n <= self.last:
            raise ConfigError(f"frame {n} is outside {self.first}:{self.last}")
        if self.last == self.first:
            return float(self.clock_start)
        a, b = float(self.clock_start), float(self.clock_end)
        t = (n - self.first) / (self.last - self.first)
        # From the nearer end: exact at both ends and constant when a == b.
        return a + t * (b - a) if t <= 0.5 else b - (1 - t) * (b - a)


def parse_frames(text: str) -> tuple[int, int]:
    """``'0:47'`` -> ``(0, 47)``; a ConfigError naming the rule otherwise."""
    match = _RANGE.match(text or "")
    if not match:
        raise ConfigError(f"--frames takes FIRST:LAST with whole numbers, e.g. 0:47, got {text!r}")
    return int(match[1]), int(match[2])


def parse_clock(text: str) -> tuple[float, float]:
    """``'0:2.5'`` -> ``(0.0, 2.5)``."""
    parts = (text or "").split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        start, end = float(parts[0]), float(parts[1])
    except ValueError:
        raise ConfigError(f"--clock takes START:END numbers, e.g. 0:1, got {text!r}") from None
    return start, end


def _povray_include_dirs(binary: str | None) -> list[Path]:
    """POV-Ray's own include folders (``/usr/share/povray-3.7/include``)."""
    found = []
    if binary:
        prefix = Path(binary).resolve().parent.parent
        found += sorted((prefix / "share").glob("povray-*/include"))
    return found + sorted(Path("/usr/share").glob("povray-*/include"))


def scene_uses_clock(scene: Scene, povray_binary: str | None = None) -> bool:
    """Whether any text file of `scene`, or a POV-Ray include file it names, reads the clock.

    Comments do not count; a mention anywhere else, even in a string, does:
    a false alarm only costs renders, a miss would give wrong frames.
    """
    texts = [_COMMENTS.sub("", p.read_bytes().decode("latin-1"))
             for p in scene.files if p.suffix.lower() in _TEXT_SUFFIXES]
    if any(_CLOCK_WORDS.search(text) for text in texts):
        return True
    names = {name for text in texts for name in _STRING.findall(text)}
    system = _povray_include_dirs(povray_binary)
    seen: set[Path] = set()
    while names:
        name = names.pop()
        for folder in system:
            path = folder / name
            if path.is_file() and path not in seen:
                seen.add(path)
                text = _COMMENTS.sub("", path.read_bytes().decode("latin-1"))
                if _CLOCK_WORDS.search(text):
                    return True
                names.update(_STRING.findall(text))  # includes of includes
                break
    return False


def frame_path(output: str | Path, n: int, digits: int = 4) -> Path:
    """``OUT.png`` -> ``OUT_0007.png`` for frame 7."""
    output = Path(output)
    return output.with_name(f"{output.stem}_{n:0{digits}d}{output.suffix}")


def render_animation(scene_path: str | Path, lens_array: LensArray, output: str | Path,
                     frames: FrameRange, *, method: str = "multi-ortho",
                     settings: RenderSettings | None = None,
                     include_dirs: tuple[str | Path, ...] = (),
                     display: dict[str, Any] | None = None, progress: Progress | None = None,
                     video: str | Path | None = None, fps: float = 24.0,
                     povray_binary: str | None = None) -> dict[str, Any]:
    """Render frames ``frames.first..last`` of an animated scene as ``OUT_nnnn.png``.

    The frames are made in a hidden folder beside `output` and moved into
    place only when every one is done, so a failure leaves no partial
    sequence (and no video).

    Returns
    -------
    dict
        ``frames`` (the paths), ``rendered`` (frames POV-Ray ran for),
        ``from_cache`` (frames wholly from the image cache),
        ``copied`` (frames that are copies of an identical frame),
        ``scene_uses_clock``, ``video`` (its path or None), ``seconds``.
    """
    from . import api
    from .povray import find_povray
    from .quality_bench import resolve_auto
    from .video import check_video_path, write_video

    settings = settings or RenderSettings()
    output = Path(output)
    if output.suffix.lower() != ".png":
        raise ConfigError(f"the output {str(output)!r} must be a .png file")
    video_path = check_video_path(video) if video is not None else None
    if not fps > 0:
        raise ConfigError(f"--fps must be a positive number, got {fps}")
    scene = load_scene(scene_path, include_dirs)
    if povray_binary is None and not settings.scheduler:
        povray_binary = find_povray()
    uses_clock = scene_uses_clock(scene, povray_binary)
    if settings.quality == AUTO:  # choose once, on the first frame, for the whole sequence
        first = dataclasses.replace(settings, clock=frames.clock(frames.first) if uses_clock else None)
        chosen, _ = resolve_auto(scene, lens_array, method, first)
        settings = dataclasses.replace(settings, quality=chosen.quality, max_error_db=None)
    digits = max(4, len(str(frames.last)))
    folder = output.parent if str(output.parent) else Path(".")
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{output.stem}-frames-", dir=folder))
    except OSError as error:
        raise OutputError(f"cannot write into {str(folder)!r}: {error.strerror}") from None

    total = len(frames)
    start = time.perf_counter()
    report: dict[str, Any] = {"frames": [], "rendered": 0, "from_cache": 0, "copied": 0,
                              "scene_uses_clock": uses_clock, "video": None}
    scale = [1]  # camera frames per animation frame, learnt from the first render
    first_record: dict[str, Any] | None = None
    try:
        for index, n in enumerate(frames.numbers):
            clock = frames.clock(n)
            staged = frame_path(staging / output.name, n, digits)
            info = {"frame": n, "clock": clock, "frames": [frames.first, frames.last],
                    "clock_range": [frames.clock_start, frames.clock_end],
                    "scene_uses_clock": uses_clock}
            if uses_clock or first_record is None:
                record = api.render(scene.path, lens_array, staged, method=method,
                                    settings=dataclasses.replace(settings, clock=clock if uses_clock else None),
                                    include_dirs=include_dirs, display=display,
                                    progress=_frame_progress(progress, index, total, scale))
                first_record = first_record or record
                timings = record["timings"]
                cached = timings["frames_from_cache"] == timings["frames"]
                report["from_cache" if cached else "rendered"] += 1
            else:
                # The scene cannot tell this clock from the first: same pixels.
                shutil.copyfile(frame_path(staging / output.name, frames.first, digits), staged)
                record = dict(first_record)
                report["copied"] += 1
            write_sidecar(staged, {**record, "animation": info})
            if progress is not None:
                progress((index + 1) * scale[0], total * scale[0])
        finals = [frame_path(output, n, digits) for n in frames.numbers]
        for n, final in zip(frames.numbers, finals):
            staged = frame_path(staging / output.name, n, digits)
            staged.with_suffix(".json").replace(final.with_suffix(".json"))
            staged.replace(final)
        report["frames"] = [str(p) for p in finals]
        if video_path is not None:
            write_video([read_png(p) for p in finals], video_path, fps=fps)
            report["video"] = str(video_path)
        report["seconds"] = round(time.perf_counter() - start, 4)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return report


def _frame_progress(progress: Progress | None, index: int, total: int, scale: list[int]
                    ) -> Callable[[int, int], None] | None:
    """Progress of frame `index` as a share of the whole animation (in camera frames)."""
    if progress is None:
        return None

    def update(done: int, per_frame: int) -> None:
        scale[0] = max(1, per_frame)
        progress(index * scale[0] + done, total * scale[0])

    return update
