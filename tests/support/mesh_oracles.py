"""Test helpers for povh3d.mesh: read a written include back, render a silhouette with POV-Ray.

The parser is written from POV-Ray's mesh2 syntax, not from the writer's code:
it reads numbers with ``float``/``int`` and returns arrays to compare exactly.
Vertices and normals are kept as POV-Ray keeps them, in single precision
(``pov_single``: each number parsed to a double, then rounded to a float).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from povh3d.mesh.raster import Window
from povh3d.povray.process import PovrayJob, run_jobs

_VEC = re.compile(r"<([^<>]*)>")


def pov_single(values) -> np.ndarray:
    """``values`` as POV-Ray stores a mesh2's vertices and normals: float32, returned as float64."""
    return np.asarray(values, dtype=np.float64).astype(np.float32).astype(np.float64)


def _numbers(text: str, kind=float) -> list[list]:
    return [[kind(x) for x in m.split(",")] for m in _VEC.findall(text)]


def _block(body: str, keyword: str) -> tuple[int, str] | None:
    """Count and contents of ``keyword { n, ... }`` (blocks without nested braces)."""
    m = re.search(rf"\b{keyword}\s*\{{\s*(\d+)\s*,?([^{{}}]*)\}}", body)
    return (int(m.group(1)), m.group(2)) if m else None


def parse_mesh2(body: str) -> dict:
    out: dict = {}
    for key, kind, width in (("vertex_vectors", float, 3), ("normal_vectors", float, 3), ("uv_vectors", float, 2)):
        found = _block(body, key)
        if found:
            count, text = found
            arr = np.array(_numbers(text, kind), dtype=np.float64).reshape(-1, width)
            assert len(arr) == count, f"{key}: count {count} but {len(arr)} vectors"
            out[key] = arr if key == "uv_vectors" else pov_single(arr)
    count, text = _block(body, "face_indices")
    # "<a, b, c>" optionally followed by 1 or 3 texture indices.
    rows = re.findall(r"<([^<>]*)>((?:\s*,\s*\d+){0,3})", text)
    faces = np.array([[int(x) for x in r[0].split(",")] for r in rows], dtype=np.int64).reshape(-1, 3)
    tex = [[int(x) for x in r[1].replace(" ", "").split(",") if x] for r in rows]
    assert len(faces) == count
    out["faces"] = faces
    if any(tex):
        out["face_textures"] = np.array(tex, dtype=np.int64)
    m = re.search(r"texture_list\s*\{\s*(\d+)\s*,(.*?)\n\s*\}\s*\n\s*face_indices", body, re.S)
    if m:
        items = re.findall(r"pigment\s*\{\s*(srgbt?|rgbt?)\s*<([^>]*)>", m.group(2))
        assert len(items) == int(m.group(1))
        out["texture_list"] = [(k, [float(x) for x in v.split(",")]) for k, v in items]
    tail = body[body.rfind("face_indices"):]
    m = re.search(r"texture\s*\{\s*pigment\s*\{\s*(srgbt?|rgbt?)\s*<([^>]*)>", tail)
    if m:
        out["base"] = (m.group(1), [float(x) for x in m.group(2).split(",")])
    m = re.search(r'image_map\s*\{\s*png\s+concat\(\s*\w+_Dir\s*,\s*"([^"]+)"\s*\)', tail)
    if m:
        out["image"] = m.group(1)
    return out


def parse_include(text: str) -> dict:
    """``{'ident', 'min', 'max', 'parts': [parse_mesh2(...), ...]}``."""
    ident = re.search(r"#declare\s+(\w+)\s*=\s*\n?\s*(?:mesh2|union)\b", text).group(1)
    lo = np.array(_numbers(re.search(rf"#declare\s+{ident}_min\s*=\s*(<[^>]*>)", text).group(1))[0])
    hi = np.array(_numbers(re.search(rf"#declare\s+{ident}_max\s*=\s*(<[^>]*>)", text).group(1))[0])
    starts = [m.start() for m in re.finditer(r"\bmesh2\s*\{", text)]
    bodies = [text[s:e] for s, e in zip(starts, starts[1:] + [len(text)])]
    return {"ident": ident, "min": lo, "max": hi, "parts": [parse_mesh2(b) for b in bodies]}


def pov_silhouette(include: Path, ident: str, window: Window, *, extra: str = "") -> np.ndarray:
    """Render ``ident`` flat white on black, orthographic from the viewer's side (-z), point-sampled."""
    cx, cy = (window.x0 + window.x1) / 2, (window.y0 + window.y1) / 2
    script = f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
#declare Povh3d_Mesh_Finish = finish {{ ambient 0 diffuse 0 emission 1 }}
#include "{include.name}"
background {{ rgb 0 }}
camera {{ orthographic location <{cx!r}, {cy!r}, -1000> direction z
         right <{window.x1 - window.x0!r}, 0, 0> up <0, {window.y1 - window.y0!r}, 0> }}
object {{ {ident} }}
{extra}
"""
    job = PovrayJob(name="silhouette", script=script, width=window.width, height=window.height,
                    include_dirs=(str(include.parent),), options=("-A",), threads=1)
    images = []
    run_jobs([job], processes=1, on_result=lambda r: images.append(_read(r.images[0])))
    return images[0]


def _read(path: Path) -> np.ndarray:
    from povh3d.image.io import read_image

    return read_image(path)
