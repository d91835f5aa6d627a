"""Turn a list of shots into images: cache lookups, POV-Ray jobs, reads.

A rendering method describes what it needs as a ``ShotBatch``: one template,
values common to every shot, and the per-shot values (a view's direction, a
lens's centre).  Each shot has its own content key, so an unchanged view comes
from the cache however the missing ones are batched into POV-Ray runs.
"""

from __future__ import annotations

import hashlib
import tempfile
import time
from collections import Counter
from dataclasses import replace
from collections.abc import Callable
from pathlib import Path

from typing import Any

import numpy as np

from ..._version import __version__
from ... import cache as cache_store
from ...cache import cache_root, code_stamp, content_key
from .cache import ImageCache
from ...image.io import read_image
from ...povray.job import SCENE_FILE
from ...povray.log import parse_photons, parse_radiosity, past_scene_end
from ...povray.job import ClockRun
from ...povray.process import JOB_PREFIX, JobResult, PovrayJob, povray_version, run_jobs
from ...povray.sandbox import confines, scene_inputs
from ...povray.version_memo import remembered_version
from ...errors import PovrayError, PovrayTimeout, raw_message, warn
from ...scene.scene import BOM, Scene, has_bom
from ...system import cpu_count, find_povray, owned_prefix
from .batch import ShotBatch, RenderStats
from .clock_runs import SEQUENCE_SAFE_WORDS, plan_runs
from .lighting import PHOTONS, SOLUTION, SharedLighting, loading_header, photon_header, shared_lighting
from .lighting import record as lighting_record
from ..methods.quality import Progress, RenderSettings
from ...scene.templates import render_template, templates_dir


class LocalRunner:
    """Runs jobs as POV-Ray processes on this machine (``povray.cluster.DaskRunner``: on a cluster)."""

    def __init__(self, binary: str) -> None:
        self.binary = binary
        # Remembered across runs: a `povray --version` costs about 0.2 s a render.
        self.version = remembered_version(binary, cache_root(), povray_version)

    def run(self, jobs: list[PovrayJob], *, processes: int, on_result: Callable[[JobResult], None],
            on_running: Callable[[dict[int, float]], None] | None = None,
            on_frame: Callable[[PovrayJob, int, Path], None] | None = None,
            should_stop: Callable[[], bool] | None = None) -> list[float]:
        return run_jobs(jobs, processes=processes, on_result=on_result, binary=self.binary,
                        on_running=on_running, on_frame=on_frame, should_stop=should_stop)


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
    """Hash of the template, the base it extends and the parts it includes: a template edit invalidates
    the cache."""
    h = hashlib.sha256()
    for n in (name, "scene.pov.j2", *(("lenslet.pov.j2",) if name == "single_stage.pov.j2" else ())):
        h.update((templates_dir() / n).read_bytes())
    return h.hexdigest()


def build_script(batch: ShotBatch, shots: list[dict[str, Any]], *, method: str, scene_path: str,
                 add_assumed_gamma: bool, header: dict[str, Any]) -> str:
    """The POV-Ray script that renders ``shots`` of ``batch`` as the frames 1..n of its own POV-Ray animation."""
    return render_template(batch.template, version=__version__, method=method, scene_path=scene_path,
                           add_assumed_gamma=add_assumed_gamma, shots=shots, **header, **batch.context)


def scene_include(scene: Scene, settings: RenderSettings) -> tuple[str, dict[str, Any]]:
    """The file povh3d's script includes for ``scene``, and the job's fields to read it.

    POV-Ray 3.7 skips a UTF-8 byte-order mark at the start of the file it is given, not in one it
    includes: a scene saved with one is included as a copy without it, of the same name (errors name
    the user's file), in the cache; its includes are still found in the scene's folder (``+L``)."""
    inputs = scene_inputs(scene)
    if not has_bom(scene.path):
        return str(scene.path), inputs
    folder = cache_store.cache_folder(cache_root(settings.cache_dir) / "bom" / scene.digest[:32], "scene copy")
    copy = folder / scene.path.name
    if not copy.is_file():
        from ...image.io import atomic_path
        with atomic_path(copy) as tmp:
            tmp.write_bytes(scene.path.read_bytes().removeprefix(BOM))
    if inputs.get("read_files") is not None:
        inputs = {**inputs, "read_files": (*inputs["read_files"], str(copy))}
    return str(copy), inputs


def _read_shot(image_path: Path, name: str) -> np.ndarray:
    """A shot POV-Ray wrote; an image cut short by a full disk is that disk's error, not the image's."""
    from ...errors import InputError
    from ...povray.process import full_disk

    try:
        return read_image(image_path)
    except InputError:
        raise full_disk(image_path.parent, 0, name) or InputError(
            f"{name}: POV-Ray wrote a damaged image {image_path.name!r}; render again") from None


def render_shots(scene: Scene, batch: ShotBatch, settings: RenderSettings, *,
                  method: str, header: dict[str, Any], progress: Progress | None = None,
                  ) -> tuple[list[np.ndarray], RenderStats]:
    """Render every shot of ``batch`` (or take it from the cache), in order.

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
    images : list of (height, width, C) uint8 or uint16 arrays, one per shot
    stats : RenderStats
    """
    start = time.perf_counter()
    runner = _runner(settings)
    stats = RenderStats(shots=len(batch.shots), povray_version=runner.version)
    cache = _usable_cache(scene, settings, stats)
    lighting = shared_lighting(scene, batch, settings, isinstance(runner, LocalRunner))
    keys = shot_keys(stats.povray_version, scene, batch, header, settings)
    if lighting is not None:
        keys = lighting.keyed(keys)
    images, missing = _looked_up(keys, cache, settings, stats)
    # Identical shots (same content key) in one batch are traced once.
    first_of: dict[str, int] = {}
    copies = {i: first_of.setdefault(keys[i], i) for i in missing}
    missing = [i for i in missing if copies[i] == i]
    taker = _Taker(images, keys, cache, settings, {}, Counter(copies.values()), stats.cached, progress, method)
    if progress:
        progress(taker.done, len(keys))
    if lighting is not None and any(i not in lighting.savers for i in missing):
        _run_lit(lighting, runner, taker, scene, batch, settings, stats, method, header, missing, progress)
    else:
        later = {} if lighting is not None else _later_frames(stats.povray_version, scene, batch, header, settings,
                                                              cache, keys, missing)
        jobs, targets = _planned_jobs(scene, batch, settings, stats, method, header, missing, later)
        taker.targets.update(targets)
        if jobs:
            try:
                _run(runner, jobs, taker, settings, progress, stats)
            except PovrayError as exc:
                if later and not isinstance(exc, PovrayTimeout):
                    # A frame of the sequence failed, maybe a later one: the rest of the request goes frame
                    # by frame (what finished is in the cache), so the error names the frame that fails.
                    settings.sequence.ledger.failed = True
                    return render_shots(scene, batch, replace(settings, sequence=None), method=method,
                                         header=header, progress=progress)
                raise _said(exc, scene) from None
    stats.radiosity_samples = sum(counts[0] for counts in taker.radiosity.values() if counts)
    for index, source in copies.items():
        if images[index] is None:
            images[index] = images[source]
    stats.wall_seconds = time.perf_counter() - start
    return [img for img in images if img is not None], stats


def _said(exc: PovrayError, scene: Scene) -> PovrayError:
    """``exc`` with a location past the end of the user's scene said as such (``past_scene_end``)."""
    if isinstance(exc, PovrayTimeout) or SCENE_FILE not in str(exc):
        return exc
    return PovrayError(past_scene_end(raw_message(exc), scene.path.name, SCENE_FILE), command=exc.command,
                       returncode=exc.returncode, log_tail=exc.log_tail)


def _run_lit(lighting: SharedLighting, runner: Any, taker: _Taker, scene: Scene, batch: ShotBatch,
             settings: RenderSettings, stats: RenderStats, method: str, header: dict[str, Any],
             missing: list[int], progress: Progress | None) -> None:
    """Render the missing shots on one lighting solution: the saving shots' run first (at every core),
    then the others' runs, which load it (``renderer.shots.lighting``)."""
    with tempfile.TemporaryDirectory(prefix=owned_prefix(JOB_PREFIX) + "lighting-") as name:
        folder = Path(name)
        user = scene
        try:
            if lighting.photons:   # the runs render a copy whose photons block saves or loads the map
                from ...scene.rewrite import copy_rewritten, photon_map_hook
                scene = copy_rewritten(scene, folder / "scene", photon_map_hook) or scene
            chain = replace(batch, shots_per_job=len(lighting.savers))  # one run: each frame adds to the file
            # POV-Ray shoots the same photons every time at one thread (at two, their order and count vary
            # from run to run): a photon map shot at one thread makes every view its independent render's.
            shooting = settings if lighting.radiosity or settings.threads else replace(settings, threads=1)
            saving, targets = _planned_jobs(scene, chain, shooting, stats, method,
                                            photon_header(header) if lighting.photons else header,
                                            list(lighting.savers), {}, extra=lighting.saving(folder))
            taker.targets.update(targets)
            _run(runner, saving, taker, settings, progress, stats)
            rest = [i for i in missing if i not in lighting.savers]
            saved = (taker.radiosity.get(id(saving[0]))
                     if lighting.radiosity and (folder / SOLUTION).is_file() else None)
            # No radiosity statistics (or no file): the scene's radiosity block is not in force (under an
            # #if), so there is nothing to share, and a later radiosity block would turn radiosity on.
            # No photon map: the scene's photons block is not in force, and loading a missing map fails.
            photons = lighting.photons and (folder / PHOTONS).is_file()
            loading_as = loading_header(header) if saved is not None else header
            loading, targets = _planned_jobs(scene, batch, settings, stats, method,
                                             photon_header(loading_as) if photons else loading_as, rest, {},
                                             extra=lighting.loading(folder, saved is not None, photons))
            taker.targets.update(targets)
            _run(runner, loading, taker, settings, progress, stats)
        except PovrayError as exc:
            raise _said(_of_user(exc, scene, user), user) from None
    stats.jobs += 1
    if saved is not None or photons:
        shot = ((taker.photons.get(id(saving[0])) or 0, sum(taker.photons.get(id(job)) or 0 for job in loading))
                if photons else None)
        stats.lighting = lighting_record(lighting, saved, [taker.radiosity.get(id(job)) for job in loading], len(rest),
                                         shot)


def _of_user(exc: PovrayError, copy: Scene, user: Scene) -> PovrayError:
    """``exc`` naming the user's files where POV-Ray named those of the copy it rendered."""
    if copy is user or isinstance(exc, PovrayTimeout):
        return exc
    mine, theirs = str(copy.path.parent), str(user.path.parent)
    return PovrayError(raw_message(exc).replace(mine, theirs), command=exc.command, returncode=exc.returncode,
                       log_tail=exc.log_tail.replace(mine, theirs))


def _runner(settings: RenderSettings) -> Any:
    """This machine's POV-Ray, or the Dask cluster ``settings.scheduler`` names."""
    if settings.scheduler:
        from ...povray.cluster import DaskRunner
        return DaskRunner(settings.scheduler)
    return LocalRunner(find_povray())


def _usable_cache(scene: Scene, settings: RenderSettings, stats: RenderStats) -> ImageCache | None:
    """The image cache, unless the settings turn it off or no key can cover what the scene reads."""
    cache = ImageCache(cache_root(settings.cache_dir)) if settings.use_cache else None
    if cache is not None and scene.computed_names and not confines():
        # Unconfined, POV-Ray may read files whose names povh3d cannot know: no key covers them.
        warn(f"{scene.path.name} reads a file whose name is computed while POV-Ray parses, and POV-Ray "
             "runs unconfined here (POVH3D_SANDBOX=off or no Landlock), so povh3d cannot know every file "
             "it reads: not using the image cache for it")
        cache = None
    if cache is not None and not scene.reproducible:
        # Two parses differ (the time, the file system): a cached image would be stale.
        stats.uncached = f"the scene uses {', '.join(scene.volatile)}, so its image is not reproducible"
        warn(f"{scene.path.name}: {stats.uncached}: not using the image cache for it")
        cache = None
    return cache


def _looked_up(keys: list[str], cache: ImageCache | None, settings: RenderSettings,
               stats: RenderStats) -> tuple[list[np.ndarray | None], list[int]]:
    """The shots found (in the cache, or held by an earlier frame's clock sequence) and the indices missing."""
    images: list[np.ndarray | None] = [None] * len(keys)
    missing: list[int] = []
    held = settings.sequence.stored if settings.sequence is not None else {}
    for index, key in enumerate(keys):
        hit = cache.load(key) if cache else None
        if hit is None and held.get(key) is not None:  # rendered by an earlier frame's sequence, no cache
            hit, held[key] = held[key], None  # taken: memory for one frame at a time
        if hit is not None:
            images[index] = hit
        else:
            missing.append(index)
    stats.cached = len(keys) - len(missing)
    if settings.sequence is not None:  # shots an earlier frame's clock sequence rendered in this request
        stats.cached -= sum(key in settings.sequence.stored for key in keys)
    return images, missing


#: Where a POV-Ray run's frame goes: (shot of this frame, None), or (None, key of a later animation
#: frame's shot, for the cache only).
Target = tuple[int | None, str | None]


def _planned_jobs(scene: Scene, batch: ShotBatch, settings: RenderSettings, stats: RenderStats, method: str,
                  header: dict[str, Any], missing: list[int], later: dict[int, dict[int, str]],
                  extra: dict[str, Any] | None = None) -> tuple[list[PovrayJob], dict[int, list[Target]]]:
    """The POV-Ray runs of the missing shots (and of the later frames' shots of a clock sequence),
    each with the targets of its frames; ``stats`` gets the jobs, processes and threads.  ``extra``:
    job fields added to each run's (a shared lighting solution's options, links, files)."""
    # Frames reach the cache one by one as POV-Ray writes them (``_Taker.take``), so the method's
    # batching into runs costs nothing when a run is stopped (Ctrl-C, timeout, crash).
    per_job = batch.shots_per_job
    if scene.animation_words - SEQUENCE_SAFE_WORDS:
        # A run of several shots is a POV-Ray animation, whose frame_number (clock_delta, ...) would
        # differ from shot to shot: a scene reading them gets each shot in a still's run of its own.
        per_job = 1
    chunks = [missing[i:i + per_job] for i in range(0, len(missing), per_job)]
    cores = cpu_count()
    runs = plan_runs(_lanes(settings.sequence, missing, later), cores) if later else []
    units = len(runs) if later else len(chunks)
    # A clock sequence's runs are independent: one per core (the method's own preference is per frame).
    processes = max(1, min(units or 1, settings.jobs or (cores if later else batch.processes) or cores))
    threads = settings.threads or max(1, cores // processes)
    stats.jobs, stats.processes, stats.threads = units, processes, threads

    scene_file, inputs = scene_include(scene, settings)
    common = dict(width=batch.width, height=batch.height, threads=threads, bit_depth=settings.bit_depth,
                  file_gamma="sRGB", timeout=settings.timeout, **inputs)
    extra = dict(extra or {})
    added = extra.pop("options", ())
    for field, value in extra.items():
        common[field] = tuple(common.get(field) or ()) + tuple(value)
    script_of = lambda shots: build_script(batch, shots, method=method, scene_path=scene_file,  # noqa: E731
                                           add_assumed_gamma=scene.adds_assumed_gamma, header=header)
    jobs: list[PovrayJob] = []
    targets: dict[int, list[Target]] = {}
    if later:
        # Shot j of consecutive animation frames: one POV-Ray run of the request's clock sequence.
        sequence = settings.sequence
        plain = replace(settings, clock=None, sequence=None).options + batch.options
        for shot, numbers in runs:
            name = f"{method} camera {shot + 1}, frames {numbers[0]}" + (f"-{numbers[-1]}" if len(numbers) > 1 else "")
            run = ClockRun(sequence.position(numbers[0]), sequence.total, sequence.clock_start, sequence.clock_end)
            # --timeout is each frame's: a run of several frames gets theirs together.
            timeout = None if settings.timeout is None else settings.timeout * len(numbers)
            job = PovrayJob(name=name, script=script_of([batch.shots[shot]] * sequence.total), frames=len(numbers),
                            options=plain, clock_run=run, **{**common, "timeout": timeout})
            jobs.append(job)
            targets[id(job)] = [(shot, None) if n == sequence.frame else (None, later[n][shot]) for n in numbers]
    else:
        for chunk in chunks:
            name = f"{method} camera {chunk[0] + 1}" + (f"-{chunk[-1] + 1}" if len(chunk) > 1 else "")
            job = PovrayJob(name=name, script=script_of([batch.shots[i] for i in chunk]), frames=len(chunk),
                            options=settings.options + batch.options + tuple(added), **common)
            jobs.append(job)
            targets[id(job)] = [(i, None) for i in chunk]
    return jobs, targets


class _Taker:
    """Takes each frame POV-Ray writes to its place (the shot's image, the cache, a later frame's
    hold) as soon as it is written, and counts what is done for the progress."""

    def __init__(self, images: list[np.ndarray | None], keys: list[str], cache: ImageCache | None,
                 settings: RenderSettings, targets: dict[int, list[Target]], copies: Counter[int], done: int,
                 progress: Progress | None, method: str) -> None:
        self.images, self.keys, self.cache, self.settings = images, keys, cache, settings
        self.targets, self.copies, self.done, self.progress, self.method = targets, copies, done, progress, method
        self.taken: set[tuple[int, int]] = set()
        self.radiosity: dict[int, tuple[int, float] | None] = {}  # job id -> POV-Ray's radiosity statistics
        self.photons: dict[int, int | None] = {}  # job id -> the photons POV-Ray shot

    def take(self, target: Target, image_path: Path) -> None:
        index, key = target
        if index is None:
            assert key is not None  # (None, key): Target
            stored = self.settings.sequence.stored
            if key not in stored:
                if self.cache is not None:
                    self.cache.store(key, image_path)
                # In the cache the later frame finds it; without one it is held here for it.
                stored[key] = None if self.cache is not None else _read_shot(image_path, self.method)
            self.done += 1
            return
        counted = self.images[index] is not None  # from the cache, rendered again to save a lighting solution
        self.images[index] = _read_shot(image_path, f"{self.method} camera {index + 1}")  # decoded whole
        if self.cache is not None:
            self.cache.store(self.keys[index], image_path)
        self.done += 0 if counted else self.copies.get(index, 1)

    def frame_done(self, job: PovrayJob, frame: int, image_path: Path) -> None:
        """A frame of a running job, as soon as POV-Ray has written it."""
        self.taken.add((id(job), frame))
        self.take(self.targets[id(job)][frame], image_path)
        self._report()

    def collect(self, result: JobResult) -> None:
        """A finished job (jobs finish in any order): the frames not taken while it ran."""
        self.radiosity[id(result.job)] = parse_radiosity(result.log)
        self.photons[id(result.job)] = parse_photons(result.log)
        for frame, (target, image_path) in enumerate(zip(self.targets[id(result.job)], result.images)):
            if (id(result.job), frame) not in self.taken:
                self.take(target, image_path)
        self._report()

    def running(self, rendered: dict[int, float]) -> None:
        """Frames of the running jobs as POV-Ray reports them (share of pixels)."""
        if self.progress:
            self.progress(self.done + sum(rendered.values()), len(self.keys))

    def _report(self) -> None:
        if self.progress:
            self.progress(self.done, len(self.keys))


def _run(runner: Any, jobs: list[PovrayJob], taker: _Taker, settings: RenderSettings, progress: Progress | None,
         stats: RenderStats) -> None:
    """Run the jobs on ``runner``, every frame to ``taker``; ``stats`` gets POV-Ray's seconds."""
    extra: dict[str, Any] = ({"on_frame": taker.frame_done, "should_stop": settings.should_stop}
                             if isinstance(runner, LocalRunner) else {})
    if progress and isinstance(runner, LocalRunner):
        extra["on_running"] = taker.running
    stats.povray_seconds = stats.povray_seconds + runner.run(jobs, processes=stats.processes,
                                                             on_result=taker.collect, **extra)


#: Raised when what a shot's image depends on changes without a change the key sees: 2, a still's
#: runs of several shots keep POV-Ray's clock at 0 (povray.job), where shots before saw it run 0..1.
KEY_REVISION = 2


def shot_keys(version: str, scene: Scene, batch: ShotBatch, header: dict[str, Any],
              settings: RenderSettings) -> list[str]:
    """The cache key of every shot of ``batch``: what the image depends on, nothing else."""
    common_key = content_key(__version__, code_stamp(), KEY_REVISION, version, scene.digest, batch.template,
                             _template_digest(batch.template), _canonical(batch.context),
                             _canonical(header), batch.width, batch.height, settings.options,
                             settings.bit_depth, scene.adds_assumed_gamma, batch.options)
    return [content_key(common_key, _canonical(frame)) for frame in batch.shots]


def _later_frames(version: str, scene: Scene, batch: ShotBatch, header: dict[str, Any], settings: RenderSettings,
                  cache: ImageCache | None, keys: list[str], missing: list[int]) -> dict[int, dict[int, str]]:
    """The later animation frames of ``settings.sequence`` to render with this one: frame -> {shot: key}
    of the shots it misses; empty when the batch, the scene or the cache rules sequences out
    (``renderer.shots.clock_runs``).  The keys are this frame's with the other frame's clock, so a later
    frame whose batch turns out different finds nothing and renders its own."""
    sequence = settings.sequence
    if (sequence is None or sequence.ledger.failed or not sequence.later or settings.clock is None
            or (batch.shots_per_job > 1 and len(batch.shots) > 1)
            or not scene.animation_words <= SEQUENCE_SAFE_WORDS):
        return {}
    if sequence.stored and not any(key in sequence.stored for key in keys):
        # An earlier frame's sequence planned other shots than this frame asks for: the batch changes
        # with the clock (a scene camera that moves), so planning ahead only wastes runs.
        sequence.ledger.failed = True
        return {}
    seen = set(keys)
    out: dict[int, dict[int, str]] = {}
    for n in sequence.later:
        clocked = replace(settings, clock=sequence.clock(n), sequence=None)
        frame_keys = shot_keys(version, scene, batch, header, clocked)
        out[n] = {}
        for shot, key in enumerate(frame_keys):
            # (a damaged cache entry is rendered again by its own frame)
            if key not in seen and key not in sequence.stored and not (cache and cache.path(key).is_file()):
                out[n][shot] = key
            seen.add(key)
    return out if any(out.values()) else {}


def _lanes(sequence: Any, missing: list[int], later: dict[int, dict[int, str]]) -> dict[int, list[int]]:
    """Shot -> the animation frames (ascending, this one first) that miss it."""
    lanes: dict[int, list[int]] = {shot: [sequence.frame] for shot in missing}
    for n, shots in later.items():
        for shot in shots:
            lanes.setdefault(shot, []).append(n)
    return lanes
