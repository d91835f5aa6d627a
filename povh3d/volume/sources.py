"""Which sources are volumes: by name, without importing NumPy or VTK (the command line and the
output cache ask before any work)."""

from __future__ import annotations

from pathlib import Path

SUFFIXES = (".vti", ".vtk", ".nrrd", ".nhdr", ".mha", ".mhd", ".nii", ".nii.gz", ".npy")


def suffix(path: Path) -> str:
    """The extension, ``.nii.gz`` taken whole."""
    name = path.name.lower()
    return ".nii.gz" if name.endswith(".nii.gz") else path.suffix.lower()


def is_volume_source(path: str | Path) -> bool:
    """A volume file by its extension, or a folder (a DICOM series)."""
    path = Path(path)
    return path.is_dir() or suffix(path) in SUFFIXES


def is_polydata_vtk(path: str | Path) -> bool:
    """A legacy ``.vtk`` file whose dataset is a polygon mesh (a model for the mesh path)."""
    path = Path(path)
    if path.suffix.lower() != ".vtk" or not path.is_file():
        return False
    with open(path, "rb") as fh:
        head = fh.read(1024).split(b"\n")[:6]
    return any(line.strip().upper().startswith(b"DATASET POLYDATA") for line in head)
