"""Turn a list of camera frames into images: cache lookups, POV-Ray jobs, reads.

A rendering method describes what it needs as a ``ShotBatch``: one template,
values common to every frame, and the per-frame values (a view's direction, a
lens's centre).  Each frame has its own content key, so an unchanged view comes
from the cache however the missing ones are batched into POV-Ray runs.
"""

from __future__ import annotations

import hashlib
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

from typing import Any

import numpy as np

from .._version import __version__
from ..cache import cache_root, content_key
from .cache import ImageCache
from ..image.io import read_png
from ..povray.job import SCENE_FILE
from ..povray.log import past_scene_end
from ..povray.process import JobResult, PovrayJob, povray_version, run_jobs
from ..povray.sandbox import confines, describe, scene_inputs
from ..povray.version_memo import remembered_version
from ..errors import PovrayError, PovrayTimeout, warn
from ..scene.scene import Scene
from ..system import cpu_count, find_povray
from .batch import ShotBatch, RenderStats
from .quality import Progress, RenderSettings
from ..povray.templates import render_template, templates_dir


def sandbox_in_use() -> str:
    """How this process's POV-Ray runs are confined (the sidecar's ``sandbox``): app/ asks the engine,
    which alone talks to ``povray/``."""
    return describe()


class LocalRunner:
    """Runs jobs as POV-Ray processes on this machine (``dask_backend.DaskRunner``: on a cluster)."""

    def __init__(self, binary: str) -> None:
        self.binary = binary
        # Remembered across runs: a `povray --version` costs about 0.2 s a render.
        self.version = remembered_version(binary, cache_root(), povray_version)

    def run(self, jobs: list[PovrayJob], *, processes: int, on_result: Callable[[JobResult], None],
            on_running: Callable[[dict[int, float]], None] | None = None,
            on_frame: Callable[[PovrayJob, int, Path], None] | None = None) -> list[float]:
        return run_jobs(jobs, processes=processes, on_result=on_result, binary=self.binary,
                        on_running=on_running, on_frame=on_frame)


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


def build_script(batch: ShotBatch, frames: list[dict[str, Any]], *, method: str, scene_path: str,
                 add_assumed_gamma: bool, header: dict[str, Any]) -> str:
    """The POV-Ray script that renders ``frames`` of ``batch`` as animation frames 1..n."""
    return render_template(batch.template, version=__version__, method=method, scene_path=scene_path,
                           add_assumed_gamma=add_assumed_gamma, frames=frames, **header, **batch.context)


def render_frames(scene: Scene, batch: ShotBatch, settings: RenderSettings, *,
                  method: str, header: dict[str, Any], progress: Progress | None = None,
                  ) -> tuple[list[np.ndarray], RenderStats]:
    """Render every frame of ``batch`` (or take it from the cache), in order.

    Parameters
    ----------
    scene : Scene
    batch : ShotBatch
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
        from ..povray.cluster import DaskRunner
        runner: Any = DaskRunner(settings.scheduler)
    else:
        runner = LocalRunner(find_povray())
    stats = RenderStats(frames=len(batch.shots), povray_version=runner.version)
    cache = ImageCache(cache_root(settings.cache_dir)) if settings.use_cache else None
    if cache is not None and scene.computed_names and not confines():
        # Unconfined, POV-Ray may read files whose names povh3d cannot know: no key covers them.
        warn(f"{scene.path.name} reads a file whose name is computed while POV-Ray parses, and POV-Ray "
             "runs unconfined here (POVH3D_SANDBOX=off or no Landlock), so povh3d cannot know every file "
             "it reads: not using the image cache for it")
        cache = None
    if cache is not None and not scene.reproducible:
        # Two parses differ (the time, the file system): a cached image would be stale.
        stats.uncached = f"the scene reads {', '.join(scene.volatile)}, so its image is not reproducible"
        warn(f"{scene.path.name}: {stats.uncached}: not using the image cache for it")
        cache = None

    common_key = content_key(__version__, stats.povray_version, scene.digest, batch.template,
                             _template_digest(batch.template), _canonical(batch.context),
                             _canonical(header), batch.width, batch.height, settings.options,
                             settings.bit_depth, scene.sets_assumed_gamma, batch.options)
    keys = [content_key(common_key, _canonical(frame)) for frame in batch.shots]
    images: list[np.ndarray | None] = [None] * len(keys)
    missing: list[int] = []
    for index, key in enumerate(keys):
        hit = cache.load(key) if cache else None
        if hit is not None:
            images[index] = hit
        else:
            missing.append(index)
    stats.cached = len(keys) - len(missing)
    # Identical frames (same content key) in one batch are traced once.
    first_of: dict[str, int] = {}
    copies = {i: first_of.setdefault(keys[i], i) for i in missing}
    missing = [i for i in missing if copies[i] == i]
    n_copies = Counter(copies.values())

    # Frames reach the cache one by one as POV-Ray writes them (``take``), so the method's
    # batching into runs costs nothing when a run is stopped (Ctrl-C, timeout, crash).
    per_job = batch.shots_per_job
    chunks = [missing[i:i + per_job] for i in range(0, len(missing), per_job)]
    cores = cpu_count()
    processes = max(1, min(len(chunks) or 1, settings.jobs or batch.processes or cores))
    threads = settings.threads or max(1, cores // processes)
    stats.jobs, stats.processes, stats.threads = len(chunks), processes, threads

    jobs = []
    for chunk in chunks:
        script = build_script(batch, [batch.shots[i] for i in chunk], method=method,
                              scene_path=str(scene.path), add_assumed_gamma=not scene.sets_assumed_gamma,
                              header=header)
        name = f"{method} camera {chunk[0] + 1}" + (f"-{chunk[-1] + 1}" if len(chunk) > 1 else "")
        jobs.append(PovrayJob(name=name, script=script, width=batch.width, height=batch.height,
                              frames=len(chunk), options=settings.options + batch.options, threads=threads,
                              bit_depth=settings.bit_depth, file_gamma="sRGB", timeout=settings.timeout,
                              **scene_inputs(scene)))
    chunk_of_job = {id(job): chunk for job, chunk in zip(jobs, chunks)}

    done = stats.cached
    if progress:
        progress(done, len(keys))

    def take(index: int, image_path: Path) -> None:
        nonlocal done
        images[index] = read_png(image_path)  # decoded whole: a complete PNG
        if cache is not None:
            cache.store(keys[index], image_path)
        done += n_copies.get(index, 1)

    def frame_done(job: PovrayJob, frame: int, image_path: Path) -> None:
        # A frame of a running job, as soon as POV-Ray has written it.
        take(chunk_of_job[id(job)][frame], image_path)
        if progress:
            progress(done, len(keys))

    def collect(result: JobResult) -> None:
        # Jobs finish in any order; take the frames not taken while the job ran.
        for index, image_path in zip(chunk_of_job[id(result.job)], result.images):
            if images[index] is None:
                take(index, image_path)
        if progress:
            progress(done, len(keys))

    def running(rendered: dict[int, float]) -> None:
        # Frames of the running jobs as POV-Ray reports them (share of pixels).
        progress(done + sum(rendered.values()), len(keys))

    if jobs:
        extra: dict[str, Any] = {"on_frame": frame_done} if isinstance(runner, LocalRunner) else {}
        if progress and isinstance(runner, LocalRunner):
            extra["on_running"] = running
        try:
            stats.povray_seconds = runner.run(jobs, processes=processes, on_result=collect, **extra)
        except PovrayError as exc:
            if isinstance(exc, PovrayTimeout) or SCENE_FILE not in str(exc):
                raise
            raise PovrayError(past_scene_end(str(exc), scene.path.name, SCENE_FILE), command=exc.command,
                              returncode=exc.returncode, log_tail=exc.log_tail) from None
    for index, source in copies.items():
        if images[index] is None:
            images[index] = images[source]
    stats.wall_seconds = time.perf_counter() - start
    return [img for img in images if img is not None], stats
