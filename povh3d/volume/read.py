"""Read a volume file (or a DICOM series folder) into a ``Volume`` in LPS space.

One reader per family, each returning voxel values ``[i, j, k]`` (``i``
fastest in the file), the spacing, the world position of voxel (0, 0, 0) and
the direction matrix:

- ``.vti`` and legacy ``.vtk`` image data: PyVista (a ``.vtk`` holding a
  polygon mesh is a model, not a volume: ``is_polydata_vtk``);
- ``.mha`` / ``.mhd``: VTK's MetaImage reader (ITK's LPS convention);
- ``.nii`` / ``.nii.gz``: VTK's NIfTI reader, its sform (else qform) matrix,
  converted from RAS to LPS (x and y negated);
- ``.nrrd`` / ``.nhdr``: pynrrd (VTK's NRRD reader drops ``space directions``
  and misreads some headers), RAS spaces converted to LPS;
- a folder of DICOM slices: pydicom (one series; slices sorted along the
  slice normal; rescale slope and intercept applied);
- ``.npy``: NumPy, with ``--spacing`` (no file-borne geometry).

Heavy packages are imported inside the readers, so naming a source's kind
(``volume_kind``) costs nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, InputError, MissingExtra, param, warn
from .grid import Volume
from .sources import SUFFIXES, is_polydata_vtk, is_volume_source, suffix as _suffix

__all__ = ["SUFFIXES", "is_polydata_vtk", "is_volume_source", "read_volume", "read_vtk_mesh", "volume_size",
           "vtk_quiet"]
_RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0])

def read_volume(path: str | Path, *, spacing: Any = None, series: str | None = None,
                weigh: Callable[[int, int], object] | None = None) -> Volume:
    """The volume in ``path``; ``spacing`` (mm, 3 values) replaces the file's; ``series`` picks a
    DICOM series by its UID; ``weigh(voxels, bytes per voxel)`` is told the volume's size from its
    header before a voxel is read (not called where the header does not tell: ``volume_size``).
    Every failure is an ``InputError``/``ConfigError`` with one line."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"volume {str(path)!r} does not exist; check the path")
    if spacing is not None:
        spacing = _spacing(spacing)
    if path.is_dir():
        from .dicom import read_dicom_series

        volume = read_dicom_series(path, series, weigh)
    else:
        if series is not None:
            raise ConfigError(f"{param('series')} picks one series of a DICOM folder; the volume is a single file")
        readers = {".vti": _read_vtk, ".vtk": _read_vtk, ".mha": _read_meta, ".mhd": _read_meta,
                   ".nii": _read_nifti, ".nii.gz": _read_nifti, ".nrrd": _read_nrrd, ".nhdr": _read_nrrd,
                   ".npy": _read_npy}
        reader = readers.get(_suffix(path))
        if reader is None:
            raise InputError(f"{path.name!r} is not a volume format povh3d reads; use one of "
                             f"{', '.join(SUFFIXES)} or a DICOM folder")
        size = volume_size(path) if weigh is not None else None
        if weigh is not None and size is not None:
            weigh(*size)
        try:
            volume = reader(path, spacing)
        except (InputError, ConfigError, MissingExtra):
            raise
        except Exception as exc:  # the readers' own errors, in any of their types
            raise InputError(f"cannot read the volume {str(path)!r} ({type(exc).__name__}: "
                             f"{str(exc).strip().splitlines()[0] if str(exc).strip() else 'no details'}); "
                             "check that it is a complete file of its format") from None
    if spacing is not None and path.suffix.lower() != ".npy":
        warn(f"{param('spacing')} {','.join(f'{s:g}' for s in spacing)} replaces the spacing {str(path.name)!r} gives "
             f"({','.join(f'{s:g}' for s in volume.spacing)})")
        volume = Volume(volume.values, spacing, volume.origin, volume.direction, volume.name, volume.label_names,
                        volume.label_colours)
    return volume


#: Bytes of a voxel of NRRD's common types (any other: 8).
_NRRD_BYTES = {"uchar": 1, "unsigned char": 1, "uint8": 1, "signed char": 1, "int8": 1, "short": 2, "ushort": 2,
               "unsigned short": 2, "int16": 2, "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4,
               "float": 4, "double": 8}


def volume_size(path: str | Path, series: str | None = None) -> tuple[int, int] | None:
    """Voxels and bytes per voxel of the volume in ``path``, from its header alone (no voxel read), so
    that a caller can weigh the reading against a memory budget first; None where the header does not
    tell (a legacy VTK file) or cannot be read (the reading then says why)."""
    path = Path(path)
    try:
        if path.is_dir():
            from .dicom import list_series, series_size

            groups = list_series(path)
            slices = groups.get(series) if series is not None else (next(iter(groups.values())) if groups else None)
            return series_size(slices) if slices else None
        kind = _suffix(path)
        if kind == ".npy":
            values = np.load(path, mmap_mode="r", allow_pickle=False)
            return int(values.size), int(values.itemsize)
        if kind in (".nrrd", ".nhdr"):
            from ..extras import require

            header = require("nrrd", "volume", "a NRRD volume").read_header(str(path))
            return int(np.prod(header["sizes"])), _NRRD_BYTES.get(str(header.get("type", "")).lower(), 8)
        if kind in (".nii", ".nii.gz", ".mha", ".mhd"):
            from vtkmodules.vtkIOImage import vtkMetaImageReader, vtkNIFTIImageReader

            reader = vtkNIFTIImageReader() if kind.startswith(".nii") else vtkMetaImageReader()
            reader.SetFileName(str(path))
            with vtk_quiet():
                reader.UpdateInformation()
            x0, x1, y0, y1, z0, z1 = reader.GetDataExtent()
            return (x1 - x0 + 1) * (y1 - y0 + 1) * (z1 - z0 + 1), 8
    except Exception:  # a header povh3d cannot read: the reading itself says what is wrong, in one line
        return None
    return None


def _spacing(value: Any) -> tuple[float, float, float]:
    try:
        values = tuple(float(v) for v in (value.split(",") if isinstance(value, str) else value))
    except (TypeError, ValueError):
        values = ()
    if len(values) != 3 or not all(np.isfinite(v) and v > 0 for v in values):
        raise ConfigError(f"{param('spacing')} takes three positive voxel sizes SX,SY,SZ in mm, got {value!r}")
    return values


def _scalar(values: np.ndarray, name: str) -> np.ndarray:
    if values.ndim == 4 and values.shape[-1] == 1:
        values = values[..., 0]
    if values.ndim != 3:
        raise InputError(f"{name} holds {values.ndim}-dimensional data of shape {values.shape}; povh3d reads "
                         "scalar 3D volumes (one value per voxel)")
    return values


def _from_image(image: Any, name: str, label_names: dict | None = None) -> Volume:
    """A ``pyvista.ImageData`` (point data, else cell data) as a ``Volume``."""
    data, dims, origin = image.point_data, tuple(image.dimensions), np.asarray(image.origin, dtype=float)
    direction = np.asarray(image.direction_matrix, dtype=float)
    if not data.keys():
        if not image.cell_data.keys():
            raise InputError(f"{name} holds no voxel values (no point or cell data arrays)")
        # Cell data: one value per cell, the cell centres half a voxel in from the points.
        data, dims = image.cell_data, tuple(max(n - 1, 1) for n in dims)
        origin = origin + direction @ (0.5 * np.asarray(image.spacing) * (np.asarray(image.dimensions) > 1))
    array = data.active_scalars if data.active_scalars is not None else data[data.keys()[0]]
    array = np.asarray(array)
    if array.ndim == 2 and array.shape[1] != 1:
        raise InputError(f"{name} has {array.shape[1]} components per voxel; povh3d reads scalar volumes")
    values = array.reshape(dims, order="F")
    sx, sy, sz = (float(s) for s in image.spacing)
    return Volume(values, (sx, sy, sz), tuple(origin.tolist()), direction, name,
                  label_names or {})


@contextmanager
def vtk_quiet() -> Iterator[None]:
    """VTK's readers print their errors themselves (and go on with an empty output): silenced here,
    the empty output becomes one ``InputError``."""
    from vtkmodules.vtkCommonCore import vtkLogger, vtkObject

    shown, verbosity = vtkObject.GetGlobalWarningDisplay(), vtkLogger.GetCurrentVerbosityCutoff()
    vtkObject.GlobalWarningDisplayOff()
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    try:
        yield
    finally:
        vtkObject.SetGlobalWarningDisplay(shown)
        vtkLogger.SetStderrVerbosity(verbosity)


def read_vtk_mesh(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A legacy ``.vtk`` polygon mesh: its triangulated surface's points and triangles."""
    from vtkmodules.vtkIOLegacy import vtkPolyDataReader

    mesh = _vtk_read(vtkPolyDataReader(), path, "a VTK polygon mesh")
    mesh = mesh.extract_surface(algorithm="dataset_surface").triangulate()
    return np.asarray(mesh.points, dtype=np.float64), np.asarray(mesh.regular_faces, dtype=np.int64)


def _vtk_read(reader: Any, path: Path, what: str) -> Any:
    """Run a VTK ``reader`` on ``path``; its output wrapped by PyVista, or an ``InputError``."""
    import pyvista

    with vtk_quiet():
        reader.SetFileName(str(path))
        reader.Update()
        output = reader.GetOutput()
    if output is None or (hasattr(output, "GetNumberOfPoints") and output.GetNumberOfPoints() == 0):
        raise InputError(f"cannot read {path.name!r} as {what}; check that it is a complete file of that format")
    return pyvista.wrap(output)


def _read_vtk(path: Path, spacing: Any) -> Volume:
    # The VTK modules themselves, not ``import vtk`` (which loads all of VTK's 150 libraries), and
    # only the one the file needs (the legacy reader's module alone costs 0.1 s).
    if is_polydata_vtk(path):
        raise InputError(f"{path.name!r} is a polygon mesh, not a volume; render it as a model")
    if path.suffix.lower() == ".vti":
        from vtkmodules.vtkIOXML import vtkXMLImageDataReader

        return _from_image(_vtk_read(vtkXMLImageDataReader(), path, "VTK XML image data"), path.name)
    from vtkmodules.vtkIOLegacy import vtkDataSetReader

    data = _vtk_read(vtkDataSetReader(), path, "a legacy VTK file")
    if not data.IsA("vtkImageData"):
        raise InputError(f"{path.name!r} holds a {data.GetClassName()}, not image data (a regular voxel grid)")
    return _from_image(data, path.name)


def _read_meta(path: Path, spacing: Any) -> Volume:
    from vtkmodules.vtkIOImage import vtkMetaImageReader

    reader = vtkMetaImageReader()
    if not reader.CanReadFile(str(path)):  # MetaIO prints its parse errors itself: ask first
        raise InputError(f"{path.name!r} is not a MetaImage file (no valid header); check the file")
    return _from_image(_vtk_read(reader, path, "a MetaImage file"), path.name)


def _read_nifti(path: Path, spacing: Any) -> Volume:
    from vtkmodules.vtkIOImage import vtkNIFTIImageReader

    reader = vtkNIFTIImageReader()
    image = _vtk_read(reader, path, "a NIfTI file")
    header = reader.GetNIFTIHeader()
    matrix = reader.GetSFormMatrix() if header.GetSFormCode() > 0 else reader.GetQFormMatrix()
    volume = _from_image(image, path.name)
    values = volume.values
    slope, intercept = reader.GetRescaleSlope(), reader.GetRescaleIntercept()
    if slope not in (0.0, 1.0) or intercept != 0.0:
        values = values * slope + intercept
    if matrix is None:  # no orientation at all (NIfTI's "method 1"): voxel axes taken as LPS
        return Volume(values, volume.spacing, (0.0, 0.0, 0.0), np.eye(3), path.name)
    # The reader's image has origin 0 and the pixdim spacing; the matrix takes (i sx, j sy, k sz) to RAS.
    m = np.array([[matrix.GetElement(r, c) for c in range(4)] for r in range(4)])
    linear = _RAS_TO_LPS @ m[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    if np.any(scale <= 0):
        raise InputError(f"{path.name!r} has a degenerate orientation matrix")
    direction = linear / scale
    if not np.allclose(direction.T @ direction, np.eye(3), atol=1e-4):
        raise InputError(f"{path.name!r} has a sheared orientation matrix; resample it to a rigid grid first")
    return Volume(values, tuple((np.asarray(volume.spacing) * scale).tolist()),
                  tuple((_RAS_TO_LPS @ m[:3, 3]).tolist()), direction, path.name)


_NRRD_SPACES = {"left-posterior-superior": np.eye(3), "lps": np.eye(3),
                "right-anterior-superior": _RAS_TO_LPS, "ras": _RAS_TO_LPS,
                "left-anterior-superior": np.diag([1.0, -1.0, 1.0]), "las": np.diag([1.0, -1.0, 1.0])}


def _read_nrrd(path: Path, spacing: Any) -> Volume:
    from ..extras import require

    nrrd = require("nrrd", "volume", "a NRRD volume")

    values, header = nrrd.read(str(path))  # Fortran order: values[i, j, k], i fastest in the file
    values = _scalar(np.asarray(values), path.name)
    to_lps = _NRRD_SPACES.get(str(header.get("space", "lps")).lower(), np.eye(3))
    directions = header.get("space directions")
    if directions is not None:
        rows = np.asarray([d for d in directions if d is not None and np.all(np.isfinite(d))], dtype=float)
        if rows.shape != (3, 3):
            raise InputError(f"{path.name!r} has no usable 'space directions' for its three axes")
        columns = to_lps @ rows.T
        sizes = np.linalg.norm(columns, axis=0)
        direction = columns / sizes
    elif header.get("spacings") is not None and np.all(np.isfinite(header["spacings"])):
        sizes, direction = np.asarray(header["spacings"], dtype=float), np.eye(3)
    elif spacing is not None:
        sizes, direction = np.asarray(spacing), np.eye(3)
    else:
        raise ConfigError(f"{path.name!r} gives no voxel spacing; give {param('spacing')} SX,SY,SZ in mm")
    origin = to_lps @ np.asarray(header.get("space origin", np.zeros(3)), dtype=float)
    names, colours = _slicer_segments(header)
    return Volume(values, tuple(sizes.tolist()), tuple(origin.tolist()), direction, path.name, names, colours)


def _slicer_segments(header: dict) -> tuple[dict[int, str], dict[int, tuple[float, float, float]]]:
    """The label table of a 3D Slicer segmentation (``SegmentN_LabelValue``, ``_Name``, ``_Color``)."""
    names, colours = {}, {}
    for key, value in header.items():
        if key.startswith("Segment") and key.endswith("_LabelValue"):
            prefix = key[: -len("LabelValue")]
            label = int(value)
            names[label] = str(header.get(prefix + "Name", label))
            rgb = str(header.get(prefix + "Color", "")).split()
            if len(rgb) == 3:
                red, green, blue = (float(c) for c in rgb)
                colours[label] = red, green, blue
    return names, colours


def _read_npy(path: Path, spacing: Any) -> Volume:
    if spacing is None:
        raise ConfigError(f"{path.name!r} (a NumPy array) carries no voxel size; give {param('spacing')} SX,SY,SZ in mm")
    values = np.load(path, allow_pickle=False)
    return Volume(_scalar(np.asarray(values), path.name), spacing, name=path.name)
