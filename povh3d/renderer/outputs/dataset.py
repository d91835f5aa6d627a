"""``render --dataset DIR`` and ``povh3d dataset H3D.png -o DIR``: a render's views and depth in the
HCI 4D light-field benchmark layout (``dataset.hci.write_hci``; docs/datasets.md).

The views are those ``extract`` writes (the camera bank, or each lens resampled at the view offsets;
a hex array's then interpolated onto the grid of its lens columns, ``export_grid``); the depth is
the render's depth pass along the ray of each exported pixel (``renderer.passes.depth.view_depth_maps``:
display mm from the screen, negative in front, NaN where nothing is hit), which is
what ``write_hci`` takes.  From an existing render the
depth pass is made again from its sidecar: the scene, the placement and the front clearance
it was rendered with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...dataset.hci import BankGeometry, centre_camera, write_hci
from ...errors import ConfigError, InputError, OutputError, param, warn
from ...geometry.lens_array import LensArray
from ...image.colour import decode, encode
from ...geometry.rays import cell_contains
from ...image.elemental import view_grid, view_offsets
from ...image.io import check_output_folder, read_png, read_sidecar_record, with_sidecar
from ...image.sidecar import PlacementRecord


@dataclass(frozen=True)
class ExportGrid:
    """Where the exported views' pixels sit: ``cols x rows`` on a rectangular grid of pitch
    ``pitch_x x pitch_y`` mm centred on the origin, and the views ``(Ny, Nx)`` each way."""

    views: tuple[int, int]
    cols: int
    rows: int
    pitch_x: float
    pitch_y: float
    resampled: bool       # hex: the views interpolated from the lens centres onto the grid

    @property
    def depth_grid(self) -> tuple[int, int, float, float]:
        """``view_depth_maps``' ``grid``: the rays of the exported pixels."""
        return (self.cols, self.rows, self.pitch_x, self.pitch_y)


def export_grid(lens_array: LensArray) -> ExportGrid:
    """The views ``extract`` reads and the rectangular grid HCI's images need (docs/datasets.md).

    A camera bank and a fractional-PPL square or lenticular array: one pixel per lens centre,
    which already sit on a grid.  Hex: odd lens rows sit half a pitch right and rows are
    ``p sqrt(3)/2`` apart, so the views are interpolated onto the square grid of the lens
    columns (pitch ``p`` both ways, HCI's one disparity for both axes)."""
    la = lens_array
    if la.views is not None:
        centre_camera(la.views)   # HCI's centre camera is the centre only of an odd grid: refuse before work
        return ExportGrid(la.views, la.lenses_x, la.lenses_y, la.pitch_x, la.pitch_y, False)
    if la.grid == "lattice" or la.rotation:
        what = f"a slanted sheet's ({param('lens_rotation')})" if la.rotation else f"a {param('lattice')} array's"
        raise ConfigError(f"the HCI layout needs views on the screen's rows and columns, and {what} lenses lean "
                          f"off them; export an unslanted square, lenticular or hex render ({param('lens_rotation')} 0), or "
                          "take its views with 'povh3d extract'")
    views = view_grid(la)
    if views[0] % 2 == 0 or views[1] % 2 == 0:
        ny, nx = views
        raise ConfigError(f"the HCI toolkit's centre camera is the centre only of an odd grid, and this "
                          f"{la.grid} array's {la.ppl_x:g} pixels per lens give {nx}x{ny} views (extract's: "
                          f"whole pixels, rounded); render with an odd {param('ppl')}, e.g. 5 or 7")
    if la.grid != "hex":
        return ExportGrid(views, la.lenses_x, la.lenses_y, la.pitch_x, la.pitch_y, False)
    # Lx - 1 columns centred on the origin are the odd rows' lens centres, halfway between the even
    # rows'; rows p apart within the outer lens rows: every grid pixel lies between lenses of both rows.
    rows = math.floor((la.lenses_y - 1) * la.pitch_y / la.pitch_x + 1 + 1e-9)
    if la.lenses_x < 2 or la.lenses_y < 2:
        raise ConfigError("the HCI export resamples a hex array between its lenses and needs at least 2x2 of them; "
                          f"render more lenses ({param('lenses')})")
    return ExportGrid(views, la.lenses_x - 1, rows, la.pitch_x, la.pitch_x, True)


def cameras_outside_cell(lens_array: LensArray, views: tuple[int, int]) -> list[int]:
    """HCI cameras whose view offset lies outside the lens cell (a hex cell's corners): ``extract``
    reads the lens's nearest pixel there, not the view's ray (``elemental.extract_views``)."""
    ny, nx = views
    u, v = view_offsets(lens_array, views)
    inside = cell_contains(lens_array.grid, lens_array.pitch_x, lens_array.pitch_y, u[None, :], v[:, None])
    return [r * nx + c for r in range(ny) for c in range(nx) if not inside[ny - 1 - r, nx - 1 - c]]


def bank_geometry(lens_array: LensArray) -> BankGeometry:
    """What the HCI export needs of a lens array: the view step, the exported pixels' pitch, ``f``."""
    grid = export_grid(lens_array)
    return BankGeometry(lens_array.panel.pitch_x, grid.pitch_x, lens_array.focal, grid.views)


def export_views(h3d: np.ndarray, lens_array: LensArray) -> np.ndarray:
    """``(Ny, Nx, rows, cols, 3)`` views of an H3D image on its ``export_grid``: ``extract``'s views
    (``sidecar_bank``), a hex array's interpolated onto the grid of lens columns."""
    from .views import sidecar_bank

    grid = export_grid(lens_array)
    views = sidecar_bank(h3d, lens_array)[..., :3]
    return hex_onto_grid(views, lens_array, grid) if grid.resampled else views


def hex_onto_grid(views: np.ndarray, lens_array: LensArray, grid: ExportGrid) -> np.ndarray:
    """Hex views (one sample per lens centre) on the rectangular ``grid``, in linear light: along
    each of the two lens rows around a grid row, linearly between the row's lens centres (odd rows
    half a pitch right), then linearly between the rows (``export_grid`` keeps every grid pixel
    between lenses of both rows: nothing is extrapolated)."""
    la = lens_array
    xs = (np.arange(grid.cols) + 0.5 - grid.cols / 2) * grid.pitch_x
    ys = (grid.rows / 2 - np.arange(grid.rows) - 0.5) * grid.pitch_y
    t = la.lenses_y / 2 - 0.5 - ys / la.pitch_y            # fractional lens row of each grid row
    i0 = np.clip(np.floor(t).astype(np.int64), 0, max(la.lenses_y - 2, 0))
    ft = np.clip(t - i0, 0.0, 1.0)
    taps = []    # per lens row around a grid row: its weight, the row, two lens columns and their weight
    for r, w in ((i0, 1.0 - ft), (np.minimum(i0 + 1, la.lenses_y - 1), ft)):
        col = xs[None, :] / la.pitch_x + la.lenses_x / 2 - 0.5 - (r % 2)[:, None] * 0.5
        j0 = np.clip(np.floor(col).astype(np.int64), 0, max(la.lenses_x - 2, 0))
        taps.append((w[:, None, None], r[:, None], j0, np.minimum(j0 + 1, la.lenses_x - 1),
                     np.clip(col - j0, 0.0, 1.0)[..., None]))
    out = np.empty(views.shape[:2] + (grid.rows, grid.cols, views.shape[-1]), views.dtype)
    for l in range(views.shape[0]):
        for k in range(views.shape[1]):     # one view at a time: a large panel's stack in floats is GBs
            lin = decode(views[l, k])
            value = sum(w * ((1.0 - fj) * lin[r, j0] + fj * lin[r, j1]) for w, r, j0, j1, fj in taps)
            out[l, k] = encode(value, views.dtype)
    return out


def check_dataset_dir(folder: Path, lens_array: LensArray, *, mapped: bool = False) -> None:
    """Before any work: an unmapped bank that fits HCI's layout, and ``folder`` holding no dataset."""
    if mapped:
        raise ConfigError(f"{param('dataset')} exports the camera bank's views; drop {param('mapping')} (map the image afterwards)")
    bank_geometry(lens_array)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{param('dataset')} {str(folder)!r} is a file; give a folder")
    if (folder / "input_Cam000.png").exists() or (folder / "parameters.cfg").exists():
        raise OutputError(f"{str(folder)!r} already holds a dataset; give an empty or new folder")


def dataset_depth(scene: Any, lens_array: LensArray, settings: Any, front_clearance: float,
                  units_per_mm: float, progress: Any = None) -> np.ndarray:
    """The depth pass along the rays of the exported pixels (``export_grid``): ``(Ny, Nx, rows, cols)``
    mm along each ray from the screen (``renderer.passes.depth.view_depth_maps``; ``progress(done, total)``
    its frames)."""
    from ..passes.depth import view_depth_maps

    grid = export_grid(lens_array)
    return view_depth_maps(scene, lens_array, settings, front_clearance, units_per_mm, views=grid.views,
                           grid=grid.depth_grid, progress=progress, name="dataset-depth")


def write_dataset(folder: Path, h3d: np.ndarray, lens_array: LensArray, ray_depth: np.ndarray, *,
                  all_views: bool = False, scene: str = "povh3d") -> list[Path]:
    """The HCI folder of an H3D image of ``lens_array`` and its per-view ray depth (mm)."""
    geometry = bank_geometry(lens_array)
    if not np.isfinite(ray_depth).any():   # never a silent all-NaN ground truth
        warn(f"the ground truth in {str(folder)!r} (gt_disp_lowres.pfm, gt_depth_lowres.pfm) is all NaN: the depth "
             "pass measured no pixel (nothing in the field, or every ray starts inside a solid); check the scene "
             "and the placement")
    bank = export_views(h3d, lens_array)
    meta = {}
    if lens_array.views is None:
        outside = cameras_outside_cell(lens_array, geometry.views)
        meta = {"povh3d_views": "resampled (docs/datasets.md)",
                "povh3d_cameras_outside_lens_cell": ",".join(map(str, outside)) or "none"}
    return write_hci(folder, bank, ray_depth, geometry, all_views=all_views, scene=scene, meta=meta)


def dataset_from_render(h3d_path: str | Path, folder: str | Path, *, all_views: bool = False) -> list[Path]:
    """``povh3d dataset``: the HCI folder of an existing render, its depth pass made again from its
    sidecar (scene, placement, front clearance, depth scale)."""
    from ..methods.quality import RenderSettings
    from ..placement.pose import recorded_pose
    from ...scene.scene import load_scene
    from ...display.display import Display

    record = read_sidecar_record(h3d_path)
    if record is None or record.lens_array is None:
        raise InputError(f"{str(h3d_path)!r} has no sidecar with its lens array; render it with povh3d, or use "
                         f"render {param('dataset')}")
    if record.kind != "h3d" or record.quilt:
        what = "a mapped panel image" if record.kind == "panel" else "not an H3D image of a camera bank"
        if record.quilt:
            what = "a Looking Glass render (its views span the device's cone in even count)"
        raise ConfigError(f"{str(h3d_path)!r} is {what}; render an odd number of views without {param('mapping')} "
                          "and export that")
    lens_array = Display.from_record(record.to_json()).lens_array
    folder = Path(folder)
    check_dataset_dir(folder, lens_array)
    scene_path = Path(record.scene or "")
    reads = (*with_sidecar(h3d_path), *(load_scene(scene_path).files if scene_path.is_file() else ()))
    check_output_folder(folder, reads, what="dataset folder")
    h3d = read_png(h3d_path)
    if h3d.shape[:2] != (lens_array.panel.height, lens_array.panel.width):
        raise InputError(f"{str(h3d_path)!r} is {h3d.shape[1]}x{h3d.shape[0]} but its sidecar describes a "
                         f"{lens_array.panel.width}x{lens_array.panel.height} panel; render it again")
    if not scene_path.is_file():
        raise InputError(f"the scene {str(scene_path)!r} the sidecar names is gone; the depth pass needs it: "
                         f"render again with {param('dataset')}")
    placed = record.placement or PlacementRecord()
    pose = recorded_pose(placed.to_json())
    scale = placed.get("depth_scale", 1.0)
    settings = RenderSettings(quality="draft", pose=pose,
                              depth_scale=float(scale) if isinstance(scale, (int, float)) else 1.0)
    clearance = record.quality.front_clearance_mm if record.quality is not None else None
    if clearance is None:
        raise InputError(f"the sidecar of {str(h3d_path)!r} has no quality.front_clearance_mm; render it again "
                         f"with {param('dataset')}")
    depth = dataset_depth(load_scene(scene_path), lens_array, settings, clearance,
                          placed.units_per_mm if placed.units_per_mm is not None else 1.0)
    return write_dataset(folder, h3d, lens_array, depth, all_views=all_views, scene=scene_path.stem)
