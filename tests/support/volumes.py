"""Synthetic volumes (phantoms) and writers for every format povh3d reads.

The writers are independent of povh3d's readers: VTK's writers for .vti, .vtk
and MetaImage, pynrrd for NRRD, pydicom for DICOM slices, and a NIfTI-1
header packed here byte by byte from the standard (so the RAS -> LPS step of
the reader is checked against the format, not against VTK's own writer).
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from povh3d.volume.grid import Volume

LABEL_BODY, LABEL_LEFT, LABEL_TOP = 1, 2, 3


def turn(degrees: float) -> np.ndarray:
    """A rotation about LPS z (superior) by ``degrees``: a direction matrix that is not the identity."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def asymmetric_phantom(direction: np.ndarray | None = None, dtype: str = "uint8") -> Volume:
    """A body (label 1) with a marker on the patient's left (label 2, +x in LPS) and one at the
    front top (label 3: anterior -y, superior +z), in a 24 x 20 x 16 grid of 1 x 1.5 x 2 mm voxels."""
    shape, spacing = (24, 20, 16), (1.0, 1.5, 2.0)
    values = np.zeros(shape, dtype=dtype)
    values[4:20, 4:16, 3:13] = LABEL_BODY
    values[20:23, 8:12, 6:10] = LABEL_LEFT
    values[10:14, 1:4, 10:14] = LABEL_TOP
    return Volume(values, spacing, origin=(-12.0, 7.5, 30.0),
                  direction=np.eye(3) if direction is None else direction, name="phantom")


def ellipsoid_field(semi_axes: tuple[float, float, float], spacing: tuple[float, float, float],
                    shape: tuple[int, int, int]) -> Volume:
    """``1 - (x/a)^2 - (y/b)^2 - (z/c)^2`` about the grid centre (float32): its 0 iso-surface is the ellipsoid."""
    axes = [(np.arange(n) - (n - 1) / 2) * s / a for n, s, a in zip(shape, spacing, semi_axes)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    return Volume((1.0 - x * x - y * y - z * z).astype(np.float32), spacing, name="ellipsoid")


def _image(volume: Volume, direction: bool = True):
    import pyvista

    image = pyvista.ImageData(dimensions=volume.shape, spacing=volume.spacing, origin=volume.origin)
    if direction:
        image.direction_matrix = np.asarray(volume.direction)
    image.point_data["values"] = volume.values.ravel(order="F")
    return image


def write_vti(volume: Volume, path: Path) -> Path:
    _image(volume).save(path)
    return path


def write_legacy_vtk(volume: Volume, path: Path) -> Path:
    """Legacy .vtk has no direction matrix: the volume must have the identity."""
    assert np.allclose(volume.direction, np.eye(3))
    _image(volume, direction=False).save(path)
    return path


def write_meta(volume: Volume, path: Path) -> Path:
    import vtk

    writer = vtk.vtkMetaImageWriter()
    writer.SetFileName(str(path))
    writer.SetInputData(_image(volume))
    writer.Write()
    return path


def write_nrrd(volume: Volume, path: Path, space: str = "left-posterior-superior") -> Path:
    import nrrd

    to_space = np.diag([-1.0, -1.0, 1.0]) if space.startswith("right-anterior") else np.eye(3)
    columns = to_space @ np.asarray(volume.direction) * np.asarray(volume.spacing)
    header = {"space": space, "space directions": columns.T,
              "space origin": to_space @ np.asarray(volume.origin), "kinds": ["domain"] * 3}
    nrrd.write(str(path), volume.values, header, detached_header=path.suffix == ".nhdr")
    return path


_NIFTI_TYPES = {np.dtype("uint8"): (2, 8), np.dtype("int16"): (4, 16), np.dtype("float32"): (16, 32)}


def write_nifti(volume: Volume, path: Path) -> Path:
    """A NIfTI-1 single file (.nii or .nii.gz) with only an sform: RAS = diag(-1, -1, 1) @ LPS."""
    import gzip

    code, bits = _NIFTI_TYPES[volume.values.dtype]
    ras = np.diag([-1.0, -1.0, 1.0])
    linear = ras @ np.asarray(volume.direction) * np.asarray(volume.spacing)
    offset = ras @ np.asarray(volume.origin)
    header = bytearray(348)
    struct.pack_into("<i", header, 0, 348)
    struct.pack_into("<8h", header, 40, 3, *volume.shape, 1, 1, 1, 1)
    struct.pack_into("<hh", header, 70, code, bits)
    struct.pack_into("<8f", header, 76, 1.0, *volume.spacing, 1.0, 1.0, 1.0, 1.0)
    struct.pack_into("<f", header, 108, 352.0)          # vox_offset
    struct.pack_into("<ff", header, 112, 1.0, 0.0)      # scl_slope, scl_inter
    struct.pack_into("<B", header, 123, 2)              # xyzt_units: mm
    struct.pack_into("<hh", header, 252, 0, 1)          # qform_code 0, sform_code 1 (scanner)
    for row in range(3):
        struct.pack_into("<4f", header, 280 + 16 * row, *linear[row], offset[row])
    header[344:348] = b"n+1\0"
    data = bytes(header) + b"\0\0\0\0" + volume.values.astype(volume.values.dtype.newbyteorder("<")).tobytes(order="F")
    path.write_bytes(gzip.compress(data) if path.name.endswith(".gz") else data)
    return path


def write_dicom_series(volume: Volume, folder: Path, *, uid: str | None = None, description: str = "phantom",
                       intercept: float = -1024.0) -> Path:
    """One CT slice file per k (written in reverse order, so the reader must sort them), int16 with a
    rescale intercept."""
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid

    folder.mkdir(parents=True, exist_ok=True)
    d = np.asarray(volume.direction)
    series = uid or generate_uid()
    study = generate_uid()
    si, sj, sk = volume.spacing
    for k in reversed(range(volume.shape[2])):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        path = folder / f"{series[-6:]}_{volume.shape[2] - k:04d}.dcm"
        ds = FileDataset(str(path), {}, file_meta=meta, preamble=b"\0" * 128)
        ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID, ds.SeriesInstanceUID, ds.SeriesDescription = study, series, description
        ds.Modality, ds.InstanceNumber = "CT", k + 1
        ds.Rows, ds.Columns = volume.shape[1], volume.shape[0]
        ds.PixelSpacing = [sj, si]  # between rows (j), between columns (i)
        ds.ImageOrientationPatient = [float(v) for v in (*d[:, 0], *d[:, 1])]
        ds.ImagePositionPatient = [float(v) for v in np.asarray(volume.origin) + d[:, 2] * sk * k]
        ds.SliceThickness = sk
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.RescaleSlope, ds.RescaleIntercept = 1, intercept
        ds.PixelData = (volume.values[:, :, k].T.astype(np.float64) - intercept).astype("<i2").tobytes()
        ds.save_as(str(path), enforce_file_format=True)
    return folder


def write_nifti_qform_flipped(volume: Volume, path: Path, offset: tuple[float, float, float]) -> Path:
    """A NIfTI-1 file with only a qform: identity quaternion, ``qfac = -1`` (the slices stored from
    head to feet), so RAS = ``offset + (i sx, j sy, -k sz)``; ``volume.origin``/``direction`` are ignored."""
    code, bits = _NIFTI_TYPES[volume.values.dtype]
    header = bytearray(348)
    struct.pack_into("<i", header, 0, 348)
    struct.pack_into("<8h", header, 40, 3, *volume.shape, 1, 1, 1, 1)
    struct.pack_into("<hh", header, 70, code, bits)
    struct.pack_into("<8f", header, 76, -1.0, *volume.spacing, 1.0, 1.0, 1.0, 1.0)   # pixdim[0] = qfac
    struct.pack_into("<f", header, 108, 352.0)
    struct.pack_into("<ff", header, 112, 1.0, 0.0)
    struct.pack_into("<B", header, 123, 2)
    struct.pack_into("<hh", header, 252, 1, 0)          # qform_code 1, no sform
    struct.pack_into("<6f", header, 256, 0.0, 0.0, 0.0, *offset)   # quatern_b, c, d; qoffset_x, y, z
    header[344:348] = b"n+1\0"
    path.write_bytes(bytes(header) + b"\0\0\0\0" + volume.values.tobytes(order="F"))
    return path
