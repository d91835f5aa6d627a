"""Copies of the user's scene with its own text rewritten, for a pass that must see it otherwise.

``copy_rewritten`` writes the scene's own sources (those in the scene's folder tree) through a text
transform into another folder and loads the copy, the original folders after the copy's so that
images, fonts and data files are read from where they are.  ``all_hollow`` is one transform: every
object the scene's text creates at the top level gets ``hollow`` last, so that a ray that starts
inside it (a backdrop ``plane`` whose inside holds the viewer, a room, a sky sphere) is not inside
a solid (``renderer.passes.depth``: POV-Ray applies no fog inside a solid).  ``hollow`` on a CSG
reaches every part of it.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

from .scene import Scene, load_scene

_SOURCES = (".pov", ".inc", ".mcr")

#: The keywords that create an object (POV-Ray 3.7's finite, infinite and CSG objects).
OBJECT_WORDS = frozenset((
    "bicubic_patch", "blob", "box", "cone", "cubic", "cylinder", "difference", "disc", "height_field",
    "intersection", "isosurface", "julia_fractal", "lathe", "lemon", "merge", "mesh", "mesh2", "object",
    "ovus", "parametric", "plane", "poly", "polygon", "polynomial", "prism", "quadric", "quartic",
    "smooth_triangle", "sor", "sphere", "sphere_sweep", "superellipsoid", "text", "torus", "triangle",
    "union"))
_TOKEN = re.compile(r'"(?:\\.|[^"\\\n])*"|//[^\n]*|/\*.*?\*/|[{}=]|#?[A-Za-z_]\w*|\S', re.S)


def all_hollow(text: str) -> str:
    """``text`` with `` hollow`` before the closing brace of every object created at the top level
    (brace depth 0, not the value of a ``#declare``/``#local``); unchanged where its braces do not
    balance (an object opened in one file and closed in another is left as it is)."""
    depth, inserts = 0, []
    previous = ""
    opening: int | None = None   # depth-0 object whose brace is next
    closing = False
    for m in _TOKEN.finditer(text):
        tok = m.group()
        if tok.startswith(('"', "//", "/*")):
            continue
        if tok == "{":
            if depth == 0:
                closing = opening is not None
            depth += 1
        elif tok == "}":
            depth -= 1
            if depth < 0:
                return text
            if depth == 0 and closing:
                inserts.append(m.start())
                closing = False
        opening = m.start() if depth == 0 and tok in OBJECT_WORDS and previous != "=" else None
        previous = tok
    if depth != 0:
        return text
    for at in reversed(inserts):
        text = text[:at] + " hollow " + text[at:]
    return text


def copy_rewritten(scene: Scene, folder: Path, transform: Callable[[str], str]) -> Scene | None:
    """The scene with ``transform`` applied to its own sources, copied into ``folder`` and loaded;
    None when the transform changes none of them."""
    root = scene.path.parent
    sources = [p for p in scene.files if p.suffix.lower() in _SOURCES and p.is_file() and p.is_relative_to(root)]
    texts = {p: p.read_text(encoding="latin-1") for p in sources}
    changed = {p: transform(t) for p, t in texts.items()}
    if all(changed[p] == texts[p] for p in sources):
        return None
    for p in sources:
        target = folder / p.relative_to(root)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(changed[p], encoding="latin-1")
    return load_scene(folder / scene.path.relative_to(root), (root, *scene.include_dirs))
