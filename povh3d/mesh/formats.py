"""The mesh formats povh3d reads (through trimesh) and what each one means.

One registry, ``FORMATS``, that the loader and the tests loop over: a new
format is a new entry here.  Every format is taken to be right-handed with
``+y`` up and the viewer on ``+z`` (OBJ, glTF and what most tools write for
STL, PLY and OFF); the loader turns that into POV-Ray's left-handed frame.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Millimetres per unit of ``--unit``.
UNITS: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4}


@dataclass(frozen=True)
class MeshFormat:
    """One file format.

    Attributes
    ----------
    name : str            shown in messages
    file_type : str       trimesh's name for it
    unit : str            the unit its numbers are in when the user gives none (a key of UNITS)
    colour_space : {'srgb', 'linear'}
        How its 8-bit colours are encoded: glTF stores linear factors and
        vertex colours; the others store display (sRGB) values.
    soup : bool           triangles do not share vertices (STL): merge equal vertices
    """

    name: str
    file_type: str
    unit: str = "mm"
    colour_space: str = "srgb"
    soup: bool = False


FORMATS: dict[str, MeshFormat] = {
    ".obj": MeshFormat("Wavefront OBJ", "obj"),
    ".stl": MeshFormat("STL", "stl", soup=True),
    ".ply": MeshFormat("PLY", "ply"),
    ".off": MeshFormat("OFF", "off"),
    ".glb": MeshFormat("binary glTF", "glb", unit="m", colour_space="linear"),
    ".gltf": MeshFormat("glTF", "gltf", unit="m", colour_space="linear"),
    ".3mf": MeshFormat("3MF", "3mf"),
}


def is_mesh_file(path: str) -> bool:
    """True when ``path`` has the extension of a format in ``FORMATS``."""
    return any(str(path).lower().endswith(ext) for ext in FORMATS)
