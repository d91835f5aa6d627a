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

from collections.abc import Callable
from pathlib import Path

from .camera import CameraError, _closing_brace, _depths, tokens
from .object_ids import OBJECTS
from .scene import Scene, load_scene, source_text

_SOURCES = (".pov", ".inc", ".mcr")


def all_hollow(text: str) -> str:
    """``text`` with `` hollow`` before the closing brace of every object statement at brace depth 0
    that is not a ``#declare``/``#local`` value (``object_ids.OBJECTS``, found as the object masks
    find them; a macro body's too, which is made where it is called); unchanged where a block has no
    closing brace (an object opened in one file and closed in another is left as it is)."""
    toks = tokens(text)
    depth_of = {i: b for i, b, _ in _depths(toks)}
    ends = []
    for i, tok in enumerate(toks[:-1]):
        if depth_of[i] == 0 and tok.text in OBJECTS and toks[i + 1].text == "{" \
                and not (i > 0 and toks[i - 1].text == "="):
            try:
                ends.append(toks[_closing_brace(toks, i + 1)].start)
            except CameraError:
                return text
    for at in reversed(ends):
        text = text[:at] + " hollow " + text[at:]
    return text


def copy_rewritten(scene: Scene, folder: Path, transform: Callable[[str], str]) -> Scene | None:
    """The scene with ``transform`` applied to its own sources, copied into ``folder`` and loaded;
    None when the transform changes none of them."""
    root = scene.path.parent
    sources = [p for p in scene.files if p.suffix.lower() in _SOURCES and p.is_file() and p.is_relative_to(root)]
    texts = {p: source_text(p.read_bytes()) for p in sources}   # a byte-order mark dropped, as POV-Ray reads
    changed = {p: transform(t) for p, t in texts.items()}
    if all(changed[p] == texts[p] for p in sources):
        return None
    for p in sources:
        target = folder / p.relative_to(root)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(changed[p], encoding="latin-1")
    return load_scene(folder / scene.path.relative_to(root), (root, *scene.include_dirs))
