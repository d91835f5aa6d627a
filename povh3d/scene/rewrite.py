"""Copies of the user's scene with its own text rewritten, for a pass that must see it otherwise.

``copy_rewritten`` writes the scene's own sources (those in the scene's folder tree) through a text
transform into another folder and loads the copy, the original folders after the copy's so that
images, fonts and data files are read from where they are.  ``all_hollow`` is one transform: every
object the scene's text creates at the top level gets ``hollow`` last, so that a ray that starts
inside it (a backdrop ``plane`` whose inside holds the viewer, a room, a sky sphere) is not inside
a solid (``renderer.passes.depth``: POV-Ray applies no fog inside a solid).  ``hollow`` on a CSG
reaches every part of it.  ``photon_map_hook`` is another: the scene's global ``photons`` block gets a
hook that saves or loads its photon map when povh3d's script asks (``renderer.shots.lighting``).
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


#: The identifier povh3d's script declares before it includes the scene (``templates/scene.pov.j2``): the
#: photon map's file name.  A run loads the map where the file is (a later frame of the saving run, a loading
#: run's link to it) and shoots and saves it where it is not: the map does not depend on the camera.
#: (``file_exists``, not ``frame_number``: a scene that reads the frame number renders a shot a run.)
PHOTON_MAP = "Povh3d_Photon_Map"
_PHOTON_HOOK = (f" #ifdef ({PHOTON_MAP}) #if (file_exists({PHOTON_MAP})) load_file {PHOTON_MAP} "
                f"#else save_file {PHOTON_MAP} #end #end ")


def photon_map_hook(text: str) -> str:
    """``text`` with ``_PHOTON_HOOK`` first in every ``photons`` block directly inside a ``global_settings``
    block (an object's ``photons { target }`` is not one), so that the same copy renders as the scene does
    where nothing is declared; unchanged where such a block names a ``save_file`` or ``load_file`` of its own
    (the scene keeps its map itself) or a block has no closing brace."""
    if "global_settings" not in text or "photons" not in text:
        return text   # a mesh include of the scene's folder is not tokenized (its text is often many MB)
    toks = tokens(text)
    depth_of = {i: b for i, b, _ in _depths(toks)}
    starts = []
    try:
        for g, tok in enumerate(toks[:-1]):
            if tok.text != "global_settings" or toks[g + 1].text != "{":
                continue
            inside = depth_of[g + 1] + 1
            for p in range(g + 2, _closing_brace(toks, g + 1)):
                if toks[p].text == "photons" and toks[p + 1].text == "{" and depth_of[p] == inside:
                    block = toks[p + 2:_closing_brace(toks, p + 1)]
                    if any(b.text in ("save_file", "load_file") for b in block):
                        return text
                    starts.append(toks[p + 1].end)
    except CameraError:
        return text
    for at in reversed(starts):
        text = text[:at] + _PHOTON_HOOK + text[at:]
    return text


def _own_sources(scene: Scene) -> list[Path]:
    root = scene.path.parent
    return [p for p in scene.files if p.suffix.lower() in _SOURCES and p.is_file() and p.is_relative_to(root)]


def rewrites(scene: Scene, transform: Callable[[str], str]) -> bool:
    """Whether ``transform`` changes any of the scene's own sources (what ``copy_rewritten`` would copy)."""
    return any(transform(t) != t for t in (source_text(p.read_bytes()) for p in _own_sources(scene)))


def copy_rewritten(scene: Scene, folder: Path, transform: Callable[[str], str]) -> Scene | None:
    """The scene with ``transform`` applied to its own sources, copied into ``folder`` and loaded;
    None when the transform changes none of them."""
    root = scene.path.parent
    sources = _own_sources(scene)
    texts = {p: source_text(p.read_bytes()) for p in sources}   # a byte-order mark dropped, as POV-Ray reads
    changed = {p: transform(t) for p, t in texts.items()}
    if all(changed[p] == texts[p] for p in sources):
        return None
    for p in sources:
        target = folder / p.relative_to(root)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(changed[p], encoding="latin-1")
    return load_scene(folder / scene.path.relative_to(root), (root, *scene.include_dirs))
