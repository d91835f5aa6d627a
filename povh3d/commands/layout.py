"""``povh3d layout``: a picture of the set-up (file in, picture out), checked before a long render.

The content is put where a render would put it, in the display's frame (mm):

- a POV-Ray scene: the display placed as ``render`` places it (``renderer.placement.place``:
  the scene's camera, the explicit ``--display-*`` options, ``--fit-depth``),
  then the depth pass (``renderer.passes.depth``) seen from the viewer: a coarse surface
  through the points it hits, the scene's bounding geometry as the display sees it;
- a mesh model: its triangles, turned (``--up``, ``--rotate``) and placed by
  ``geometry.fit.fit_to_display`` exactly as the default stage places them;
- a volume: its physical box turned by the orientation preset and ``--rotate``
  (``volume.orient``) and fitted to the display the same way, with the patient's
  directions marked on it.

The picture (``commands.layout_picture``) shows it with the screen, the depth-budget
slab, the lens array and the viewing cone (``geometry.setup``).  A sidecar
beside the PNG holds every number of the legend.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, param, warn
from ..geometry.lens_array import LensArray
from ..geometry.setup import SetUp, depth_figures, depth_points, set_up
from ..display.display import Display
from ..renderer.records import base_record, png_output, write_image
from ..geometry.fit import FILL, depth_budget_mm, fit_to_display, fit_record

SCENE_SUFFIXES = (".pov",)
MIN_SIZE, MAX_SIZE = 200, 8000   # picture pixels on a side
#: What the share outside the depth budget is a share of.
COUNTED = {"scene": "of the field it covers", "model": "of its surface", "volume": "of its box's depth"}
PREVIEW_VOXELS = 96              # voxels on a side of a volume's shape in the picture


@dataclass
class Content:
    """What the picture shows of the content, display mm.

    Attributes
    ----------
    kind : {'scene', 'model', 'volume'}
    name : str
    vertices : (n, 3) float, mm      surface vertices (a scene: its depth-pass hit points)
    faces : (m, 3) int               triangles into ``vertices`` (may be empty: points only)
    z_samples : (k,) float, mm       what the depth figures count: a scene's hits (even over the field),
                                     points even over a model's surface, or a volume box's depth
    box : (8, 3) float or None       a volume's physical box (``Volume.corners`` order)
    marks : list of (label, (3,) mm) the patient's directions on a volume's box
    units_per_mm : float             the placement's scene units per mm (1 for models, volumes)
    record : mapping                 where it came from: placement, fit, depth pass
    """

    kind: str
    name: str
    vertices: np.ndarray
    faces: np.ndarray
    z_samples: np.ndarray
    box: np.ndarray | None = None
    marks: list[tuple[str, np.ndarray]] = field(default_factory=list)
    units_per_mm: float = 1.0
    record: dict[str, Any] = field(default_factory=dict)


def source_kind(path: Path) -> str:
    """'scene', 'model' or 'volume', from the name; a ConfigError listing the kinds otherwise."""
    from ..mesh.formats import is_mesh_file
    from ..volume.sources import SUFFIXES as VOLUME_SUFFIXES, is_volume_source

    name = path.name.lower()
    if name.endswith(SCENE_SUFFIXES):
        return "scene"
    if is_mesh_file(str(path)):
        return "model"
    if is_volume_source(path):
        return "volume"
    raise ConfigError(f"cannot tell what {path.name!r} is: give a POV-Ray scene (.pov), a mesh model "
                      f"(.obj .stl .ply ...) or a volume ({' '.join(VOLUME_SUFFIXES)}, a DICOM folder)")


def scene_content(path: Path, lens_array: LensArray, placement: Any = None, *,
                  include_dirs: tuple = (), use_cache: bool = True) -> Content:
    """The scene as the display sees it: the depth pass's hits in the frame ``render`` would use."""
    from ..renderer.passes.depth import depth_pass
    from ..renderer.methods.registry import get_method
    from ..renderer.methods.quality import RenderSettings
    from ..scene.scene import load_scene
    from ..renderer.placement.pose import PlacementOptions
    from ..renderer.placement.place import place_display
    from ..renderer.request import RenderRequest

    scene = load_scene(path, include_dirs)
    request = RenderRequest(source=path, display=Display(lens_array), output=Path("layout.png"),
                            settings=RenderSettings(use_cache=use_cache), include_dirs=include_dirs,
                            placement=placement or PlacementOptions())
    placed, record = place_display(request, scene)
    s = placed.settings
    units = record.units_per_mm if record.units_per_mm is not None else 1.0
    front_clearance = s.front_clearance or get_method(placed.method).default_front_clearance(lens_array)
    depth = depth_pass(scene, lens_array, s, front_clearance, units)
    points = depth_points(depth.z, depth.width_mm, depth.height_mm)
    faces = _grid_faces(depth.z, depth.width_mm / depth.z.shape[1], depth_budget_mm(lens_array))
    summary = depth.summary(depth_budget_mm(lens_array))
    warnings = list(record.warnings or ())
    if depth.unmeasured > 0.05:
        warnings.append(f"the depth pass could not measure {100 * depth.unmeasured:.0f} % of the field: the "
                        f"viewpoint is inside a solid object there (a plane or a box whose inside faces the "
                        f"viewer); declaring it 'hollow' lets the picture show it")
    entry = {**record.to_json(), "depth": summary, "warnings": warnings}
    return Content("scene", path.name, points, faces, points[:, 2], units_per_mm=units, record=entry)


def _grid_faces(z: np.ndarray, step: float, budget: float) -> np.ndarray:
    """Triangles between neighbouring hit pixels of a depth map, indices into ``depth_points``' order.

    A cell whose corners differ in depth by more than a few pixel widths (or a
    twentieth of the budget) spans a silhouette, not a surface, and is left open.
    """
    finite = np.isfinite(z)
    index = np.full(z.shape, -1, dtype=np.int64)
    index[finite] = np.arange(int(finite.sum()))
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]
    corners = np.stack([z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:]])
    with np.errstate(invalid="ignore"):   # NaN corners give NaN spreads, dropped below
        spread = corners.max(axis=0) - corners.min(axis=0)
    keep = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
    keep &= np.nan_to_num(spread, nan=np.inf) <= max(4 * step, budget / 20)
    tri = np.concatenate([np.stack([a[keep], c[keep], b[keep]], -1), np.stack([b[keep], c[keep], d[keep]], -1)])
    return tri.reshape(-1, 3)


def model_content(path: Path, lens_array: LensArray, *, depth: float | None = None, up: str | None = None,
                  rotate: Any = None, unit: str | None = None) -> Content:
    """The model's triangles, turned and placed as the default stage (``renderer.content.model``) places them."""
    from ..renderer.content.convert_mesh import model_bounds, turned_parts

    if not path.is_file():
        raise InputError(f"model file {str(path)!r} does not exist; check the path")
    _, parts, _, up, reason = turned_parts(path, unit=unit, up=up, rotate=rotate)
    lo, hi = model_bounds(parts)
    fit = fit_to_display(lo, hi, lens_array, depth=depth)
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    vertices = (np.concatenate([p.vertices for p in parts]) + fit.shift) * fit.scale
    faces = np.concatenate([p.faces + o for p, o in zip(parts, offsets)])
    record = {"up": up, "up_reason": reason, "triangles": len(faces),
              "fit": fit_record(fit, fill=FILL)}
    return Content("model", path.name, vertices, faces, _surface_z(vertices, faces), record=record)


def _surface_z(vertices: np.ndarray, faces: np.ndarray, count: int = 20000) -> np.ndarray:
    """``z`` of points spread evenly over the surface (by area, seeded): the share of a model
    outside the budget is a share of its surface, not of its vertices (a long triangle has three)."""
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    if not mesh.area > 0:
        return vertices[:, 2]
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=0)
    return np.asarray(points)[:, 2]


def volume_shape(volume: Any, iso: tuple[float, ...] | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """A coarse surface of what the volume holds, world mm (LPS), for the picture only.

    VTK's contour of the volume taken at every ``k``-th voxel (at most
    ``PREVIEW_VOXELS`` a side) at the ``iso`` values; without them, a label
    volume (integers) shows the boundary of its non-zero voxels and scalar data
    shows nothing.  Returns ``(vertices (n, 3), faces (m, 3))`` or None.
    """
    from .layout_picture import quiet_pyvista

    values = np.asarray(volume.values)
    if iso is None:
        if not np.issubdtype(values.dtype, np.integer):
            return None
        values, iso = (values != 0).astype(np.float32), (0.5,)
    else:
        lo, hi = volume.value_range()
        wrong = [v for v in iso if not lo <= v <= hi]
        if wrong:
            raise ConfigError(f"{param('iso')} {wrong[0]:g} is outside the volume's values, {lo:g} .. {hi:g}")
    step = max(1, -(-max(values.shape) // PREVIEW_VOXELS))
    values = np.ascontiguousarray(values[::step, ::step, ::step], dtype=np.float32)
    pv = quiet_pyvista()
    grid = pv.ImageData(dimensions=values.shape, spacing=tuple(step * np.asarray(volume.spacing, dtype=float)))
    grid.point_data["v"] = values.ravel(order="F")   # i fastest, as VTK stores a grid
    surface = grid.contour(list(iso), scalars="v").triangulate()
    if surface.n_points == 0 or surface.n_cells == 0:
        return None
    # grid points are spacing * (i, j, k): world = origin + direction @ that
    world = np.asarray(surface.points, dtype=np.float64) @ np.asarray(volume.direction, dtype=float).T + volume.origin
    return world, surface.faces.reshape(-1, 4)[:, 1:].astype(np.int64)


def volume_content(volume: Any, lens_array: LensArray, *, orientation: str = "coronal", rotate: Any = None,
                   depth: float | None = None, iso: tuple[float, ...] | None = None) -> Content:
    """A volume's physical box, turned by the orientation preset and ``rotate``, fitted to the display,
    with a coarse surface of what it holds (``volume_shape``)."""
    from ..renderer.content.volume import place_volume

    _, fit, m = place_volume(volume, lens_array, orientation, rotate, depth)
    box = volume.corners() @ m[:3, :3].T + m[:3, 3]
    centre = box.mean(axis=0)
    # The patient's directions (LPS: +x left, +y posterior, +z superior) at the box's faces.
    half = np.abs((box - centre) @ np.linalg.inv(m[:3, :3]).T).max(axis=0)
    marks = []
    for label, axis, sign in (("L", 0, 1), ("R", 0, -1), ("A", 1, -1), ("P", 1, 1), ("S", 2, 1), ("I", 2, -1)):
        world = np.zeros(3)
        world[axis] = sign * half[axis] * 1.08
        marks.append((label, centre + m[:3, :3] @ world))
    zs = np.linspace(box[:, 2].min(), box[:, 2].max(), 1001)   # the box's depth, evenly
    vertices, faces = np.empty((0, 3)), np.empty((0, 3), dtype=np.int64)
    shape = volume_shape(volume, iso)
    if shape is not None:
        vertices, faces = shape[0] @ m[:3, :3].T + m[:3, 3], shape[1]
    record = {"volume": volume.as_record(), "orientation": orientation, "rotate": list(rotate) if rotate else None,
              "world_to_display": m.round(12).tolist(), "shape": "iso" if iso else ("labels" if shape else None),
              "fit": fit_record(fit)}
    return Content("volume", volume.name, vertices, faces, zs, box=box, marks=marks, record=record)


def read_volume_content(path: Path, lens_array: LensArray, *, spacing: Any = None, series: str | None = None,
                        **options: Any) -> Content:
    """Read a volume file or DICOM folder (``volume.read``) and place it (``volume_content``)."""
    if not path.exists():
        raise InputError(f"volume {str(path)!r} does not exist; check the path")
    try:
        from ..volume.read import read_volume
    except ImportError:
        raise ConfigError(f"reading volumes ({path.name}) is not available in this povh3d; "
                          "give a scene or a mesh model") from None
    from ..renderer.content.volume import volume_weigher

    return volume_content(read_volume(path, spacing=spacing, series=series, weigh=volume_weigher(path)), lens_array,
                          **options)


def picture_size(size: tuple[int, int]) -> tuple[int, int]:
    w, h = (int(v) for v in size)
    if not (MIN_SIZE <= w <= MAX_SIZE and MIN_SIZE <= h <= MAX_SIZE):
        raise ConfigError(f"{param('size')} takes WxH pixels, each from {MIN_SIZE} to {MAX_SIZE}, got {w}x{h}")
    return w, h


def figures(content: Content, setup: SetUp) -> dict[str, Any]:
    """The content's depth against the budget, as the legend and the sidecar give it."""
    out = {**depth_figures(content.z_samples, setup.budget_mm), "counted": COUNTED[content.kind]}
    if out["points"] and len(content.vertices):   # the reach is the vertices' (samples miss the tips)
        z = np.concatenate([content.z_samples, content.vertices[:, 2]])
        out.update(near_mm=float(z.min()), far_mm=float(z.max()), depth_mm=float(z.max() - z.min()))
    return out


def write_layout(content: Content, lens_array: LensArray, output: str | Path, *, display: Display | None = None,
                 size: tuple[int, int] = (1200, 900), content_seconds: float = 0.0) -> dict[str, Any]:
    """Draw ``content`` with the display's set-up into ``output`` (PNG and sidecar); returns the record."""
    from .layout_picture import draw

    start = time.perf_counter()
    output = png_output(output)
    size = picture_size(size)
    setup = set_up(lens_array, depth_budget_mm(lens_array))
    numbers = figures(content, setup)
    described = display.as_record()["display"] if display is not None else {}
    image = draw(content, setup, lens_array, numbers, size=size, display=described)
    record = base_record("layout", lens_array, display=described, content={
        "kind": content.kind, "name": content.name, **content.record}, setup=setup.as_record(),
        content_depth=numbers, units_per_mm=content.units_per_mm, size_px=list(size),
        timings={"content_seconds": round(content_seconds, 3),
                 "picture_seconds": round(time.perf_counter() - start, 3)})
    write_image(output, image, record)
    return record.to_json()


def find_content(source: Path, lens_array: LensArray, *, placement: Any = None, include_dirs: tuple = (),
                 model: dict | None = None, volume: dict | None = None, use_cache: bool = True) -> Content:
    """The scene, model or volume at ``source``, placed on the display as ``render`` places it."""
    kind = source_kind(source)
    if kind == "scene":
        return scene_content(source, lens_array, placement, include_dirs=include_dirs, use_cache=use_cache)
    if kind == "model":
        return model_content(source, lens_array, **(model or {}))
    return read_volume_content(source, lens_array, **(volume or {}))


def content_report(source: str | Path, lens_array: LensArray) -> dict[str, Any]:
    """``povh3d info MODEL|VOLUME``: how the default stage places it, and its depth against the budget."""
    content = find_content(Path(source), lens_array)
    setup = set_up(lens_array, depth_budget_mm(lens_array))
    return {"content": str(source), "kind": content.kind, "fit": content.record.get("fit"),
            "depth": figures(content, setup), "depth_budget_mm": setup.budget_mm,
            "warnings": content.record.get("warnings", [])}


def layout(source: str | Path, output: str | Path, lens_array: LensArray, *, display: Display | None = None,
           placement: Any = None, include_dirs: tuple = (), model: dict | None = None,
           volume: dict | None = None, size: tuple[int, int] = (1200, 900), use_cache: bool = True) -> dict[str, Any]:
    """``povh3d layout SOURCE``: the content found, placed and drawn with the set-up (returns the record).

    ``model``: ``depth``, ``up``, ``rotate``, ``unit``; ``volume``: ``orientation``,
    ``rotate``, ``depth``, ``spacing``, ``series``.  The output is checked before any work.
    """
    start = time.perf_counter()
    from ..scene.scene import load_scene

    source = Path(source)
    reads = (source, *(load_scene(source, include_dirs).files if source_kind(source) == "scene" else ()))
    png_output(output, inputs=reads)
    picture_size(size)
    content = find_content(source, lens_array, placement=placement, include_dirs=include_dirs,
                           model=model, volume=volume, use_cache=use_cache)
    record = write_layout(content, lens_array, output, display=display, size=size,
                          content_seconds=time.perf_counter() - start)
    for message in record["content"].get("warnings", []):   # the one channel: the command line prints them
        warn(message)
    return record
