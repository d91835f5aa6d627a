"""The scene's camera evaluated by POV-Ray: the runs that turn a scene's last camera into numbers.

``evaluate_camera`` runs the scene's camera statements alone (one row of the smallest image
that tells them exactly, ``camera_size``: ``image_width / image_height`` in a scene means the
panel's physical shape in mm, ``physical_size``, not the pixel grid of a lenticular or mapped
view space, whose pixels are not square: 16 x 9 pixels for a 16:9 panel);
``evaluate_and_measure``, where a depth pass is wanted (``renderer.placement.place``), runs them
with the rest of the scene and
``templates/camera_depth.pov.j2``, which works out the pose from the
declared values and renders the fog depth pass through it in the same run.
Both are cached in the one cache (``povh3d.cache``: ``cameras/ab/<key>.camera``),
keyed by the scene's digest and the panel, so a re-run starts no POV-Ray.  The
pose these numbers define is worked out in ``geometry/pose.py``; which
pose a render uses is decided in ``renderer/placement/pose.py``.
"""

from __future__ import annotations

import io
import math
import re
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import cache
from ..._version import __version__
from ...cache import content_key
from ...geometry.pose import EXPLICIT_OPTIONS, DisplayPose
from ...geometry.lens_array import LensArray
from ...scene.camera import CameraError, CameraScript, camera_from_log, parse_log
from ...scene.features import strip_comments
from ...scene.scene import Scene, source_text
from .record import note
from ...errors import param, raw_message

if TYPE_CHECKING:  # only for annotations: keeps the import chain short
    from ..methods.quality import Progress
    from .depth import DepthMap

_AGAIN = "evaluating the scene's camera again"


def _load(path: Any, key: str, use_cache: bool, parse: Any) -> Any:
    """``parse(json, bytes)`` of the camera entry ``key``; None on a miss (a damaged entry, or one ``parse``
    refuses: warned, removed)."""
    if not use_cache:
        return None
    try:
        return cache.load(path, key, lambda body: parse(*cache.split_json(body)), again=_AGAIN)
    except OSError:
        return None


def _camera(meta: dict[str, Any], data: bytes) -> dict[str, Any]:
    if not {"type", "location"} <= meta.keys():
        raise ValueError("no camera")
    return meta


def _camera_and_pass(meta: dict[str, Any], data: bytes) -> tuple[dict[str, Any], Seen]:
    distances = np.load(io.BytesIO(data), allow_pickle=False)
    return _camera(meta["camera"], b""), Seen(distances, float(meta["unmeasured"]),
                                               tuple(float(v) for v in meta["printed"]))


def _keep(path: Any, key: str, meta: dict[str, Any], data: bytes = b"") -> None:
    """Store a camera entry; a cache that cannot be written only costs the next run a POV-Ray start."""
    from ...errors import OutputError

    try:
        cache.store(path, key, cache.json_and_bytes(meta, data))
    except (OSError, OutputError):
        pass


def probe_size(lens_array: LensArray, rows: int = 48) -> tuple[int, int]:
    """``physical_size``'s aspect at about ``rows`` rows: a run that tells the camera's type quickly."""
    w, h = physical_size(lens_array)
    k = max(1, h // rows)
    return max(1, round(w / k)), max(1, round(h / k))


def physical_size(lens_array: LensArray) -> tuple[int, int]:
    """``(width, height)`` pixels with the physical panel's aspect (its size in mm), about as many rows
    as the panel: the size the scene's camera is evaluated at.  A lenticular panel's 5760 x 1080
    subpixel columns are 930 x 523 mm, 16:9, not 5.33:1."""
    from fractions import Fraction

    width_mm, height_mm = lens_array.panel.size_mm
    rows = lens_array.panel.height
    ratio = Fraction(width_mm / height_mm).limit_denominator(max(rows, 1))
    k = max(1, rows // ratio.denominator)
    return ratio.numerator * k, ratio.denominator * k


def evaluate_camera(scene: Scene, script: str, lens_array: LensArray, cameras: int, cache_dir: Any,
                    use_cache: bool, lines: tuple[tuple[int, str, int], ...] = (), timeout: float | None = None,
                    size: tuple[int, int] | None = None) -> tuple[dict[str, Any], float, bool]:
    """The camera's vectors from one POV-Ray run of ``script``, cached by the scene's digest; ``timeout``:
    the render's own limit on each POV-Ray run (a parse may take minutes: the user decides, not us);
    ``size``: the run's pixels (default ``camera_size``).

    The run has the physical panel's aspect (``physical_size``) where the scene names the sizes, so
    ``image_width / image_height`` in the camera is the panel's shape; it traces one row, at +Q0.
    """
    from ...povray.process import PovrayJob
    from ...povray.sandbox import scene_inputs

    start = time.perf_counter()
    w, h = size or camera_size(scene, lens_array)
    key = content_key("scene-camera-3", __version__, cache.code_stamp(), scene.digest, w, h)
    path = cache.entry_path(cache.cache_root(cache_dir), "cameras", key, ".camera")
    stored = _load(path, key, use_cache, _camera)
    if stored is not None:
        note("scene-camera", time.perf_counter() - start, 0, 0, True)
        return stored, time.perf_counter() - start, True
    # +Q0: the parse is what tells the camera; photons and a radiosity pretrace would only cost time.
    job = PovrayJob(name="scene camera", script=script, width=w, height=h, start_row=0, end_row=1,
                    options=("-A", "+Q0"), threads=1, timeout=timeout, **scene_inputs(scene))
    logs: list[str] = []
    _run([job], lambda result: logs.append(result.log), lines, scene)
    camera = camera_from_log(logs[0] if logs else "", cameras).as_record()
    if use_cache:
        _keep(path, key, camera)
    note("scene-camera", time.perf_counter() - start, 1, 1)
    return camera, time.perf_counter() - start, False


def camera_size(scene: Scene, lens_array: LensArray) -> tuple[int, int]:
    """The smallest run that evaluates the camera exactly: the panel's physical aspect (``physical_size``)
    in lowest terms, which is what ``image_width / image_height`` reads (also in a library include such
    as screen.inc, whose text ``scene.files`` does not hold); a scene that builds from the sizes themselves
    gets ``physical_size`` (its values then follow the panel's)."""
    from fractions import Fraction

    if uses_image_size(scene):
        return physical_size(lens_array)
    w, h = physical_size(lens_array)
    ratio = Fraction(w, h)
    return ratio.numerator, ratio.denominator


def _run(jobs: Any, on_result: Any, lines: tuple[tuple[int, str, int], ...], scene: Scene) -> None:
    """Run the camera's jobs side by side; an error at a line of the rewritten script names the user's file and line."""
    from ...errors import PovrayError, PovrayTimeout
    from ...povray.job import SCENE_FILE
    from ...povray.process import run_jobs
    from ...scene.camera_script import source_line

    try:
        run_jobs(jobs, processes=len(jobs), on_result=on_result)
    except PovrayError as exc:
        if isinstance(exc, PovrayTimeout) or SCENE_FILE not in str(exc):
            raise
        message = re.sub(rf"{re.escape(SCENE_FILE)} line (\d+)",
                         lambda m: source_line(lines, int(m[1]), scene.path.name), raw_message(exc), count=1)
        raise PovrayError(message, command=exc.command, returncode=exc.returncode,
                          log_tail=exc.log_tail) from None


def measured_size(scene: Scene, width: int, height: int, target: int) -> tuple[int, int] | None:
    """The image size of the run that evaluates the camera and measures depth through it, or None
    when the camera must be evaluated at the panel's own size in a run of its own.

    The camera is evaluated in the run's ``image_width x image_height``: a scene that uses
    them only as ``image_width / image_height`` gets the panel's exact aspect at the size of
    the depth pass (``target`` pixels wide or less: the panel's size divided by a common divisor);
    one that never names them, ``target`` wide;
    one that uses them otherwise (``#declare IW = image_width``), the panel's size, so
    the depth is measured by a pass of its own.
    """
    text = _scene_text(scene)
    named = re.search(r"\bimage_(width|height)\b", text)
    if uses_image_size(scene, text):
        return None
    if not named:
        w = min(target, width)
        return w, max(1, round(w * height / width))
    common = math.gcd(width, height)
    for m in range(1, common + 1):
        if common % m == 0 and width // m <= target:
            return width // m, height // m
    return (width, height) if width <= 2 * target else None


def _scene_text(scene: Scene) -> str:
    return "\n".join(source_text(p.read_bytes()) for p in scene.files if p.is_file())


def uses_image_size(scene: Scene, text: str | None = None) -> bool:
    """Whether the scene names ``image_width`` or ``image_height`` other than as their ratio
    (``#declare N = image_width * image_height``): what it builds from them then depends on the
    size of each POV-Ray run, which for the views is not the panel's."""
    code = strip_comments(_scene_text(scene) if text is None else text)   # a comment names them freely
    return re.search(r"\bimage_(width|height)\b", _RATIO.sub("", code)) is not None


_RATIO = re.compile(r"\bimage_width\s*/\s*image_height\b|\bimage_height\s*/\s*image_width\b")


def evaluate_and_measure(scene: Scene, script: CameraScript, lens_array: LensArray, front_clearance: float,
                         cache_dir: Any, use_cache: bool, timeout: float | None = None,
                         progress: Progress | None = None) -> tuple[dict[str, Any], Seen, float, bool] | None:
    """The camera's vectors and a depth pass along the normal of the pose it defines, from two
    POV-Ray runs side by side (the two fog frames): the evaluation script, the rest of the scene and ``templates/camera_depth.pov.j2``,
    which works out the pose and the clearance from the declared values, prints them and renders
    the two fog frames (``renderer.passes.depth``).  Cached by the scene's digest, the panel and ``front_clearance``.
    None when the camera needs a run at the panel's own size (``measured_size``).  ``progress(done, total)``:
    the two frames (the run takes about a second, most of it POV-Ray's start-up)."""
    from .depth import PASS_THREADS, fog_distances, pass_lighting, pass_size
    from ...image.io import read_image
    from ...povray.job import ClockRun, JobResult
    from ...povray.process import PovrayJob
    from ...povray.sandbox import files_within
    from ...scene.templates import render_template

    start = time.perf_counter()
    w, h = physical_size(lens_array)
    right, up = (lens_array.lenses_x * lens_array.pitch_x, 0.0, 0.0), (0.0, lens_array.lenses_y * lens_array.pitch_y, 0.0)
    target = pass_size(lens_array)[0]
    key = content_key("scene-camera-depth-2", __version__, cache.code_stamp(), scene.digest, w, h, target, right, up, front_clearance,
                      lens_array.panel.size_mm[0])
    path = cache.entry_path(cache.cache_root(cache_dir), "cameras", key, ".camera")
    stored = _load(path, key, use_cache, _camera_and_pass)
    if stored is not None:
        note("scene-camera-depth", time.perf_counter() - start, 0, 0, True)
        return *stored, time.perf_counter() - start, True
    size = measured_size(scene, w, h, target)
    if size is None:
        return None
    text = script.script + script.rest + render_template(
        "camera_depth.pov.j2", panel_width=lens_array.panel.size_mm[0], front_clearance=front_clearance, right=right, up=up,
        add_assumed_gamma=not scene.sets_assumed_gamma, lighting=pass_lighting(scene))
    # The two fog frames (frame_number 1 and 2 of the template) as two runs side by side, one thread
    # each: the pass then waits for one POV-Ray start-up and no frame change (about 0.25 s, POV-Ray idling).
    jobs = [PovrayJob(name="scene camera and depth", script=text, width=size[0], height=size[1],
                      clock_run=ClockRun(frame, 2, 0.0, 0.0), threads=PASS_THREADS,
                      include_dirs=tuple(str(d) for d in scene.include_dirs), options=("-A",), bit_depth=16,
                      read_files=files_within(scene.files, scene.include_dirs), timeout=timeout)
            for frame in (1, 2)]
    found: dict[int, tuple[str, np.ndarray]] = {}

    def take(result: JobResult) -> None:
        assert result.job.clock_run is not None
        found[result.job.clock_run.first] = (result.log, read_image(result.images[0]))
        if progress:
            progress(len(found), 2)

    if progress:
        progress(0, 2)
    _run(jobs, take, script.lines, scene)
    log = found[1][0] if 1 in found else ""
    images = [found[frame][1] for frame in (1, 2) if frame in found]
    camera = camera_from_log(log, script.cameras).as_record()
    printed = next((tuple(v) for k, v in parse_log(log) if k == "depth_frame" and isinstance(v, list)), ())
    if len(printed) != 14 or len(images) != 2:
        raise CameraError(f"cannot use the scene's camera (POV-Ray did not finish the depth pass through its "
                          f"pose); place the display with {EXPLICIT_OPTIONS}, or {param('placement.mode')} native")
    distances, unmeasured = fog_distances(images[:1], images[1:], printed[12] * printed[13])
    seen = Seen(distances[0].astype(np.float32), float(unmeasured[0]), printed)
    if use_cache:
        buffer = io.BytesIO()
        np.save(buffer, seen.distances)
        _keep(path, key, {"camera": camera, "unmeasured": seen.unmeasured, "printed": list(printed)},
              buffer.getvalue())
    note("scene-camera-depth", time.perf_counter() - start, 2, 2)
    return camera, seen, time.perf_counter() - start, False


@dataclass(frozen=True)
class Seen:
    """A depth pass made in the camera's own run: ray lengths (scene units, NaN: none), the share the
    fog did not reach, and the pose and clearance it was made in, as POV-Ray worked them out:
    centre, x, y, normal (3 each), units per mm, front clearance (mm)."""

    distances: np.ndarray
    unmeasured: float
    printed: tuple[float, ...]

    def depth(self, pose: DisplayPose, front_clearance: float, lens_array: LensArray) -> DepthMap | None:
        """The depth map, if the pass was made in ``pose`` with ``front_clearance``; else None (measure again)."""
        from .depth import depth_map

        expected = [*pose.centre, *pose.axis_x, *pose.axis_y, *pose.axis_z, pose.units_per_mm, front_clearance]
        size = max(1.0, *(abs(v) for v in pose.centre))
        if not (np.allclose(self.printed[:3], expected[:3], rtol=0, atol=1e-9 * size)
                and np.allclose(self.printed[3:12], expected[3:12], rtol=0, atol=1e-9)
                and np.allclose(self.printed[12:], expected[12:], rtol=1e-9, atol=0)):
            return None
        return depth_map(self.distances, lens_array, front_clearance, pose.units_per_mm, self.unmeasured)
