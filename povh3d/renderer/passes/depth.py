"""The scene's depth along the display normal, measured by POV-Ray: a low-resolution depth pass.

An orthographic camera looks along the display normal from ``front_clearance`` mm in
front of the screen, over the lens array's field.  It renders the scene twice
with a constant ``fog`` (``fog_type 1``) of colour 0 and of colour 1: POV-Ray
blends a pixel of surface colour ``c`` as ``c t + fog (1 - t)`` with
``t = exp(-d / D)`` for a ray of length ``d`` (scene units) and fog distance
``D``, so the difference of the two renders is ``1 - t``, independent of ``c``,
and ``d = -D ln t``.  In linear light at 16 bits the depth resolution is about
``D / 65535 / t``.  Each colour channel gives ``t`` on its own: a channel that clips
in the fog-1 render (the surface brighter than 1 there, e.g. the red of an emissive red
object) is left out, so only a surface brighter than 1 in every channel goes unmeasured
(``saturated``).  Pixels where nothing is hit (``t`` about 0) are left out too.

POV-Ray applies no fog (nor any media) along a ray segment inside a non-hollow object,
whatever the fog or media: a pass whose rays start inside a solid (a plane whose inside
holds the viewer, a room box or a sky sphere around the camera) sees ``t = 1`` exactly at
every surface.  No POV-Ray 3.7 construct measures depth there without the user's object
being ``hollow``; those pixels are counted (``unmeasured``) and a pass whose middle is
all unmeasured is reported as blind, with the cause and the fix, never as an empty scene.
The per-view depth maps (``--depth-maps``, ``--dataset``, ``povh3d dataset``) are made again then
on a copy of the scene whose top-level objects are all ``hollow`` (``scene.rewrite.all_hollow``),
which measures them exactly; what is still unmeasured is a warning.

The pass needs POV-Ray's quality 9 (no fog below it), which turns the scene's radiosity, photons and
subsurface scattering on as well; the pass turns them down (``LIGHTING_OFF``): they cost time, and
radiosity's sample rays cross the fog, which leaves ``c`` different in the two renders.  The pass runs
at one thread (``PASS_THREADS``): what POV-Ray samples at random per thread (a jittered area light)
is then the same in both renders.

The pass is cached like any frame (the scene's digest, the frame, the size).
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ...jsontext import JSONValue
from ...errors import Povh3dError, param, warn
from ...geometry.camera_mesh import tiled_views_mesh
from ...geometry.lens_array import LensArray
from ...geometry.rays import depth_scaled_rays
from ...image.colour import decode
from ...scene.features import needed_settings
from ...scene.scene import Scene
from ..shots.batch import ShotBatch
from ..shots.shots import render_shots
from ..methods.quality import Progress, RenderSettings
from .record import note

MAX_WIDTH = 160     # pixels across the depth pass
T_MIN = 1e-3        # below this transmittance a pixel counts as "nothing hit"
CLIP = 0.9999       # a channel at or above this in the fog-1 render is clipped
HOLLOW_NOTE = ("a copy of the scene with every top-level object hollow: the viewer stands inside a solid, "
               "where POV-Ray applies no fog")
BLIND_REASON = ("the depth pass is blind: its rays start inside a solid object (a 'plane' whose inside holds "
                "the viewer, or a closed 'box' or 'sphere' around the camera such as a room or a sky), and "
                "POV-Ray applies no fog inside a non-hollow object; add 'hollow' to that object")
SATURATED_REASON = ("the depth pass cannot measure the middle of the field: its surfaces are brighter than 1 in "
                    "every colour channel (emissive, 'ambient' or 'emission' above 1); keep one channel below 1 "
                    f"or place the display with {param('placement.center')}/{param('placement.normal')}/{param('placement.width')}")
#: POV-Ray threads of a pass.  A jittered area light (and subsurface scattering) samples at random per
#: render thread, so at two threads, which take the pixels in another order in each frame, a surface's
#: colour differs between the two fog frames (a sphere before a plane: its shadow's edge 7-10 mm off in
#: every pass); one thread gives both frames the same samples.  (``crand`` still differs: its sequence
#: runs on from one frame to the next.)
PASS_THREADS = 1
#: The scene's radiosity, photons and subsurface scattering cut to almost nothing for the pass (a later
#: ``global_settings`` overrides the scene's values; written only where the scene has them: a radiosity
#: block would turn radiosity on).  Fog needs POV-Ray's quality 9, which turns them on too.  Photons and
#: subsurface scattering (at one thread) light a surface the same in both frames of the fog pair, so
#: they cost only time (photons are shot anew for each frame; `povh3d info` on subsurface.pov: 15 s, now 2.4 s).
#: Radiosity does not: its sample rays cross the fog, so a surface it lights is brighter in the fog-1
#: frame and ``c`` does not cancel (a sky-lit sphere 3 mm off: tests/renderer/test_depth.py); its
#: ``brightness`` (which must be positive) all but removes its light.
LIGHTING_OFF = {"radiosity": "{ pretrace_start 1 pretrace_end 1 count 1 nearest_count 1 error_bound 100 "
                             "recursion_limit 1 always_sample off brightness 1e-6 }",
                "photons": "{ count 1 max_trace_level 1 }",
                "subsurface": "{ samples 0, 0 }"}


@dataclass(frozen=True)
class DepthMap:
    """Display depth ``z`` (mm, screen 0, viewer at -z) of each pixel; NaN where nothing is hit."""

    z: np.ndarray          # (H, W) float, mm
    width_mm: float
    height_mm: float
    unmeasured: float = 0.0   # fraction of pixels the fog did not reach (the viewpoint inside a solid)
    saturated: np.ndarray | None = None   # (H, W) bool: a surface brighter than 1 in every channel
    hollow_copy: bool = False   # measured on a copy of the scene whose top-level objects are hollow

    def summary(self, budget_mm: float) -> dict[str, JSONValue]:
        """The framed subject's near and far z against the budget (``2 N f``, centred on the screen).

        The subject is what the middle half of the field (in width and height) shows,
        between its 5th and 95th percentiles: a ground plane or a backdrop that runs
        out of the field does not count there, but its reach over the whole field
        (``field_near_mm``, ``field_far_mm``: 1st and 99th percentiles) is reported.
        """
        h, w = self.z.shape
        hit = self.z[np.isfinite(self.z)]
        middle = self.z[h // 4:h - h // 4, w // 4:w - w // 4]
        middle = middle[np.isfinite(middle)]
        saturated = self.saturated if self.saturated is not None else np.zeros(self.z.shape, bool)
        record: dict[str, JSONValue] = {"depth_budget_mm": budget_mm, "hit_fraction": float(hit.size / self.z.size),
                                  "unmeasured_fraction": self.unmeasured,
                                  "saturated_fraction": float(saturated.mean()), "pixels": [w, h]}
        if self.hollow_copy:   # the viewer stood inside a solid: measured where POV-Ray's fog reaches
            record["measured_on"] = HOLLOW_NOTE
        if middle.size == 0:
            return {**record, **self._why_unmeasured(), "within_budget": True, "field_within_budget": True}
        near, far = (float(v) for v in np.percentile(middle, [5, 95]))
        field_near, field_far = (float(v) for v in np.percentile(hit, [1, 99]))
        half = budget_mm / 2
        return {**record, "empty": False, "near_mm": near, "far_mm": far, "depth_mm": far - near,
                "field_near_mm": field_near, "field_far_mm": field_far,
                "within_budget": bool(-half <= near and far <= half),
                "field_within_budget": bool(-half <= field_near and field_far <= half)}

    def _why_unmeasured(self) -> dict[str, JSONValue]:
        """Why the middle of the field has no depth: blind (inside a solid), too bright, or nothing there."""
        h, w = self.z.shape
        if self.unmeasured > 0.5:
            return {"empty": False, "blind": True, "reason": BLIND_REASON}
        if self.saturated is not None and self.saturated[h // 4:h - h // 4, w // 4:w - w // 4].mean() > 0.5:
            return {"empty": False, "saturated": True, "reason": SATURATED_REASON}
        return {"empty": True}


def pass_lighting(scene: Scene) -> dict[str, str]:
    """``LIGHTING_OFF``'s settings for what this scene uses (for a later ``global_settings``)."""
    return needed_settings(scene.features, LIGHTING_OFF)


#: Most POV-Ray runs of a fog pass of many directions at once (the per-view depth maps where their mesh
#: camera cannot be used, ``_views_pass``).  A further shot of a run costs about 0.25 s, nearly all of it
#: POV-Ray waiting (20 shots of an empty scene: 5 s of wall time, 0.1 s of CPU); each run parses the scene.
FOG_RUNS = 16
#: Fewest fog pairs a run of a many-direction pass renders: a run costs about 0.65 s to start.
PAIRS_PER_RUN = 2


def _fog_batch(directions: list[tuple[float, float, float]], lens_array: LensArray, front_clearance: float,
               fog: float, width: int, height: int, field: tuple[float, float] | None = None) -> ShotBatch:
    """Two shots (fog 0, fog 1) per direction, a pair never split between runs (but a lone pair's two
    shots run side by side), in up to ``FOG_RUNS`` POV-Ray runs at once (one thread each: ``PASS_THREADS``).  ``field`` (mm, centred on the origin)
    defaults to the lens array's."""
    width_mm, height_mm = field or (lens_array.lenses_x * lens_array.pitch_x, lens_array.lenses_y * lens_array.pitch_y)
    right, up = (width_mm, 0.0, 0.0), (0.0, height_mm, 0.0)
    shots = [{"direction": d, "fog": colour} for d in directions for colour in (0, 1)]
    if len(directions) == 1:
        # One pair: its two frames as two runs side by side, one thread each (the same images to the bit,
        # each run starting POV-Ray's random sequences afresh), so the pass waits for one POV-Ray start-up
        # and no frame change (about 0.25 s, nearly all of it POV-Ray idling: ``FOG_RUNS``).
        per_job, runs = 1, 2
    else:
        runs = max(1, min(FOG_RUNS, len(directions) // PAIRS_PER_RUN))
        per_job = 2 * -(-len(directions) // runs)
    return ShotBatch("depth.pov.j2", {"fog_distance": fog, "front_clearance": front_clearance, "right": right, "up": up},
                      shots, width, height, shots_per_job=per_job, processes=runs, options=("-A",))


def _views_batch(slopes: np.ndarray, views: tuple[int, int], cells: tuple[int, int], pitch: tuple[float, float],
                 front_clearance: float, fog: float) -> ShotBatch:
    """The fog pair of many views as two shots, one POV-Ray run each at once: the views' orthographic
    cameras tiled into one mesh camera (``camera_mesh.tiled_views_mesh``, the very rays of ``_fog_batch``).
    A further shot of a run costs about 0.25 s, nearly all of it POV-Ray waiting, so demo's 64 views
    took 128 shots (2 s over 16 runs); their pixels in one image take 2 shots, and the two runs side
    by side 0.45-0.65 s where one run of both took 0.65-1.0 s (the same maps to the bit: each run starts
    POV-Ray's random sequences afresh, at one thread, ``PASS_THREADS``)."""
    mesh = tiled_views_mesh(slopes, views, cells, pitch, front_clearance)
    w, h = mesh.image_size
    return ShotBatch("depth_mesh.pov.j2", {"fog_distance": fog, "mesh": mesh},
                     [{"fog": 0}, {"fog": 1}], w, h, shots_per_job=1, processes=2, options=("-A",))


def _views_pass(slopes: np.ndarray, views: tuple[int, int], cells: tuple[int, int], pitch: tuple[float, float],
                lens_array: LensArray, front_clearance: float, fog: float,
                ) -> tuple[ShotBatch, tuple[tuple[int, int], tuple[int, int]] | None]:
    """The batch of ``view_depth_maps``' pass and its ``tiles`` (``_ray_lengths``): every view in one mesh
    camera (``_views_batch``), or a fog pair per view where the tiled image is one pixel wide (POV-Ray's
    mesh camera crashes there: ``mesh_camera_batch``)."""
    if views[1] * cells[0] >= 2:
        return _views_batch(slopes, views, cells, pitch, front_clearance, fog), (views, cells)
    directions = [(a, b, 1.0) for a, b in np.asarray(slopes).tolist()]
    field = (cells[0] * pitch[0], cells[1] * pitch[1])
    return _fog_batch(directions, lens_array, front_clearance, fog, *cells, field), None


def _untiled(image: np.ndarray, views: tuple[int, int], cells: tuple[int, int]) -> np.ndarray:
    """A ``_views_batch`` shot as ``(Ny Nx, rows, cols, C)``, view ``l Nx + k`` first, without the mesh
    camera's extra first row and last column (``CameraMesh``)."""
    (ny, nx), (cols, rows) = views, cells
    tiled = image[1:, :-1]
    return tiled.reshape(ny, rows, nx, cols, -1).transpose(0, 2, 1, 3, 4).reshape(ny * nx, rows, cols, -1)


def _ray_lengths(scene: Scene, lens_array: LensArray, settings: RenderSettings, batch: ShotBatch,
                 fog: float, name: str, progress: Progress | None = None,
                 tiles: tuple[tuple[int, int], tuple[int, int]] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(n, H, W) scene-unit distances from each ray's start (NaN: nothing hit, unmeasured; -inf: too bright)
    and the fraction of unmeasured pixels per direction; the pass noted as ``name`` (``passes.record``).
    ``tiles`` ``(views, cells)``: the batch is ``_views_batch``'s, its shots cut into the views."""
    start = time.perf_counter()
    header: dict[str, Any] = {"panel_size": lens_array.panel.size_mm, "lens_pitch": lens_array.pitch_x,
                              "focal": lens_array.focal}   # as methods.display_header
    if settings.pose is not None:
        header.update(pose_matrix=tuple(settings.pose), pose_transform=" transform { Povh3d_Display_Pose }")
    lighting = pass_lighting(scene)
    if lighting:
        header["global_settings"] = lighting
    pass_settings = replace(settings, quality="draft", bit_depth=16, threads=PASS_THREADS)
    images, stats = render_shots(scene, batch, pass_settings, method="depth", header=header, progress=progress)
    if tiles is not None:
        dark, light = (list(_untiled(image, *tiles)) for image in images)
        found = fog_distances(dark, light, fog)
    else:
        found = fog_distances(images[0::2], images[1::2], fog)
    traced = stats.shots - stats.cached
    note(name, time.perf_counter() - start, traced, stats.jobs if traced else 0, from_cache=not traced)
    return found


def nan_median_last(values: np.ndarray) -> np.ndarray:
    """``np.nanmedian(values, axis=-1)`` (the same numbers) without the 10-40 ms import of
    ``numpy.ma`` that NumPy's small-axis path makes; NaN where a row has no number."""
    ordered = np.sort(values, axis=-1)  # NaN last
    count = (~np.isnan(values)).sum(axis=-1, keepdims=True)
    low = np.take_along_axis(ordered, np.maximum(count - 1, 0) // 2, axis=-1)[..., 0]
    high = np.take_along_axis(ordered, count // 2 - (count == 0), axis=-1)[..., 0]
    with np.errstate(invalid="ignore"):
        return np.where(count[..., 0] > 0, (low + high) / 2, np.nan)


def fog_distances(dark_images: list[np.ndarray], light_images: list[np.ndarray],
                  fog: float) -> tuple[np.ndarray, np.ndarray]:
    """(n, H, W) ray lengths (scene units) from renders with fog colour 0 and 1 (sRGB-encoded PNG
    pixels): NaN where nothing is hit or unmeasured, -inf on a surface brighter than 1 in every
    channel (saturated); and the unmeasured fraction per render."""
    dark = np.stack([decode(img[..., :3]) for img in dark_images])
    light = np.stack([decode(img[..., :3]) for img in light_images])
    clipped = light >= CLIP   # per channel: c t + (1 - t) clips where the surface's c >= 1
    every = clipped.all(axis=-1)
    # t from each channel that does not clip; the median of those.
    channel_t = np.where(clipped, np.nan, 1.0 - (light - dark))
    channel_t[every] = 0.0   # no channel left: set below
    t = np.clip(nan_median_last(channel_t), 0.0, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):   # t = 0: nothing hit; fog 0: no pass
        d = -fog * np.log(t)
    # t = 1 at a surface: no fog there.  POV-Ray applies no fog to a ray that starts inside a
    # solid (non-hollow) object, e.g. behind a plane whose inside faces the viewer: the two
    # renders are then the same in every channel.
    unmeasured = np.abs(light - dark).max(axis=-1) < 1e-6
    # Clipped in every channel: nothing hit (t about 0: the fog-0 render black there) or a
    # surface brighter than 1 in every channel (seen in the fog-0 render).
    saturated = every & ~unmeasured & (dark.max(axis=-1) >= T_MIN)
    d[every | (t < T_MIN) | unmeasured] = np.nan
    d[saturated] = -np.inf
    return d, unmeasured.mean(axis=(1, 2))


def pass_size(lens_array: LensArray) -> tuple[int, int]:
    """The depth pass's image size: at most ``MAX_WIDTH`` wide, two pixels a lens, the field's aspect."""
    width_mm, height_mm = lens_array.lenses_x * lens_array.pitch_x, lens_array.lenses_y * lens_array.pitch_y
    w = min(MAX_WIDTH, lens_array.lenses_x * 2)
    return w, max(1, round(w * height_mm / width_mm))


def depth_map(distances: np.ndarray, lens_array: LensArray, front_clearance: float, units_per_mm: float,
              unmeasured: float = 0.0) -> DepthMap:
    """The depth map of ray lengths (scene units) of a pass along the normal from ``front_clearance`` mm."""
    width_mm, height_mm = lens_array.lenses_x * lens_array.pitch_x, lens_array.lenses_y * lens_array.pitch_y
    saturated = np.isneginf(distances)   # fog_distances' mark
    z = np.where(saturated, np.nan, distances / units_per_mm - front_clearance)
    return DepthMap(z, width_mm, height_mm, unmeasured, saturated)


def depth_pass(scene: Scene, lens_array: LensArray, settings: RenderSettings, front_clearance: float,
               units_per_mm: float, progress: Progress | None = None) -> DepthMap:
    """Measure the scene's depth in the pose of ``settings.pose`` (None: native); ``progress(done,
    total)``: its two shots."""
    w, h = pass_size(lens_array)
    fog = front_clearance * units_per_mm   # scene units: t = 1/e at the screen
    batch = _fog_batch([(0.0, 0.0, 1.0)], lens_array, front_clearance, fog, w, h)
    d, unmeasured = _ray_lengths(scene, lens_array, settings, batch, fog, "depth", progress)
    hollow = False
    if unmeasured[0] > 0:   # rays that start inside a solid: measured again on the hollow copy
        again = _hollow_lengths(scene, lens_array, settings, batch, fog, "depth", progress)
        if again is not None and again[1][0] < unmeasured[0]:
            (d, unmeasured), hollow = again, True
    found = depth_map(d[0], lens_array, front_clearance, units_per_mm, float(unmeasured[0]))
    return replace(found, hollow_copy=hollow)


def origin_field(lens_array: LensArray, front_clearance: float) -> tuple[float, float]:
    """Width and height (mm) of the plane ``z = -front_clearance`` that holds every pixel ray's origin: the
    lens array's field, widened on each side by the clearance times the most oblique ray's slope (the
    largest pixel offset from a lens centre over ``f``; a lenticular sheet's rays keep their row)."""
    f = lens_array.focal
    if lens_array.grid == "hex":
        hx = hy = lens_array.pitch_x / np.sqrt(3)   # the cell's circumradius
    elif lens_array.grid == "lattice":
        a1, a2 = np.abs(np.array(lens_array.basis, dtype=np.float64))
        hx, hy = (a1 + a2) / 2
    else:
        hx = lens_array.pitch_x / 2
        hy = 0.0 if lens_array.grid == "lenticular" else lens_array.pitch_y / 2
    return (lens_array.lenses_x * lens_array.pitch_x + 2 * front_clearance * hx / f,
            lens_array.lenses_y * lens_array.pitch_y + 2 * front_clearance * hy / f)


#: How far in front of the origins' plane the origins pass's cap stands, as a share of the front clearance.
CAP_SHARE = 0.01


def origins_inside(scene: Scene, lens_array: LensArray, settings: RenderSettings, front_clearance: float,
                   units_per_mm: float, name: str = "origins-inside", progress: Progress | None = None) -> float:
    """The share of the plane of every view's ray origins (``origin_field``, ``front_clearance`` mm out)
    that lies inside a solid: a fog pass along the normal over that plane (the pixels the fog does not
    reach).  ``lens_array``: the rays as traced (``depth_scaled_rays``).

    Only the rays' first stretch counts, so a black hollow slab (``cap``) stops them ``CAP_SHARE`` of
    the clearance out, under a fog of that distance: the fog shows on the slab (1 - 1/e) wherever a ray
    starts outside every solid, and nowhere else, as on the scene's own surfaces before (a surface nearer
    than the slab shows its own fog, as it would without the slab).  Without it the pass traced the
    whole scene, its media and its lights: 6 s of ``advanced/abyss.pov``'s media, 8 s of
    ``benchmark.pov``, where the cap leaves a tenth."""
    field = origin_field(lens_array, front_clearance)
    w = MAX_WIDTH
    h = max(1, min(4 * MAX_WIDTH, round(w * field[1] / field[0])))
    gap = CAP_SHARE * front_clearance
    fog = gap * units_per_mm
    batch = _fog_batch([(0.0, 0.0, 1.0)], lens_array, front_clearance, fog, w, h, field)
    batch = replace(batch, context={**batch.context, "cap": {"near": -front_clearance + gap,
                                                              "far": -front_clearance + 2 * gap,
                                                              "half": (field[0], field[1])}})
    _, unmeasured = _ray_lengths(scene, lens_array, settings, batch, fog, name, progress)
    return float(unmeasured[0])


def _inside_solid(scene: Scene, lens_array: LensArray, settings: RenderSettings, batch: ShotBatch, fog: float,
                  d: np.ndarray, unmeasured: np.ndarray, name: str, progress: Progress | None = None,
                  tiles: tuple[tuple[int, int], tuple[int, int]] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The pass again on a copy of the scene whose top-level objects are all ``hollow``
    (``scene.rewrite.all_hollow``), where rays started inside a solid; a warning naming the share
    still unmeasured (a solid the copy cannot reach: one a macro or another folder's include makes).
    At ``max_trace_level 1`` only the way to the first surface counts, and there the copy's fog is the
    scene's wherever a ray starts outside every solid: its lengths replace the first pass's whole."""
    again = _hollow_lengths(scene, lens_array, settings, batch, fog, name, progress, tiles)
    if again is not None:
        d, unmeasured = again
    if unmeasured.max() > 0:
        warn(f"the depth pass cannot measure {100 * float(unmeasured.mean()):.3g} % of the depth maps' pixels "
             f"(NaN there): {BLIND_REASON}")
    return d, unmeasured


def _hollow_lengths(scene: Scene, lens_array: LensArray, settings: RenderSettings, batch: ShotBatch, fog: float,
                    name: str, progress: Progress | None = None,
                    tiles: tuple[tuple[int, int], tuple[int, int]] | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """``_ray_lengths`` on a copy of the scene whose top-level objects are all ``hollow``
    (``scene.rewrite.all_hollow``): POV-Ray applies no fog inside a non-hollow solid, so a ray that
    starts inside one (a backdrop ``plane``, a room, a sky sphere) measures nothing; hollow, the same
    surfaces are found.  None when no object of the scene's own sources changes, or the copy fails to
    parse (said in a warning)."""
    from ...scene.rewrite import all_hollow, copy_rewritten

    with tempfile.TemporaryDirectory(prefix="povh3d-hollow-") as folder:
        try:
            copy = copy_rewritten(scene, Path(folder), all_hollow)
            if copy is None:
                return None
            return _ray_lengths(copy, lens_array, settings, batch, fog, f"{name}-hollow", progress, tiles)
        except Povh3dError as exc:   # the copy does not parse: say so, keep the first pass
            warn(f"the depth pass could not make {scene.path.name}'s objects hollow ({exc}); the rays that "
                 "start inside a solid stay unmeasured")
            return None


def view_depth_maps(scene: Scene, lens_array: LensArray, settings: RenderSettings, front_clearance: float,
                    units_per_mm: float, *, views: tuple[int, int] | None = None,
                    grid: tuple[int, int, float, float] | None = None, progress: Progress | None = None,
                    name: str = "depth-maps") -> np.ndarray:
    """Per view ``(l, k)``: the distance (display mm) along each of its rays from the screen
    (where the ray crosses ``z = 0``, at its lens centre) to the first surface; negative in front.

    With ``settings.depth_scale`` k the maps are the compressed scene's, as the display
    shows it: the rays traced have slopes ``k (u, v) / f`` (``depth_scaled_rays``), a hit at
    depth ``z`` of the scene shows at ``k z``.

    ``views`` (Ny, Nx) default the camera bank's; a resampled array passes its own
    (``elemental.view_grid``).  ``grid`` ``(cols, rows, pitch_x, pitch_y)`` puts the rays'
    screen crossings on that rectangular grid centred on the origin (a hex array's views
    resampled onto lens columns) instead of the lens centres of a rectangular array.
    ``progress(done, total)``: the pass's shots (two a view); ``name``: the pass in the sidecar.

    Returns
    -------
    (Ny, Nx, Ly, Lx) float32, mm (``grid``: rows x cols); NaN where nothing is hit (or it
    cannot be measured).
    """
    ny, nx = views or lens_array.require_views()
    cols, rows, gx, gy = grid or (lens_array.lenses_x, lens_array.lenses_y, lens_array.pitch_x, lens_array.pitch_y)
    s, sy = lens_array.panel.pitch_x, lens_array.panel.pitch_y
    k = settings.depth_scale
    f = depth_scaled_rays(lens_array, k).focal
    slopes = np.array([((j + 0.5 - nx / 2) * s / f, (ny / 2 - l - 0.5) * sy / f)
                       for l in range(ny) for j in range(nx)])
    fog = front_clearance * units_per_mm
    batch, tiles = _views_pass(slopes, (ny, nx), (cols, rows), (gx, gy), lens_array, front_clearance, fog)
    d, unmeasured = _ray_lengths(scene, lens_array, settings, batch, fog, name, progress, tiles)
    if unmeasured.max() > 0:
        d, unmeasured = _inside_solid(scene, lens_array, settings, batch, fog, d, unmeasured, name, progress, tiles)
    # The ray starts front_clearance * |(a, b, 1)| before the screen; z = length / |(a, b, 1)|.
    lengths = np.sqrt((slopes ** 2).sum(axis=1) + 1.0)[:, None, None]
    z = np.where(np.isneginf(d), np.nan, d) / units_per_mm / lengths - front_clearance
    shown = np.sqrt(((slopes / k) ** 2).sum(axis=1) + 1.0)   # the display's own ray, slope (u, v) / f
    out = k * z * shown[:, None, None]
    return out.reshape(ny, nx, *out.shape[1:]).astype(np.float32)
