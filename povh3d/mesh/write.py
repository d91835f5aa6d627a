"""A model's parts as the text of a POV-Ray include: ``mesh2`` objects and their bounds.

Pure: text and texture images in, nothing written; ``renderer.content.convert_mesh`` writes them.
The include declares ``IDENT`` (one ``mesh2``, or a ``union`` of them),
``IDENT_min`` and ``IDENT_max`` (its bounding box, mm) and ``IDENT_Dir``, the
folder prefix of its texture files (empty: found beside the scene or through
``+L``).  Every texture uses the finish ``Povh3d_Mesh_Finish``, which a scene
may declare before the include to change how the model is lit.
"""

from __future__ import annotations

import numpy as np

from .._version import __version__
from ..image.colour import srgb_to_linear
from ..scene.format import pov_string, pov_vector
from .load import Part
from .numbers import format_rows, format_vectors, vector_item
from .text32 import format_vectors32

DEFAULT_FINISH = "finish { ambient 0.05 diffuse 0.85 specular 0.15 roughness 0.05 }"


def colour_keyword(colour_space: str, alpha: bool) -> str:
    """``rgb``/``rgbt``: colours are written linear whatever the file held.

    POV-Ray's ``srgb`` keyword needs ``assumed_gamma`` set before it is parsed
    ("Cannot parse sRGB colors before assumed_gamma has been set"); an include
    must parse in any scene, so sRGB colours are decoded here instead (exact under
    ``assumed_gamma 1.0``, which povh3d adds to a scene that sets none).
    """
    return "rgb" + ("t" if alpha else "")


def colour_values(rgba: np.ndarray, alpha: bool, colour_space: str = "linear") -> np.ndarray:
    """``(k, 4)`` uint8 RGBA -> ``(k, 3|4)`` float64 linear light: ``c / 255`` decoded from sRGB
    when ``colour_space`` is ``'srgb'``; transmit ``1 - a / 255``."""
    rgba = np.asarray(rgba, dtype=np.float64).reshape(-1, 4)
    rgb = rgba[:, :3] / 255.0
    if colour_space == "srgb":
        rgb = srgb_to_linear(rgb)
    return np.column_stack([rgb, (255.0 - rgba[:, 3]) / 255.0]) if alpha else rgb


def _pigment_literal(rgba: np.ndarray, colour_space: str) -> str:
    alpha = bool(rgba[3] < 255)
    return f"{colour_keyword(colour_space, alpha)} {pov_vector(colour_values(rgba, alpha, colour_space)[0])}"


def _block(keyword: str, count: int, body: str) -> str:
    return f"  {keyword} {{\n    {count},\n    {body}\n  }}\n" if count else f"  {keyword} {{ 0 }}\n"


def _texture_list(colours: np.ndarray, colour_space: str) -> str:
    alpha = bool((colours[:, 3] < 255).any())
    item = ("texture { pigment { " + colour_keyword(colour_space, alpha) + " "
            + vector_item(4 if alpha else 3) + " } finish { Povh3d_Mesh_Finish } }")
    return _block("texture_list", len(colours), format_rows(colour_values(colours, alpha, colour_space), item, per_line=1))


def mesh2_text(part: Part, *, smooth: bool, normals: np.ndarray | None, texture_file: str | None,
               ident: str) -> str:
    """One part as a ``mesh2 { ... }`` block.

    Parameters
    ----------
    part : Part                cleaned (finite numbers, no degenerate faces)
    smooth : bool              write ``normal_vectors`` (``normals`` must be given)
    normals : (n, 3) float or None
    texture_file : str or None the image file name the part's UVs look up
    ident : str                the model's identifier (for ``IDENT_Dir``)
    """
    # POV-Ray keeps vertices and normals as floats: their shortest float32 text (text32.py).
    # the name is a comment: a line break in it (a glTF node may have one) would end the comment early
    out = [f"mesh2 {{  // {' '.join(part.name.splitlines())}\n",
           _block("vertex_vectors", len(part.vertices), format_vectors32(part.vertices))]
    if smooth and normals is not None:  # given together (normals None: flat)
        out.append(_block("normal_vectors", len(normals), format_vectors32(normals)))
    textured = texture_file is not None and part.uv is not None
    if texture_file is not None and part.uv is not None:  # textured
        out.append(_block("uv_vectors", len(part.uv), format_vectors(part.uv)))

    faces = part.faces
    if not textured and part.vertex_colors is not None:
        colours, index = np.unique(part.vertex_colors, axis=0, return_inverse=True)
        out.append(_texture_list(colours, part.colour_space))
        rows = np.column_stack([faces, index.ravel()[faces]])
        out.append(_block("face_indices", len(faces), format_rows(rows, "<%d, %d, %d>, %d, %d, %d", 2)))
    elif not textured and part.face_colors is not None:
        colours, index = np.unique(part.face_colors, axis=0, return_inverse=True)
        out.append(_texture_list(colours, part.colour_space))
        rows = np.column_stack([faces, index.ravel()])
        out.append(_block("face_indices", len(faces), format_rows(rows, "<%d, %d, %d>, %d", 3)))
    else:
        out.append(_block("face_indices", len(faces), format_vectors32(faces)))

    if texture_file is not None and textured:
        kind = "png"
        out.append(f"  texture {{ uv_mapping pigment {{ image_map {{ {kind} concat({ident}_Dir, "
                   f"{pov_string(texture_file)}) interpolate 2 }} }} finish {{ Povh3d_Mesh_Finish }} }}\n")
    elif part.vertex_colors is None and part.face_colors is None:
        out.append(f"  texture {{ pigment {{ {_pigment_literal(part.base_color, part.colour_space)} }} "
                   "finish { Povh3d_Mesh_Finish } }\n")
    out.append("}\n")
    return "".join(out)


def include_text(parts: list[str], ident: str, bounds: tuple[np.ndarray, np.ndarray], *,
                 source: str, summary: str) -> str:
    """The include file around the parts' ``mesh2`` blocks."""
    lo, hi = bounds
    body = parts[0] if len(parts) == 1 else "union {\n" + "".join(parts) + "}\n"
    return (f"// {ident}: converted by povh3d {__version__} from {source}\n"
            f"// {summary}\n"
            "// POV-Ray frame, mm: x right, y up, z away from the viewer (the model's +z was negated).\n"
            f"#ifndef ({ident}_Dir) #declare {ident}_Dir = \"\"; #end  // folder of the texture files, ending in /\n"
            f"#ifndef (Povh3d_Mesh_Finish) #declare Povh3d_Mesh_Finish = {DEFAULT_FINISH} #end\n"
            f"#declare {ident}_min = {pov_vector(lo)};\n"
            f"#declare {ident}_max = {pov_vector(hi)};\n"
            f"#declare {ident} =\n{body}")
