"""The rendering methods, registered by name (``METHODS``).

- ``multi-ortho``: the multi-orthographic camera bank traced in one POV-Ray
  pass through a mesh camera (one face per view, or per lens with fractional
  pixels per lens); the default, about as fast as a plain 2D render of the panel.
- ``multi-ortho-views``: the same bank as one orthographic camera per view
  (the BBC method as the thesis ran it), views interleaved in NumPy.
- ``pinhole``: one perspective camera per lens, the traditional baseline.
- ``single-stage``: a virtual array of CSG lenslets with an index of
  refraction, rendered by one orthographic camera (thesis 3.3): a physical
  simulation, compared with the others by an error figure (``single_stage``).
- ``subpixel``: a slanted lenticular panel, every R, G and B subpixel's own ray
  through its lenticule, one pass at ``3W x H`` written as the panel image.

Every method traces the ray of a pixel (docs/geometry.md); point-sampled they
agree.  A method is pure around the renderer: its ``plan`` says which frames to
ask POV-Ray for and how to assemble the returned images into the H3D image;
its hooks say what it supports and what the sidecar records of it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ...errors import ConfigError, param, warn
from ...jsontext import JSONObject, JSONValue
from ...geometry.cameras import ortho_view_shots, pinhole_shots
from ...geometry.camera_mesh import check_front_clearance, clearance_range, default_front_clearance
from ...geometry.view_bank import bank_front_clearance, eye_clearance, stack_shots, view_bank_shots
from ...geometry.crop import CropSettings
from ...geometry.footprint import CENTRE, latin_hypercube
from ...geometry.lattice_mesh import lens_mesh
from ...geometry.lens_array import LensArray
from ...geometry.phase_tiles import phase_tiles, tiles_mesh, uncovered
from ...geometry.rays import depth_scaled_rays
from ...image.colour import decode, encode, mean_in_linear_light
from ...image.interleave import interleave, tile_elemental_images, untile_views
from ...scene.scene import Scene
from ...system import cpu_count
from ..placement.clearance import front_clearance as front_clearance_for
from .cropped import render_cropped_tiles
from ..shots.batch import ShotBatch, RenderStats, mesh_camera_batch
from ..shots.shots import render_shots
from .quality import Progress, Quality, RenderSettings, quality_settings
from ...display import subpixel
from .single_stage import SingleStagePlan, default_depth, lenslet_for, recentre_unit


#: multi-ortho-views: the most POV-Ray runs a core, the views spread evenly over them (``_multi_ortho_views``).
RUNS_PER_CORE = 8

#: Pixels between the tiles of a one-pass view bank when antialiasing samples pixel
#: borders: one, each tile reaching half of it (``view_bank._bank_mesh``).
GUTTER = 1


@dataclass(frozen=True)
class MethodPlan:
    """What one render of a method asks POV-Ray for, and how it becomes the H3D image."""

    batch: ShotBatch
    assemble: Callable[[list[np.ndarray]], np.ndarray]
    record: JSONObject | None = None    # what the sidecar says of the method's own set-up
    # The H3D image of each run of consecutive samples (their counts), in linear light, from the
    # same images: what --quality auto scores its seeds with (None: the method cannot split them).
    assemble_groups: Callable[[list[np.ndarray], list[int]], list[np.ndarray]] | None = None


def _multi_ortho(lens_array: LensArray, front_clearance: float, samples: np.ndarray, *, gutter: int = 0,
                 bank: bool = True, viewing_distance: float | None = None) -> MethodPlan:
    # bank False: a clearance the view bank cannot start at exactly (under one step, kept within a
    # scene camera): the lens mesh, which starts rays anywhere, traces the same rays.
    if viewing_distance is not None and (not lens_array.views or not bank):
        raise ConfigError(f"{param('viewing_distance')} traces a view bank's rows: it needs whole pixels per lens "
                          f"({param('ppl')}) and a {param('front_clearance')} of a whole number of focal x views")
    if not lens_array.views or not bank:  # fractional PPL, hex, rotated lattices: one cell per lens
        if len(samples) == 1 and not np.any(samples):
            mesh = lens_mesh(lens_array, front_clearance)
            return MethodPlan(mesh_camera_batch("multi_ortho.pov.j2", [mesh]),
                              lambda images: mesh.crop(stack_shots(images)))
        # One frame per footprint sample, every sample through the pixel's own lens.
        meshes = [lens_mesh(lens_array, front_clearance, sample=p) for p in samples]
        return MethodPlan(mesh_camera_batch("multi_ortho.pov.j2", meshes), lambda images: mean_in_linear_light(
            np.stack([mesh.crop(stack_shots([im])) for mesh, im in zip(meshes, images)])))
    # Whole PPL: one quad per view (views tiled, gutters between them where antialiasing
    # samples pixel borders), one bank per footprint sample, a few banks a frame.
    meshes = view_bank_shots(lens_array, front_clearance, samples, gutter=gutter, viewing_distance=viewing_distance)
    return MethodPlan(mesh_camera_batch("multi_ortho.pov.j2", meshes),
                      lambda images: banks_to_h3d(lens_array, stack_shots(images, meshes)),
                      assemble_groups=lambda images, counts: bank_groups(lens_array, stack_shots(images, meshes),
                                                                         counts))


def banks_to_h3d(lens_array: LensArray, image: np.ndarray) -> np.ndarray:
    """The H3D image of tiled view banks stacked one per footprint sample (averaged in linear light)."""
    ny, nx = lens_array.require_views()
    banks = image.shape[0] // (ny * lens_array.lenses_y)
    bank = mean_in_linear_light(image.reshape(banks, -1, *image.shape[1:])) if banks > 1 else image
    return interleave(untile_views(bank, (ny, nx)))


def bank_groups(lens_array: LensArray, image: np.ndarray, counts: list[int]) -> list[np.ndarray]:
    """The linear-light H3D image of each run of ``counts`` consecutive banks of ``image`` (stacked
    one per footprint sample, as ``banks_to_h3d`` reads them)."""
    ny, nx = lens_array.require_views()
    banks = image.reshape(sum(counts), -1, *image.shape[1:])
    ends = np.cumsum([0, *counts])
    return [interleave(untile_views(sum(decode(b) for b in banks[a:e]) / (e - a), (ny, nx)))
            for a, e in zip(ends[:-1], ends[1:])]


def _multi_ortho_views(lens_array: LensArray, front_clearance: float, samples: np.ndarray) -> MethodPlan:
    ny, nx = lens_array.require_views()
    check_front_clearance(lens_array, front_clearance)
    common, shots = ortho_view_shots(lens_array)
    width, height = common.pop("width"), common.pop("height")
    # POV-Ray idles about 0.7 s starting and 0.24 s a frame (measured: 64 frames of 4x3 pixels, 15.6 s
    # wall, 0.2 s of CPU), so runs of a few frames, many more than the cores, overlap that idling:
    # desk.pov's 64 views on 2 cores rendered in 2.0 s as 16 runs of 4 frames, 2.4-2.8 s as 8 of 8,
    # 4.1 s as 64 of 1 (each run's own start-up CPU), 7.8 s as 2 of 32 (docs/benchmarks.md).  A few
    # views go one a run, which lets an animation's frames run in clock sequences (``clock_runs``).
    per_job = -(-len(shots) // (RUNS_PER_CORE * cpu_count()))
    processes = -(-len(shots) // per_job)
    batch = ShotBatch("multi_ortho_views.pov.j2", {**common, "front_clearance": front_clearance}, shots,
                       width, height, shots_per_job=per_job, processes=processes,
                       lighting_shots=centre_and_corners(ny, nx))
    return MethodPlan(batch, lambda images: interleave(np.stack(images).reshape(ny, nx, *images[0].shape)))


def centre_and_corners(rows: int, columns: int) -> tuple[int, ...]:
    """Shots of a row-major grid that light the others (``ShotBatch.lighting_shots``): the centre, the corners."""
    return tuple(dict.fromkeys((rows // 2 * columns + columns // 2, 0, columns - 1, (rows - 1) * columns,
                                rows * columns - 1)))


def _pinhole(lens_array: LensArray, front_clearance: float, samples: np.ndarray) -> MethodPlan:
    lens_array.require_views()
    common, shots = pinhole_shots(lens_array)
    width, height = common.pop("width"), common.pop("height")
    processes = 2 * cpu_count()
    # Many small shots per run: each further shot costs a re-parse, not a start-up.
    per_job = max(1, min(500, -(-len(shots) // processes)))
    batch = ShotBatch("pinhole.pov.j2", common, shots, width, height, shots_per_job=per_job, processes=processes,
                       lighting_shots=centre_and_corners(lens_array.lenses_y, lens_array.lenses_x))
    lenses = (lens_array.lenses_y, lens_array.lenses_x)
    return MethodPlan(batch, lambda images: tile_elemental_images(
        np.stack(images).reshape(*lenses, *images[0].shape)))


def _single_stage(lens_array: LensArray, front_clearance: float, samples: np.ndarray, *,
                  lenslet: str, ior: float | None, supersample: int = 1) -> MethodPlan:
    if lens_array.grid == "lattice":
        raise ConfigError(f"{param('method')} single-stage builds square, hex and lenticular lenslets, not a general "
                          f"lattice ({param('lattice')}); render it with {param('method')} multi-ortho")
    plan = SingleStagePlan.checked(lens_array, lenslet_for(lens_array, lenslet, ior, front_clearance), front_clearance, supersample)
    return MethodPlan(plan.batch(), lambda images: plan.assemble(images[0]), plan.as_record())


def single_stage_supersamples(quality: Quality) -> int:
    """Sub-pixel samples per axis with which single-stage antialiases at ``quality``.

    POV-Ray's adaptive antialiasing samples pixel corners, and every corner of a
    capture pixel at a lens border lies on that border, so its rays graze the
    neighbouring lenslet and the border pixels come out a mix of two views.  The
    method therefore renders point-sampled and supersamples itself, strictly
    inside each pixel's own lens: ``k x k`` sub-pixel-centred samples (``+R``
    of the adaptive levels, 4 for footprint-sampled levels, the sub-views per
    axis where a level asks for them), averaged in linear light.
    """
    if quality.footprint:
        return 4
    if quality.subviews > 1:
        return quality.subviews
    return quality.aa_depth if quality.antialias is not None else 1


def _subpixel(lens_array: LensArray, front_clearance: float, samples: np.ndarray, *, supersample: int = 1,
              sheet_shift_mm: float = 0.0) -> MethodPlan:
    """A rational sheet (every real panel): one quad per phase coset, and with ``supersample``
    k > 1 one frame per point of ``k x k`` footprint samples (aperture and subpixel area, averaged
    in linear light).  Otherwise one strip per lenticule, point-sampled.  ``sheet_shift_mm``: the
    lenticules lie that far across from the centred sheet's (a calibrated phase, ``subpixel.placed_sheet``)."""
    shift = float(sheet_shift_mm)
    sub = subpixel.subpixel_array(lens_array)
    tiles = phase_tiles(sub)
    if tiles is None:
        if supersample > 1:
            warn(f"this lens sheet's phases do not repeat within 64 subpixels and rows, so {param('method')} subpixel "
                 "traces it point-sampled (one strip per lenticule); give a rational sheet to antialias")
        meshes = [lens_mesh(sub, front_clearance, shift)]
    else:
        points = latin_hypercube(supersample * supersample) if supersample > 1 else CENTRE
        meshes = [tiles_mesh(sub, tiles, front_clearance, tuple(p), shift) for p in points]
    outside = uncovered(sub, shift) if tiles is not None else None
    return MethodPlan(mesh_camera_batch("multi_ortho.pov.j2", meshes),
                      lambda images: subpixel.assemble(meshes[0], tiles, images, outside),
                      subpixel.sheet_record(lens_array, tiles, len(meshes), shift))


@dataclass(frozen=True)
class Method:
    """A rendering method and what it supports.

    plan(array, front clearance mm, footprint samples (K, 4), **options) -> MethodPlan
    """

    plan: Callable[..., MethodPlan]
    # The method's own options and their defaults (CLI --lenslet, --ior).
    options: Mapping[str, Any] = field(default_factory=dict)
    default_front_clearance: Callable[[LensArray], float] = default_front_clearance
    # Where the rays really start for a requested clearance (the sidecar's figure).
    round_front_clearance: Callable[[LensArray, float], float] = lambda lens_array, front_clearance: front_clearance
    # Under a limit: the step (mm) its clearances must come in, given the plan's options, rounded down to
    # it (single-stage's depth moves the lens array by whole lenses, 0 is a step; a view bank's rays start
    # only at whole steps: under one, multi-ortho traces a lens mesh); 0: the limit itself.
    front_clearance_step: Callable[[LensArray, Mapping[str, Any]], float] = lambda lens_array, options: 0.0
    # Whether the method can trace footprint samples (sub-views) for this array;
    # where it cannot, a quality that asks for them falls back to antialiasing.
    takes_samples: Callable[[LensArray], bool] = lambda lens_array: False
    # Whether it can trace only the lenses objects can reach (``cropped``).
    crops: bool = False
    # Methods that antialias inside each pixel themselves: sub-samples per axis for a
    # quality, passed to ``plan`` as ``supersample`` while POV-Ray traces point-sampled.
    supersamples: Callable[[Quality], int] | None = None
    # Methods that tile several views (or lens ranges) into one POV-Ray image: passed
    # ``gutter`` pixels to leave between them where POV-Ray's antialiasing samples
    # pixel borders (``Quality.samples_pixel_borders``).
    gutters: bool = False
    # Whether POV-Ray's own antialiasing stays inside each pixel's footprint on this array;
    # where not, a quality that asks for it traces footprint samples (``Quality.footprint_sampled``).
    confines_antialias: Callable[[LensArray], bool] | None = None
    # Traced by POV-Ray 3.7's mesh camera, which gives every ray the inside-solid state of a thread's
    # first ray (other cameras work it out per ray): renderer/placement/ray_state.py.
    shares_ray_state: bool = False

    def resolve_options(self, name: str, given: Mapping[str, Any]) -> dict[str, Any]:
        """``given`` (None values count as not given) over the defaults; unknown names refused."""
        given = {k: v for k, v in given.items() if v is not None}
        unknown = sorted(set(given) - set(self.options))
        if unknown:
            raise ConfigError(f"method {name!r} takes no option {', '.join(unknown)}; "
                              f"drop it or pick a method that does")
        return {**self.options, **given}


def _whole_views(lens_array: LensArray) -> bool:
    return lens_array.views is not None


METHODS: dict[str, Method] = {
    # A lens mesh (hex, fractional PPL, turned lattices) lays neighbouring lenses side by side in
    # POV-Ray's image, where corner samples would cross lens borders: footprint samples instead.
    # viewing_distance: a lenticular array's rows seen from that distance (``view_bank._row_strips``).
    "multi-ortho": Method(_multi_ortho, {"viewing_distance": None}, takes_samples=_whole_views, crops=True, gutters=True,
                          confines_antialias=_whole_views, shares_ray_state=True,
                          round_front_clearance=lambda la, b: bank_front_clearance(la, b) if la.views else b,
                          front_clearance_step=lambda la, o: la.focal * math.lcm(*la.require_views()) if la.views else 0.0),
    "multi-ortho-views": Method(_multi_ortho_views),
    "pinhole": Method(_pinhole),
    "single-stage": Method(_single_stage, {"lenslet": "conic", "ior": None}, default_depth,
                           supersamples=single_stage_supersamples,
                           front_clearance_step=lambda la, o: recentre_unit(la, o.get("supersample", 1))),
    "subpixel": Method(_subpixel, {"sheet_shift_mm": 0.0}, supersamples=single_stage_supersamples, shares_ray_state=True),
}


def pose_units(frame: tuple[float, ...] | None) -> float:
    """Scene units per display mm of a frame matrix (its rows' common length; 1 without a frame)."""
    return 1.0 if frame is None else float(np.linalg.norm(np.asarray(frame[:3], dtype=np.float64)))


def _check_clearance(name: str, method: Method, lens_array: LensArray, front_clearance: float,
                     units_per_mm: float) -> None:
    """Refuse a clearance POV-Ray cannot trace in scene units, advising requests that pass once the
    method has rounded them (a view bank's clearance comes in steps of ``f lcm(Nx, Ny)``)."""
    least, most = clearance_range(lens_array, units_per_mm)
    rounded = lambda x: method.round_front_clearance(lens_array, x)  # noqa: E731
    step = rounded(least)
    top = most if rounded(most) <= most * (1 + 1e-12) else rounded(most) - step
    if least <= most and rounded(least) > most and name == "multi-ortho":
        raise ConfigError(
            f"multi-ortho's view bank starts its rays a whole {step:.4g} mm (focal x views) in front of the screen, "
            f"beyond the {most:.4g} mm POV-Ray can trace here; use {param('method')} multi-ortho-views "
            f"{param('front_clearance')} {float(f'{0.99 * most:.3g}'):g} (its views start anywhere)")
    check_front_clearance(lens_array, front_clearance, units_per_mm, accepted=(least, top))


def get_method(name: str) -> Method:
    if name not in METHODS:
        raise ConfigError(f"unknown method {name!r}; choose one of: {', '.join(METHODS)}")
    return METHODS[name]


def display_header(lens_array: LensArray) -> dict[str, Any]:
    """Display constants the scene header declares (``Povh3d_Panel_Width`` ...)."""
    return {"panel_size": lens_array.panel.size_mm, "lens_pitch": lens_array.pitch_x,
            "focal": lens_array.focal}


class GroupsUnsupported(ConfigError):
    """``footprint_groups`` asked of a plan that cannot split its samples (checked before any trace)."""


@dataclass
class MethodResult:
    h3d: np.ndarray          # (H, W, C) uint8 or uint16
    stats: RenderStats
    front_clearance: float
    quality: Quality         # as rendered (after any fallback to antialiasing)
    crop: JSONObject | None = None    # what the crop did, for the sidecar
    record: JSONObject | None = None  # the method's own set-up, for the sidecar
    front_clearance_reason: str = ""      # why rays start there, for the sidecar and the summary
    groups: list[np.ndarray] | None = None   # ``footprint_groups``: each group's H3D image, linear light
    # (Ny, Nx, Ly, Lx, C): the camera bank's views where the method rendered them apart (the vendor's
    # cameras), so a quilt is tiled from them, not gathered back out of the interleaved image
    views: np.ndarray | None = None


def run_method(name: str, scene: Scene, lens_array: LensArray, settings: RenderSettings,
               progress: Progress | None = None, crop: CropSettings | None = None,
               declared: LensArray | None = None, footprint_groups: list[np.ndarray] | None = None,
               method_options: Mapping[str, JSONValue] | None = None,
               on_clearance: Callable[[float], None] | None = None, **options: Any) -> MethodResult:
    """Render ``scene`` with method ``name`` and return the H3D image.

    ``options`` (and ``method_options``, a request's) are the method's own (``single-stage``:
    ``lenslet``, ``ior``); None values count as not given.  ``crop`` (methods that crop): trace each
    view only where objects can be, fill the rest with the background
    (``cropped``); None renders everything.  ``declared``: the display the scene is told
    about (``Povh3d_Panel_Width`` ...) when ``lens_array`` is a window of it (auto's probe).
    ``footprint_groups``: footprint sample sets ``(K_i, 4)`` traced in the one run instead of the
    quality's own (a method whose plan splits them; no crop), each group's image in ``groups`` and
    their mean over every sample in ``h3d``: --quality auto's seeds and its draft, priced as one render.
    ``on_clearance(mm)``: called once where the rays will start is known, before POV-Ray runs (the
    depth maps' pass starts beside the render there, ``passes.beside``).
    """
    method = get_method(name)
    options = method.resolve_options(name, {**(method_options or {}), **options})
    asked = settings.spec
    header = display_header(declared or lens_array)   # the display's own constants, whatever --depth-scale does
    lens_array = depth_scaled_rays(lens_array, settings.depth_scale)
    quality = settings.spec if method.takes_samples(lens_array) else settings.spec.point_sampled()
    if method.confines_antialias is not None and not method.confines_antialias(lens_array):
        quality = quality.footprint_sampled()
    if quality != settings.spec:
        settings = replace(settings, quality=quality)
    plan_options = dict(options)
    if method.supersamples is not None:
        # POV-Ray point-samples; the method spreads its own samples inside each pixel.
        plan_options["supersample"] = method.supersamples(asked)
        quality = Quality(max_trace_level=quality.max_trace_level)
        settings = replace(settings, quality=quality)
    if method.gutters:
        plan_options["gutter"] = GUTTER if quality.samples_pixel_borders else 0
    clearance = front_clearance_for(method, lens_array, settings, plan_options)
    if name != "single-stage":  # its depth is checked by its own optics (check_optics)
        _check_clearance(name, method, lens_array, clearance.rounded, pose_units(settings.pose))
    front_clearance, reason = clearance.used, clearance.reason
    distance = plan_options.get("viewing_distance")
    if distance is not None:   # --depth-scale k: the eye of the compressed scene, its slopes k y / D as the views'
        distance = plan_options["viewing_distance"] = distance / settings.depth_scale
    if distance is not None and front_clearance >= distance:   # an eye sees nothing behind itself
        front_clearance = eye_clearance(lens_array, distance)
        reason = f"the viewing distance {distance:g} mm: rays start at the eye, at the view bank's last step before it"
    if clearance.lens_mesh:
        plan_options["bank"], crop = False, None
    if footprint_groups is not None and (plan_options.get("bank") is False or not method.takes_samples(lens_array)
                                         or name != "multi-ortho"):
        raise GroupsUnsupported(f"{name} cannot return footprint sample groups here (no view bank)")
    samples = quality.samples() if footprint_groups is None else np.concatenate(footprint_groups)
    if settings.pose is not None:  # move every camera (and a lens array) into the scene
        header.update(pose_matrix=tuple(settings.pose), pose_transform=" transform { Povh3d_Display_Pose }")
    settings_needed = quality_settings(scene.features, quality)
    if settings_needed:
        header["global_settings"] = settings_needed
    def trace(batch: ShotBatch, label: str, progress: Progress | None) -> tuple[list[np.ndarray], RenderStats]:
        return render_shots(scene, batch, settings, method=label, header=header, progress=progress)

    if on_clearance is not None:
        on_clearance(front_clearance)

    h3d, crop_info, record, groups = None, None, None, None
    if method.crops and crop is not None and footprint_groups is None and options.get("viewing_distance") is None:
        tiles = render_cropped_tiles(trace, scene, lens_array, front_clearance, settings, crop, progress, samples,
                                     plan_options.get("gutter", 0))
        crop_info = tiles.info
        if tiles.tiled is not None and tiles.stats is not None:  # traced: both or neither
            h3d, stats = banks_to_h3d(lens_array, tiles.tiled), tiles.stats
    if h3d is None:
        plan = method.plan(lens_array, front_clearance, samples, **plan_options)
        images, stats = trace(plan.batch, name, progress)
        if footprint_groups is None:
            h3d, record = plan.assemble(images), plan.record
        else:
            counts = [len(g) for g in footprint_groups]
            assert plan.assemble_groups is not None  # multi-ortho's view bank (GroupsUnsupported above)
            groups = [on_panel(lens_array, g) for g in plan.assemble_groups(images, counts)]
            h3d = encode(np.asarray(sum(n * g for n, g in zip(counts, groups)) / sum(counts)), images[0].dtype)
    return MethodResult(on_panel(lens_array, h3d), stats, front_clearance, quality, crop_info, record, reason,
                        groups=groups)


def on_panel(lens_array: LensArray, h3d: np.ndarray) -> np.ndarray:
    """``h3d`` on the whole panel: a camera bank covers the lens array; the margin outside it stays black."""
    panel_shape = (lens_array.panel.height, lens_array.panel.width)
    if h3d.shape[:2] == panel_shape:
        return h3d
    canvas = np.zeros(panel_shape + h3d.shape[2:], h3d.dtype)
    canvas[lens_array.bank_region] = h3d
    return canvas
