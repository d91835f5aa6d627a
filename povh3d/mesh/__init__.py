"""Mesh files to POV-Ray text: load (trimesh), clean, simplify, format ``mesh2``.

One module per step: ``formats`` (the registry), ``load``, ``clean``,
``simplify``, ``numbers`` (array formatting), ``write`` (include text),
``identifiers``, ``raster`` (silhouettes in NumPy).  Writing files is
``povh3d.renderer``'s and ``povh3d.commands``'s: ``renderer.content.convert_mesh`` (``povh3d convert-mesh``) and
``renderer.content.model`` (the default scene around a model for ``povh3d render MODEL``).
"""

from .formats import FORMATS, UNITS, is_mesh_file

__all__ = ["FORMATS", "UNITS", "is_mesh_file"]
