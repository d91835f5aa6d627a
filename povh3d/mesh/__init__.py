"""Mesh files to POV-Ray: load (trimesh), clean, simplify, write ``mesh2``, stage for rendering.

One module per step: ``formats`` (the registry), ``load``, ``clean``,
``simplify``, ``numbers`` (array formatting), ``write`` (include text),
``convert`` (writes files), ``raster`` (silhouettes in NumPy), ``stage``
(the default scene around a model for ``povh3d render MODEL``).
"""

from .convert import ConversionResult, convert_mesh
from .formats import FORMATS, UNITS, is_mesh_file

__all__ = ["ConversionResult", "convert_mesh", "FORMATS", "UNITS", "is_mesh_file"]
