"""``render --dataset DIR`` and ``povh3d dataset H3D.png -o DIR``: a render's views and depth in the
HCI 4D light-field benchmark layout (``dataset.hci.write_hci``; docs/datasets.md).

The views are the render's camera bank; the depth is the render's depth pass along each view's
ray (``engine.depth.view_depth_maps``: mm of the display frame from the screen, negative in
front, NaN where nothing is hit), which is what ``write_hci`` takes.  From an existing render the
depth pass is made again from its sidecar: the scene, the display frame and the front clearance
it was rendered with.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.hci import BankGeometry, centre_camera, write_hci
from ..errors import ConfigError, InputError, OutputError
from ..geometry.lens_array import LensArray
from ..image.interleave import extract
from ..image.io import read_png, read_sidecar


def bank_geometry(lens_array: LensArray) -> BankGeometry:
    """What the HCI export needs of a lens array with a camera bank (odd views each way)."""
    views = lens_array.require_views()
    centre_camera(views)      # HCI's centre camera is the centre only of an odd grid: refuse before work
    return BankGeometry(lens_array.panel.pitch_x, lens_array.pitch_x, lens_array.focal, views)


def check_dataset_dir(folder: Path, lens_array: LensArray, *, mapped: bool = False) -> None:
    """Before any work: an unmapped bank that fits HCI's layout, and ``folder`` holding no dataset."""
    if mapped:
        raise ConfigError("--dataset exports the camera bank's views; drop --mapping (map the image afterwards)")
    bank_geometry(lens_array)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"--dataset {str(folder)!r} is a file; give a folder")
    if (folder / "input_Cam000.png").exists() or (folder / "parameters.cfg").exists():
        raise OutputError(f"{str(folder)!r} already holds a dataset; give an empty or new folder")


def write_dataset(folder: Path, h3d: np.ndarray, lens_array: LensArray, ray_depth: np.ndarray, *,
                  all_views: bool = False, scene: str = "povh3d") -> list[Path]:
    """The HCI folder of an H3D image of ``lens_array`` and its per-view ray depth (mm)."""
    geometry = bank_geometry(lens_array)
    bank = extract(h3d[lens_array.bank_region], geometry.views)[..., :3]
    return write_hci(folder, bank, ray_depth, geometry, all_views=all_views, scene=scene)


def dataset_from_render(h3d_path: str | Path, folder: str | Path, *, all_views: bool = False) -> list[Path]:
    """``povh3d dataset``: the HCI folder of an existing render, its depth pass made again from its
    sidecar (scene, display frame, front clearance, depth scale)."""
    from ..engine.depth import view_depth_maps
    from ..engine.quality import RenderSettings
    from ..geometry.frame import DisplayFrame
    from ..scene.scene import load_scene
    from .display_setup import Display

    record = read_sidecar(h3d_path)
    if not record or "lens_array" not in record:
        raise InputError(f"{str(h3d_path)!r} has no sidecar with its lens array; render it with povh3d, or use "
                         "render --dataset")
    if record.get("kind") != "h3d" or record.get("quilt"):
        what = "a mapped panel image" if record.get("kind") == "panel" else "not an H3D image of a camera bank"
        if record.get("quilt"):
            what = "a Looking Glass render (its views span the device's cone in even count)"
        raise ConfigError(f"{str(h3d_path)!r} is {what}; render an odd number of views without --mapping "
                          "and export that")
    lens_array = Display.from_record(record).lens_array
    folder = Path(folder)
    check_dataset_dir(folder, lens_array)
    h3d = read_png(h3d_path)
    if h3d.shape[:2] != (lens_array.panel.height, lens_array.panel.width):
        raise InputError(f"{str(h3d_path)!r} is {h3d.shape[1]}x{h3d.shape[0]} but its sidecar describes a "
                         f"{lens_array.panel.width}x{lens_array.panel.height} panel; render it again")
    scene_path = Path(record.get("scene", ""))
    if not scene_path.is_file():
        raise InputError(f"the scene {str(scene_path)!r} the sidecar names is gone; the depth pass needs it: "
                         "render again with --dataset")
    frame_record = record.get("display_frame") or {}
    frame = _frame(frame_record, DisplayFrame)
    settings = RenderSettings(quality="draft", frame=frame, depth_scale=float(frame_record.get("depth_scale", 1.0)))
    depth = view_depth_maps(load_scene(scene_path), lens_array, settings, record["quality"]["front_clearance_mm"],
                            float(frame_record.get("units_per_mm", 1.0)))
    return write_dataset(folder, h3d, lens_array, depth, all_views=all_views, scene=scene_path.stem)


def _frame(record: dict[str, Any], frame_type: Any) -> tuple[float, ...] | None:
    """The POV-Ray matrix of the sidecar's display frame (None: native)."""
    if "matrix" in record:
        return tuple(float(v) for v in record["matrix"])
    if not record or record.get("source") == "native":
        return None
    frame = frame_type(tuple(record["centre"]), tuple(record["axis_x"]), tuple(record["axis_y"]),
                       tuple(record["normal"]), float(record["units_per_mm"]))
    return None if frame.is_native else tuple(frame.matrix().ravel().tolist())
