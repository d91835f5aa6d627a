"""Turn a list of camera frames into images: cache lookups, POV-Ray jobs, reads.

A rendering method describes what it needs as a ``FrameBatch``: one template,
values common to every frame, and the per-frame values (a view's direction, a
lens's centre).  Each frame has its own content key, so an unchanged view comes
from the cache however the missing ones are batched into POV-Ray runs.
"""

from __future__ import annotations

import hashlib
import os
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from . import __version__
from .cache import ImageCache, content_key, default_cache_dir
from .errors import ConfigError
from .footprint import GRID, angular_grid, latin_hypercube
from .imageio import read_png
from .povray import JobResult, PovrayJob, find_povray, povray_version, run_jobs
from .sandbox import files_within
from .scene import Scene
from .templating import render_template, templates_dir

@dataclass(frozen=True)
class Quality:
    """How densely a render samples each pixel's footprint (CONVENTIONS).

    Attributes
    ----------
    antialias : float or None   POV-Ray's ``+A`` threshold; None: one ray per sub-view
    aa_method : {1, 2}          ``+AM``: 1 non-recursive, 2 adaptive recursive
    aa_depth : int              ``+R``: supersampling depth
    jitter : bool               ``+J``: jitter the supersamples
    subviews : int              angular sub-views per axis, averaged in linear light:
                                an orthographic view pixel spans the lens aperture
                                but not the pixel's angular width; these do
    footprint : int             > 0: that many stratified random samples of the whole
                                footprint instead (the converged reference)
    seed : int                  of the footprint samples
    max_trace_level : int or None   overrides the scene's (None: the scene's own)
    """

    antialias: float | None = None
    aa_method: int = 1
    aa_depth: int = 2
    jitter: bool = False
    subviews: int = 1
    footprint: int = 0
    seed: int = 0
    max_trace_level: int | None = None

    def __post_init__(self) -> None:
        if self.antialias is not None and not 0 <= self.antialias <= 3:
            raise ConfigError(f"the antialiasing threshold must be within 0..3, got {self.antialias}")
        if self.aa_method not in (1, 2):
            raise ConfigError(f"the antialiasing method must be 1 or 2, got {self.aa_method}")
        if not 1 <= self.aa_depth <= 9:
            raise ConfigError(f"the antialiasing depth must be within 1..9, got {self.aa_depth}")
        if self.subviews < 1 or not 0 <= self.footprint <= GRID:
            raise ConfigError(f"sub-views must be at least 1 and footprint samples 0 to {GRID}")
        if self.max_trace_level is not None and not 1 <= self.max_trace_level <= 256:
            raise ConfigError(f"max trace level must be within 1..256, got {self.max_trace_level}")

    @property
    def options(self) -> tuple[str, ...]:
        """POV-Ray's command-line switches for this quality."""
        if self.antialias is None:
            return ("-A",)
        # POV-Ray jitters by default, and its jitter depends on where a pixel sits in
        # the image: -J keeps a pixel's value whatever the layout (crop, tiling).
        return (f"+A{self.antialias:g}", f"+AM{self.aa_method}", f"+R{self.aa_depth}",
                "+J" if self.jitter else "-J")

    def point_sampled(self) -> Quality:
        """This quality for a method that traces one ray per sub-view (no footprint
        samples): sub-views and footprint samples become adaptive antialiasing."""
        if self.subviews == 1 and not self.footprint:
            return self
        aa = {} if self.antialias is not None else {"antialias": 0.05, "aa_method": 2, "aa_depth": 3}
        return replace(self, subviews=1, footprint=0, **aa)

    def samples(self) -> np.ndarray:
        """The footprint samples each pixel gets, ``(K, 4)`` (see ``povh3d.footprint``)."""
        if self.footprint:
            return latin_hypercube(self.footprint, self.seed)
        return angular_grid(self.subviews)

    @property
    def label(self) -> str:
        parts = [" ".join(self.options)]
        if self.footprint:
            parts.append(f"{self.footprint} footprint samples")
        elif self.subviews > 1:
            parts.append(f"{self.subviews}x{self.subviews} sub-views")
        if self.max_trace_level is not None:
            parts.append(f"trace level {self.max_trace_level}")
        return ", ".join(parts)


# The named levels, chosen from `povh3d bench` (README, "Run time against error"):
# on a finely textured scene, against a reference that integrates every pixel's
# footprint, point sampling reached 21 dB; POV-Ray's adaptive antialiasing 34 dB
# at about 1.8x the time (it integrates across the lens aperture, which an
# orthographic view pixel spans, not the pixel's angular width); stratified
# footprint samples converge to the reference itself, 256 of them to its noise
# floor.  draft is point-sampled: what methods are compared with when they must
# agree exactly.  A method that cannot trace footprint samples antialiases
# instead (``Quality.point_sampled``).
QUALITY_LEVELS: dict[str, Quality] = {
    "draft": Quality(),
    "normal": Quality(antialias=0.1, aa_method=2, aa_depth=3),
    "high": Quality(footprint=256),
}
AUTO = "auto"  # --quality auto --max-error DB: the fastest setting that meets DB (quality_bench)
QUALITY_OPTIONS: dict[str, tuple[str, ...]] = {name: q.options for name, q in QUALITY_LEVELS.items()}

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class RenderSettings:
    """How to run POV-Ray; none of it changes the geometry.

    Attributes
    ----------
    quality : {'draft', 'normal', 'high', 'auto'} or Quality
              ('auto' is resolved before rendering; see ``quality_bench.resolve_auto``)
    jobs : int or None          parallel POV-Ray processes (None: chosen per method)
    threads : int or None       POV-Ray threads per process (None: cores / jobs)
    timeout : float or None     seconds allowed to each POV-Ray run
    use_cache : bool            read and write the image cache
    cache_dir : Path or None    None: ``default_cache_dir()``
    bit_depth : {8, 16}
    back_off : float or None    mm in front of the screen where rays start (None: default)
    clock : float or None       POV-Ray's ``clock`` for every run (None: POV-Ray's default, 0);
                                set only for scenes that read it (see animation.py)
    scheduler : str or None     Dask scheduler address (``tcp://host:8786``); None: local processes
    max_error_db : float or None   with quality 'auto': the lowest PSNR against the reference to accept
    """

    quality: str | Quality = "normal"
    jobs: int | None = None
    threads: int | None = None
    timeout: float | None = None
    use_cache: bool = True
    cache_dir: Path | None = None
    bit_depth: int = 8
    back_off: float | None = None
    clock: float | None = None
    scheduler: str | None = None
    max_error_db: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.quality, Quality) and self.quality not in (*QUALITY_LEVELS, AUTO):
            raise ConfigError(f"quality must be one of {', '.join(QUALITY_LEVELS)} or auto, got {self.quality!r}")
        if (self.quality == AUTO) != (self.max_error_db is not None):
            raise ConfigError("--quality auto needs --max-error DB (the lowest PSNR to accept), "
                              "and --max-error needs --quality auto")
        if self.jobs is not None and self.jobs < 1:
            raise ConfigError(f"--jobs must be at least 1, got {self.jobs}")
        if self.threads is not None and self.threads < 1:
            raise ConfigError(f"--threads must be at least 1, got {self.threads}")
        if self.timeout is not None and not self.timeout > 0:
            raise ConfigError(f"--timeout must be a positive number of seconds, got {self.timeout}")
        if self.bit_depth not in (8, 16):
            raise ConfigError(f"bit depth must be 8 or 16, got {self.bit_depth}")
        if self.back_off is not None and not (np.isfinite(self.back_off) and self.back_off > 0):
            raise ConfigError(f"--front-clearance must be a positive number of mm, got {self.back_off}")

        if self.clock is not None and not np.isfinite(self.clock):
            raise ConfigError(f"the clock must be a finite number, got {self.clock}")

    @property
    def spec(self) -> Quality:
        if self.quality == AUTO:
            raise RuntimeError("resolve --quality auto first (quality_bench.resolve_auto)")
        return self.quality if isinstance(self.quality, Quality) else QUALITY_LEVELS[self.quality]

    @property
    def options(self) -> tuple[str, ...]:
        # +K sets the clock of a still; a run of several camera frames is a
        # POV-Ray animation, where initial = final clock keeps it constant.
        c = self.clock
        clock = () if c is None else (f"+K{c!r}", f"+KI{c!r}", f"+KF{c!r}")
        return self.spec.options + clock


@dataclass(frozen=True)
class FrameBatch:
    """What a method asks POV-Ray for: ``len(frames)`` images of ``width x height``.

    ``frames_per_job`` bounds how many frames one POV-Ray run renders as an
    animation: a run costs about 0.7 s to start, a further frame about 0.2 s.
    """

    template: str
    context: dict[str, Any]
    frames: list[dict[str, Any]]
    width: int
    height: int
    frames_per_job: int = 1
    processes: int | None = None  # the method's preferred process count
    options: tuple[str, ...] = ()  # POV-Ray switches after the quality's, e.g. a coverage pre-pass


def mesh_camera_batch(template: str, meshes: list[Any], options: tuple[str, ...] = ()) -> FrameBatch:
    """One frame per camera mesh (``cameras.CameraMesh``, all of one image size), spread over the cores."""
    width, height = meshes[0].image_size
    if len(meshes) == 1:
        return FrameBatch(template, {"mesh": meshes[0]}, [{}], width, height, processes=1, options=options)
    processes = min(cpu_count(), len(meshes))
    return FrameBatch(template, {}, [{"mesh": m} for m in meshes], width, height,
                      frames_per_job=-(-len(meshes) // processes), processes=processes, options=options)


@dataclass
class RenderStats:
    """What a render did, for the sidecar and the benchmark."""

    frames: int = 0
    cached: int = 0
    jobs: int = 0
    processes: int = 0
    threads: int = 0
    povray_seconds: list[float] = field(default_factory=list)
    wall_seconds: float = 0.0
    povray_version: str = ""

    def as_dict(self) -> dict[str, Any]:
        return {"frames": self.frames, "frames_from_cache": self.cached, "povray_jobs": self.jobs,
                "processes": self.processes, "threads_per_process": self.threads,
                "povray_seconds_total": round(sum(self.povray_seconds), 4),
                "wall_seconds": round(self.wall_seconds, 4)}


class LocalRunner:
    """Runs jobs as POV-Ray processes on this machine (``dask_backend.DaskRunner``: on a cluster)."""

    def __init__(self, binary: str) -> None:
        self.binary = binary
        self.version = povray_version(binary)

    def run(self, jobs: list[PovrayJob], *, processes: int,
            on_result: Callable[[JobResult], None]) -> list[float]:
        return run_jobs(jobs, processes=processes, on_result=on_result, binary=self.binary)


def cpu_count() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _canonical(value: Any) -> Any:
    """JSON-able stand-in for key computation: arrays become their hash."""
    if isinstance(value, np.ndarray):
        return {"sha256": hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest(),
                "shape": value.shape, "dtype": str(value.dtype)}
    if isinstance(value, dict):
        return {k: _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if hasattr(value, "__dataclass_fields__"):
        return {k: _canonical(getattr(value, k)) for k in value.__dataclass_fields__}
    return value


def _template_digest(name: str) -> str:
    """Hash of the template and the base it extends: a template edit invalidates the cache."""
    h = hashlib.sha256()
    for n in (name, "scene.pov.j2"):
        h.update((templates_dir() / n).read_bytes())
    return h.hexdigest()


def build_script(batch: FrameBatch, frames: list[dict[str, Any]], *, method: str, scene_path: str,
                 add_assumed_gamma: bool, header: dict[str, Any]) -> str:
    """The POV-Ray script that renders ``frames`` of ``batch`` as animation frames 1..n."""
    return render_template(batch.template, version=__version__, method=method, scene_path=scene_path,
                           add_assumed_gamma=add_assumed_gamma, frames=frames, **header, **batch.context)


def render_frames(scene: Scene, batch: FrameBatch, settings: RenderSettings, *,
                  method: str, header: dict[str, Any], progress: Progress | None = None,
                  ) -> tuple[list[np.ndarray], RenderStats]:
    """Render every frame of ``batch`` (or take it from the cache), in order.

    Parameters
    ----------
    scene : Scene
    batch : FrameBatch
    settings : RenderSettings
    method : str                 the method's name, written into the script header
    header : dict                display constants for the scene header template
    progress : callable(done, total), optional

    Returns
    -------
    images : list of (height, width, C) uint8 or uint16 arrays, one per frame
    stats : RenderStats
    """
    start = time.perf_counter()
    if settings.scheduler:
        from .dask_backend import DaskRunner
        runner: Any = DaskRunner(settings.scheduler)
    else:
        runner = LocalRunner(find_povray())
    stats = RenderStats(frames=len(batch.frames), povray_version=runner.version)
    cache = ImageCache(settings.cache_dir or default_cache_dir()) if settings.use_cache else None

    common_key = content_key(__version__, stats.povray_version, scene.digest, batch.template,
                             _template_digest(batch.template), _canonical(batch.context),
                             _canonical(header), batch.width, batch.height, settings.options,
                             settings.bit_depth, scene.sets_assumed_gamma, batch.options)
    keys = [content_key(common_key, _canonical(frame)) for frame in batch.frames]
    images: list[np.ndarray | None] = [None] * len(keys)
    missing: list[int] = []
    for index, key in enumerate(keys):
        hit = cache.get(key) if cache else None
        if hit is not None:
            images[index] = read_png(hit)
        else:
            missing.append(index)
    stats.cached = len(keys) - len(missing)
    # Identical frames (same content key) in one batch are traced once.
    first_of: dict[str, int] = {}
    copies = {i: first_of.setdefault(keys[i], i) for i in missing}
    missing = [i for i in missing if copies[i] == i]
    n_copies = Counter(copies.values())

    chunks = [missing[i:i + batch.frames_per_job] for i in range(0, len(missing), batch.frames_per_job)]
    cores = cpu_count()
    processes = max(1, min(len(chunks) or 1, settings.jobs or batch.processes or cores))
    threads = settings.threads or max(1, cores // processes)
    stats.jobs, stats.processes, stats.threads = len(chunks), processes, threads

    jobs = []
    for chunk in chunks:
        script = build_script(batch, [batch.frames[i] for i in chunk], method=method,
                              scene_path=str(scene.path), add_assumed_gamma=not scene.sets_assumed_gamma,
                              header=header)
        name = f"{method} frame {chunk[0] + 1}" + (f"-{chunk[-1] + 1}" if len(chunk) > 1 else "")
        jobs.append(PovrayJob(name=name, script=script, width=batch.width, height=batch.height,
                              frames=len(chunk), include_dirs=tuple(str(d) for d in scene.include_dirs),
                              options=settings.options + batch.options, threads=threads, bit_depth=settings.bit_depth,
                              file_gamma="sRGB", timeout=settings.timeout,
                              read_files=files_within(scene.files, scene.include_dirs)))
    chunk_of_job = {id(job): chunk for job, chunk in zip(jobs, chunks)}

    done = stats.cached
    if progress:
        progress(done, len(keys))

    def collect(result: JobResult) -> None:
        # Jobs finish in any order; count the frames each one brings.
        nonlocal done
        for index, image_path in zip(chunk_of_job[id(result.job)], result.images):
            images[index] = read_png(image_path)
            if cache is not None:
                cache.put(keys[index], image_path)
            done += n_copies.get(index, 1)
        if progress:
            progress(done, len(keys))

    if jobs:
        stats.povray_seconds = runner.run(jobs, processes=processes, on_result=collect)
    for index, source in copies.items():
        if images[index] is None:
            images[index] = images[source]
    stats.wall_seconds = time.perf_counter() - start
    return [img for img in images if img is not None], stats
