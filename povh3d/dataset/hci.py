"""The HCI 4D light-field benchmark layout (Honauer et al., ACCV 2016) from a camera bank.

A folder holds ``input_Cam000.png`` ... (camera ``r * num_cams_x + c``, row ``r`` from the
top, column ``c`` from the left, as the toolkit's ``read_lightfield`` indexes them),
``parameters.cfg`` (sections ``intrinsics``, ``extrinsics``, ``meta`` with every key the
toolkit's ``read_parameters`` reads), and for the centre camera
(``int(num_cams_x * num_cams_y / 2)``, the toolkit's ``get_center_cam``)
``gt_disp_lowres.pfm`` and ``gt_depth_lowres.pfm``.

Our views are orthographic: bank view ``(l, k)`` looks along ``normalize(u_k, v_l, f)``
and samples the display plane at the lens centres (lens pitch ``p``).  A point at depth
``z`` lies on the ray through lens centre ``x = X - u_k z / f``; one view step
(``u_k`` grows by ``s``) moves it by ``-z s / f`` mm, ``-z s / (f p)`` view pixels.
The viewer of view ``k`` stands at ``-u_k``, so HCI's camera column ``c`` (left to right)
is ``k = Nx - 1 - c`` and row ``r`` (top to bottom) is ``l = Ny - 1 - r``; a point then
moves by ``+z s / (f p)`` pixels per camera step to the right.  HCI's disparity ``d``
moves it by ``-d`` (its ``depth2disp`` makes ``d > 0`` nearer than the focus plane, and
a camera stepping right sees a near point step left), so

    d = -z s / (f p)        (pixels per view step; z < 0, in front of the screen: d > 0)

The depth file holds HCI's Z: the distance, in metres, from the plane of an equivalent
camera array ``viewing_distance_mm`` in front of the screen, ``(D + z) / 1000``.
``parameters.cfg`` describes that equivalent pinhole array (baseline ``D s / f``,
focus at the screen); its ``depth2disp`` agrees with the disparity file to first order
in ``z / D`` -- the disparity file is the exact one.
"""

from __future__ import annotations

import math
from typing import Any
from dataclasses import dataclass
from datetime import date
from pathlib import Path

import numpy as np

from ..errors import ConfigError, OutputError, param
from ..image.io import atomic_path, write_png
from ..image.pfm import write_pfm

FOCAL_MM = 100.0      # the equivalent camera's focal length (the benchmark's scenes use 100 mm)


@dataclass(frozen=True)
class BankGeometry:
    """What the export needs of the lens array.

    pixel_pitch : float   s, panel pixel pitch (mm): one view step of u or v
    lens_pitch : float    p, lens pitch (mm): one view pixel on the display plane
    focal : float         f, lens focal length (mm)
    views : (ny, nx)      views per lens vertically, horizontally
    viewing_distance_mm : float   D, where the equivalent camera array stands
    """

    pixel_pitch: float
    lens_pitch: float
    focal: float
    views: tuple[int, int]
    viewing_distance_mm: float = 1000.0

    def __post_init__(self) -> None:
        for name in ("pixel_pitch", "lens_pitch", "focal", "viewing_distance_mm"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"{name} must be a positive number (mm), got {v!r}")
        ny, nx = self.views
        if ny < 1 or nx < 1:
            raise ConfigError(f"the bank needs at least one view each way, got {ny}x{nx}")

    @property
    def disparity_per_mm(self) -> float:
        """HCI disparity (view pixels per view step) of a point per mm of depth z: ``-s / (f p)``."""
        return -self.pixel_pitch / (self.focal * self.lens_pitch)

    def offsets(self, l: int, k: int) -> tuple[float, float]:
        """``(u_k, v_l)`` of bank view ``(l, k)``, mm (conventions: multi-orthographic bank)."""
        ny, nx = self.views
        return ((k + 0.5 - nx / 2) * self.pixel_pitch, (ny / 2 - l - 0.5) * self.pixel_pitch)


def to_hci_order(bank: np.ndarray) -> np.ndarray:
    """``(Ny, Nx, ...)`` bank -> ``(Ny * Nx, ...)`` HCI cameras: Cam000 top-left, row-major."""
    return np.ascontiguousarray(bank[::-1, ::-1]).reshape(-1, *bank.shape[2:])


def centre_camera(views: tuple[int, int]) -> tuple[int, int, int]:
    """HCI's centre camera index and its bank view ``(l, k)``; the grid must be odd each way."""
    ny, nx = views
    if ny % 2 == 0 or nx % 2 == 0:
        raise ConfigError(f"the HCI toolkit takes camera num_cams_x * num_cams_y // 2 as the centre view, which "
                          f"is the centre only of an odd grid, not {nx}x{ny} views; render an odd count each way, "
                          f"e.g. {param('ppl')} {nx | 1}x{ny | 1}")
    cam = int(nx * ny / 2)
    r, c = divmod(cam, nx)
    return cam, ny - 1 - r, nx - 1 - c


def z_from_ray_depth(t: np.ndarray, u: float, v: float, focal: float) -> np.ndarray:
    """Display depth ``z`` (mm) of points ``t`` mm along the ray ``normalize(u, v, f)``
    from the display plane (NaN stays NaN)."""
    return np.asarray(t, float) * focal / math.sqrt(u * u + v * v + focal * focal)


def disparity(z: np.ndarray, geometry: BankGeometry) -> np.ndarray:
    """HCI disparity (pixels per view step, positive in front of the screen) of depth ``z`` mm."""
    return np.asarray(z, float) * geometry.disparity_per_mm


def hci_depth_m(z: np.ndarray, geometry: BankGeometry) -> np.ndarray:
    """HCI's Z depth, metres from the equivalent camera plane ``D`` mm in front of the screen."""
    return (geometry.viewing_distance_mm + np.asarray(z, float)) / 1000.0


def parameters_cfg(geometry: BankGeometry, shape: tuple[int, int], disp_range: tuple[float, float], *,
                   scene: str = "povh3d", meta: dict[str, str] | None = None) -> str:
    """``parameters.cfg`` text with every key the HCI toolkit's ``read_parameters`` reads.

    shape : (height, width) of a view, pixels.
    meta : more ``[meta]`` keys (the toolkit reads only its own).
    """
    h, w = shape
    ny, nx = geometry.views
    d_mm = geometry.viewing_distance_mm
    # the equivalent pinhole array: cameras D s / f apart, the screen filling the sensor's long side
    sensor = FOCAL_MM * max(w, h) * geometry.lens_pitch / d_mm
    lo, hi = disp_range
    return "\n".join([
        "[intrinsics]",
        f"focal_length_mm = {FOCAL_MM!r}",
        f"image_resolution_x_px = {w}",
        f"image_resolution_y_px = {h}",
        f"sensor_size_mm = {sensor!r}",
        "fstop = 100.0",
        "",
        "[extrinsics]",
        f"num_cams_x = {nx}",
        f"num_cams_y = {ny}",
        f"baseline_mm = {d_mm * geometry.pixel_pitch / geometry.focal!r}",
        f"focus_distance_m = {d_mm / 1000.0!r}",
        "center_cam_x_m = 0.0", "center_cam_y_m = 0.0", f"center_cam_z_m = {-d_mm / 1000.0!r}",
        "center_cam_rx_rad = 0.0", "center_cam_ry_rad = 0.0", "center_cam_rz_rad = 0.0",
        "",
        "[meta]",
        f"scene = {scene}",
        "category = povh3d",
        f"date = {date.today().isoformat()}",
        "version = povh3d orthographic bank",
        "authors = povh3d",
        "contact = none",
        f"disp_min = {lo!r}",
        f"disp_max = {hi!r}",
        f"frustum_disp_min = {lo!r}",
        f"frustum_disp_max = {hi!r}",
        "depth_map_scale = 1.0",
        *(f"{k} = {v}" for k, v in (meta or {}).items()),
        "",
    ])


def write_hci(folder: str | Path, bank: np.ndarray, ray_depth: np.ndarray, geometry: BankGeometry, *,
              all_views: bool = False, scene: str = "povh3d", meta: dict[str, str] | None = None) -> list[Path]:
    """Write the HCI layout of a camera bank into ``folder`` (created if missing).

    bank : (Ny, Nx, H, W, 3) uint8 or uint16 views, bank order (conventions)
    ray_depth : (Ny, Nx, H, W) float, mm along each view's ray from the display plane
                (positive behind the screen), NaN where nothing is hit
    all_views : also ``gt_disp_lowres_CamNNN.pfm`` / ``gt_depth_lowres_CamNNN.pfm`` per camera
    meta : more ``[meta]`` keys for ``parameters.cfg``

    Every file is checked before any is written; existing files are refused, not replaced.
    Returns the paths written.
    """
    ny, nx = geometry.views
    if bank.ndim != 5 or bank.shape[:2] != (ny, nx) or bank.shape[4] != 3:
        raise ConfigError(f"the views are {bank.shape[:2]} of shape {bank.shape[2:]} but the geometry has "
                          f"{ny}x{nx} views of RGB; check the bank")
    if ray_depth.shape != bank.shape[:4]:
        raise ConfigError(f"the depth maps are {ray_depth.shape}, the views {bank.shape[:4]}: they must match")
    cam, lc, kc = centre_camera(geometry.views)
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{str(folder)!r} is a file; give a folder for the dataset")

    def z_of(l: int, k: int) -> np.ndarray:
        u, v = geometry.offsets(l, k)
        return z_from_ray_depth(ray_depth[l, k], u, v, geometry.focal)

    z_centre = z_of(lc, kc)
    disp = disparity(z_centre, geometry)
    finite = disp[np.isfinite(disp)]
    disp_range = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 0.0)
    files: dict[Path, tuple[str, Any]] = {}  # (kind, payload): an image, a depth map or text
    for i, view in enumerate(to_hci_order(bank)):
        files[folder / f"input_Cam{i:03d}.png"] = ("png", view)
    files[folder / "parameters.cfg"] = ("text", parameters_cfg(geometry, bank.shape[2:4], disp_range, scene=scene,
                                                                  meta=meta))
    files[folder / "gt_disp_lowres.pfm"] = ("pfm", disp)
    files[folder / "gt_depth_lowres.pfm"] = ("pfm", hci_depth_m(z_centre, geometry))
    if all_views:
        for i in range(ny * nx):
            r, c = divmod(i, nx)
            z = z_of(ny - 1 - r, nx - 1 - c)
            files[folder / f"gt_disp_lowres_Cam{i:03d}.pfm"] = ("pfm", disparity(z, geometry))
            files[folder / f"gt_depth_lowres_Cam{i:03d}.pfm"] = ("pfm", hci_depth_m(z, geometry))
    taken = [p.name for p in files if p.exists()]
    if taken:
        raise OutputError(f"{str(folder)!r} already holds {taken[0]}{' and more' if len(taken) > 1 else ''}; "
                          "give an empty or new folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"cannot create {str(folder)!r}: {exc.strerror}") from None
    for path, (kind, payload) in files.items():
        if kind == "png":
            write_png(path, payload)
        elif kind == "pfm":
            write_pfm(path, payload)
        else:
            with atomic_path(path) as tmp:
                tmp.write_text(payload, encoding="utf-8")
    return list(files)
