"""A folder of DICOM slices as a ``Volume``, through pydicom.

VTK's DICOM reader takes the first series it meets and ignores the slice
orientation; here every file's header is read (without pixels), the files are
grouped by ``SeriesInstanceUID``, and one series is chosen: the only one, or
the one ``--series UID`` names.  Its slices are sorted along the slice normal
(``ImageOrientationPatient``'s row x column direction) by
``ImagePositionPatient``; the spacing between slices comes from those
positions (``SliceThickness`` is not a spacing), and must be even.

DICOM's patient frame is LPS already.  ``PixelSpacing`` is (between rows,
between columns): the column spacing is the ``i`` spacing.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, param
from .grid import Volume


def _headers(folder: Path) -> list[tuple[Path, Any]]:  # Any: pydicom's Dataset (an optional extra)
    from ..extras import require

    pydicom = require("pydicom", "volume", "a DICOM folder")
    from pydicom.errors import InvalidDicomError

    found = []
    for path in sorted(p for p in folder.iterdir() if p.is_file()):
        try:
            ds = pydicom.dcmread(path, stop_before_pixels=True)
        except (InvalidDicomError, OSError, EOFError, ValueError):
            continue  # not a DICOM file (a DICOMDIR's siblings, notes): skipped
        if "ImagePositionPatient" in ds and "SeriesInstanceUID" in ds:
            found.append((path, ds))
    return found


def list_series(folder: Path) -> dict[str, list[tuple[Path, Any]]]:
    """Image slices of ``folder`` grouped by series UID."""
    groups: dict[str, list[tuple[Path, Any]]] = {}
    for path, ds in _headers(folder):
        groups.setdefault(str(ds.SeriesInstanceUID), []).append((path, ds))
    return groups


def _describe(uid: str, slices: list) -> str:
    description = str(getattr(slices[0][1], "SeriesDescription", "") or "no description")
    return f"{uid} ({description}, {len(slices)} slices)"


def series_size(slices: list) -> tuple[int, int]:
    """Voxels and bytes per voxel of a series (``list_series``'s headers: no pixel read)."""
    first = slices[0][1]
    return len(slices) * int(first.Rows) * int(first.Columns), max(1, int(first.BitsAllocated) // 8)


def read_dicom_series(folder: Path, series: str | None = None,
                      weigh: Callable[[int, int], object] | None = None) -> Volume:
    """The series of ``folder`` (the only one, or ``series``) as a ``Volume``; ``weigh(voxels, bytes per
    voxel)`` is told its size from the headers before a pixel is read."""
    groups = list_series(folder)
    if not groups:
        raise InputError(f"{str(folder)!r} holds no DICOM image slices; give a folder of one DICOM series "
                         "or a volume file")
    if series is None and len(groups) > 1:
        raise ConfigError(f"{str(folder)!r} holds {len(groups)} DICOM series; pick one with {param('series')} UID: "
                          + "; ".join(_describe(uid, s) for uid, s in groups.items()))
    if series is not None and series not in groups:
        raise ConfigError(f"no DICOM series {series!r} in {str(folder)!r}; it holds "
                          + "; ".join(_describe(uid, s) for uid, s in groups.items()))
    uid = series if series is not None else next(iter(groups))
    if weigh is not None:
        weigh(*series_size(groups[uid]))
    return _assemble(groups[uid], f"{folder.name} ({uid})")


def _assemble(slices: list, name: str) -> Volume:
    import pydicom

    first = slices[0][1]
    orientation = np.asarray(first.ImageOrientationPatient, dtype=float)
    for _, ds in slices:
        if not np.allclose(np.asarray(ds.ImageOrientationPatient, dtype=float), orientation, atol=1e-4):
            raise InputError(f"the slices of {name} are not all oriented alike (ImageOrientationPatient differs); "
                             "povh3d reads one regular grid")
        if (ds.Rows, ds.Columns) != (first.Rows, first.Columns):
            raise InputError(f"the slices of {name} differ in size; povh3d reads one regular grid")
    row, column = orientation[:3], orientation[3:]
    normal = np.cross(row, column)
    positions = np.array([np.asarray(ds.ImagePositionPatient, dtype=float) for _, ds in slices])
    order = np.argsort(positions @ normal, kind="stable")
    slices, positions = [slices[i] for i in order], positions[order]
    if len(slices) > 1:
        steps = np.diff(positions, axis=0)
        step = np.linalg.norm(steps, axis=1)
        if np.any(step < 1e-6):
            raise InputError(f"{name} has two slices at the same position; a folder mixes two acquisitions")
        if np.ptp(step) > 0.01 * step.mean():
            raise InputError(f"the slices of {name} are unevenly spaced ({step.min():.4g} to {step.max():.4g} mm); "
                             "povh3d reads one regular grid")
        slice_dir = steps.mean(axis=0) / step.mean()
        slice_spacing = float(step.mean())
    else:
        slice_dir, slice_spacing = normal, float(getattr(first, "SliceThickness", 1.0) or 1.0)
    pixel = [float(v) for v in getattr(first, "PixelSpacing", (1.0, 1.0))]
    planes = []
    for path, _ in slices:
        ds = pydicom.dcmread(path)
        image = ds.pixel_array.astype(np.float32 if _rescaled(ds) else ds.pixel_array.dtype)
        if _rescaled(ds):
            image = image * float(getattr(ds, "RescaleSlope", 1.0)) + float(getattr(ds, "RescaleIntercept", 0.0))
        planes.append(image.T)  # pixel_array is [row, column] = [j, i]
    values = np.stack(planes, axis=-1)
    direction = np.column_stack([row, column, slice_dir])
    return Volume(values, (pixel[1], pixel[0], slice_spacing), tuple(positions[0].tolist()), direction, name)


def _rescaled(ds: object) -> bool:
    return float(getattr(ds, "RescaleSlope", 1.0)) != 1.0 or float(getattr(ds, "RescaleIntercept", 0.0)) != 0.0
