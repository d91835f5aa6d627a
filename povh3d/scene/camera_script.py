"""The scene with every camera statement rewritten to print its values: POV-Ray finds the camera.

A scene's camera may be written anywhere the parse reaches: in an ``#include``d
file (``screen.inc`` builds one in a macro), in a ``#macro``, inside ``#if``, or
``#declare``d and used later as ``camera { Cam ... }``.  Rather than guess which
statement POV-Ray uses, povh3d rewrites them all and lets POV-Ray run the scene:

- every ``camera { ... }`` statement becomes its modifiers as ``#declare``s and
  ``#debug`` prints (``camera._rewrite``), between a ``begin`` and an ``end`` line;
  whichever statements the parse executes print, and the last block printed is
  the camera POV-Ray would use (a later camera replaces an earlier one);
- a ``#declare Cam = camera { ... }`` keeps its values under numbered identifiers
  (``Povh3d_K<n>_<i>``) and which declaration ran last (``Povh3d_W<m>``), so that a
  ``camera { Cam ... }`` prints them, then its own modifiers;
- an ``#include "file"`` whose file (or what it includes) holds a camera is
  replaced by that file's text, rewritten the same way (include is textual in
  POV-Ray); other includes stay as they are.

The log's first line of each parse is ``povh3d-camera parse``, so an animation's
later frames are told apart.  What cannot be followed (an include whose name is
computed, a camera copied from an identifier povh3d finds no declaration of) is a
``CameraError`` naming the ``--display-*`` options.

Pure: text in, text out; reading the files is the caller's ``read`` function.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field

from .camera import (TAG, CameraScript, Token, _cannot, _closing_brace, _KEYWORDS, _rewrite, _version,
                     replay_code, stored_items, tokens)

#: How deep includes holding cameras may nest (a file including itself stops here).
MAX_DEPTH = 32


@dataclass
class _Declaration:
    store: str                      # the prefix of its kept values
    items: list[tuple[int, str]]    # camera.stored_items of its body
    number: int                     # its value of Povh3d_W<m> once it ran


@dataclass
class _Scene:
    read: Callable[[str], str | None]
    texts: dict[str, str | None] = field(default_factory=dict)
    cameras: dict[str, bool] = field(default_factory=dict)
    declarations: dict[str, list[_Declaration]] = field(default_factory=dict)
    sites: dict[tuple[str, int], _Declaration] = field(default_factory=dict)

    def text(self, name: str) -> str | None:
        if name not in self.texts:
            self.texts[name] = self.read(name)
        return self.texts[name]

    def holds_camera(self, name: str, depth: int = 0) -> bool:
        """Whether the file ``name`` (or one it includes by a literal name) has the word ``camera``."""
        if name in self.cameras:
            return self.cameras[name]
        self.cameras[name] = False   # while it is being looked at: an include cycle holds none
        text = self.text(name)
        found = False
        if text is not None and depth < MAX_DEPTH:
            word, includes = _camera_word_and_includes(text)
            found = word or any(self.holds_camera(n, depth + 1) for n in includes)
        self.cameras[name] = found
        return found


#: What ``holds_camera`` looks for, outside comments and strings: the word ``camera`` and the
#: ``#include "name"`` directives.  One scan in C, not every token of the file in Python
#: (the standard includes ``shapes.inc`` pulls in cost 0.3 s to tokenise).
_CAMERA_SCAN = re.compile(r'//[^\n]*|/\*.*?\*/|#\s*include\s*("(?:\\.|[^"\\\n])*")|"(?:\\.|[^"\\\n])*"|\bcamera\b',
                          re.S)


def _camera_word_and_includes(text: str) -> tuple[bool, list[str]]:
    """Whether ``text`` has the word ``camera`` outside comments and strings, and the names its
    ``#include`` directives give literally (the tokens' ``#include`` then a string)."""
    includes = []
    for m in _CAMERA_SCAN.finditer(text):
        if m.group(1) is not None:
            includes.append(m.group(1)[1:-1])
        elif m.group() == "camera":
            return True, includes
    return False, includes


def _literal_includes(toks: list[Token]) -> list[str]:
    return [toks[i + 1].text[1:-1] for i, t in enumerate(toks[:-1])
            if t.text == "#include" and toks[i + 1].text.startswith('"')]


def camera_script(main: str, read: Callable[[str], str | None]) -> CameraScript | None:
    """The scene ``main`` (text) with its cameras and those of its includes rewritten, or None when no
    file it reaches has the word ``camera``.

    ``read(name)``: the text of the file an ``#include "name"`` reads, None when there is none.
    """
    scene = _Scene(read)
    scene.texts[""] = main
    if not scene.holds_camera(""):
        return None
    _collect("", scene, 0)
    pieces = [(f'#debug "{TAG} parse\\n"\n', None), *_rewritten("", scene, 0), ("\n", None)]
    lines, line = [], 1
    for piece, origin in pieces:
        lines.append((line, *(origin or ("", 0))))
        line += piece.count("\n")
    return CameraScript("".join(p for p, _ in pieces), 0, lines=tuple(lines))


#: Camera types whose refusal needs none of the camera's values (only a perspective camera defines a
#: frame; an orthographic one's refusal quotes its place): told from the text, before POV-Ray parses a
#: scene that may take minutes at the panel's size (the mesh-camera demos build their mesh from image_width).
REFUSED_TYPES = ("mesh_camera", "fisheye", "ultra_wide_angle", "omnimax", "panoramic", "cylinder", "spherical")


def written_camera_types(main: str, read: Callable[[str], str | None]) -> set[str]:
    """The words every camera statement of the scene ``main`` and of the files it includes by a literal
    name opens with (``perspective``, ``mesh_camera``, ``location`` for a camera of the default type, an
    identifier for one copied from it)."""
    scene = _Scene(read)
    scene.texts[""] = main
    found: set[str] = set()
    todo, seen = [""], set[str]()
    while todo:
        name = todo.pop()
        if name in seen or len(seen) > 4 * MAX_DEPTH or not scene.holds_camera(name):
            continue
        seen.add(name)
        toks = tokens(scene.text(name) or "")
        todo.extend(_literal_includes(toks))
        for i in range(len(toks)):
            if _camera_at(toks, i):
                found.add(toks[i + 2].text if i + 2 < len(toks) else "")
    return found


def refused_type(types: set[str]) -> str | None:
    """The one type ``types`` (``written_camera_types``) all open with, where it is in ``REFUSED_TYPES``;
    None otherwise (a perspective or orthographic camera, a camera copied from an identifier, a name
    computed at parse time, no camera, types mixed: the parse says which one runs)."""
    return next(iter(types)) if len(types) == 1 and types <= set(REFUSED_TYPES) else None


def written_camera_type(main: str, read: Callable[[str], str | None]) -> str | None:
    """``refused_type`` of the scene's written camera types."""
    return refused_type(written_camera_types(main, read))


def _camera_at(toks: list[Token], i: int) -> bool:
    return toks[i].text == "camera" and i + 1 < len(toks) and toks[i + 1].text == "{"


def _declared_name(toks: list[Token], i: int) -> str | None:
    """``Name`` of ``#declare Name = camera {`` at token i (the ``camera``), else None."""
    if i >= 3 and toks[i - 1].text == "=" and toks[i - 3].text in ("#declare", "#local"):
        return toks[i - 2].text
    return None


def _collect(name: str, scene: _Scene, depth: int) -> None:
    """Number every ``#declare X = camera {...}`` of the files holding cameras (before any use is written)."""
    text = scene.text(name) or ""
    toks = tokens(text)
    for i in range(len(toks)):
        if _camera_at(toks, i) and (ident := _declared_name(toks, i)) is not None and (name, i) not in scene.sites:
            close = _closing_brace(toks, i + 1)
            body = text[toks[i + 1].end:toks[close].start]
            declarations = scene.declarations.setdefault(ident, [])
            found = _Declaration(f"Povh3d_K{len(scene.sites)}", stored_items(body), len(declarations) + 1)
            declarations.append(found)
            scene.sites[(name, i)] = found
    for included in _literal_includes(toks):
        if depth < MAX_DEPTH and included not in scene.sites and scene.holds_camera(included):
            scene.sites[(included, -1)] = _Declaration("", [], 0)   # visited
            _collect(included, scene, depth + 1)


def _which(ident: str, scene: _Scene) -> str:
    return f"Povh3d_W{list(scene.declarations).index(ident)}"


Piece = tuple[str, "tuple[str, int] | None"]


def _rewritten(name: str, scene: _Scene, depth: int) -> list[Piece]:
    """The text of file ``name`` with its cameras rewritten and its camera-holding includes inlined, in
    pieces: ``(text, (file, line))`` for the file's own text from that line, ``(text, None)`` for povh3d's."""
    if depth > MAX_DEPTH:
        raise _cannot(f"its includes nest deeper than {MAX_DEPTH} files")
    text = scene.text(name) or ""
    toks = tokens(text)
    out: list[Piece] = []
    at, version, i = 0, None, 0

    def own(end: int) -> Piece:
        return text[at:end], (name, text.count("\n", 0, at) + 1)

    while i < len(toks):
        t = toks[i].text
        if t == "#version" and i + 1 < len(toks):
            number = re.match(r"\s*([0-9.]+)", text[toks[i].end:])
            version = number[1] if number else version
        if t == "#include" and i + 1 < len(toks):
            nxt = toks[i + 1].text
            if nxt.startswith('"') and scene.holds_camera(nxt[1:-1]):
                out += [own(toks[i].start), ("\n", None), *_rewritten(nxt[1:-1], scene, depth + 1), ("\n", None)]
                at = toks[i + 1].end
                i += 2
                continue
        if _camera_at(toks, i):
            close = _closing_brace(toks, i + 1)
            body = text[toks[i + 1].end:toks[close].start]
            ident = _declared_name(toks, i)
            if ident is not None:   # keep the declaration, and its values for a later camera { Name }
                d = scene.sites[(name, i)]
                undo = "\n".join(f"#ifdef ({d.store}_{k}) #undef {d.store}_{k} #end" for k, _ in d.items)
                out += [own(toks[close].end), ("\n" + undo + "\n" + _rewrite(_plain(body, ident), store=d.store)
                                               + f"\n#declare {_which(ident, scene)} = {d.number};\n", None)]
            elif i > 0 and toks[i - 1].text == "=":
                raise _cannot("a camera is a value inside another declaration, which povh3d cannot follow")
            else:
                if version is not None and _version(version) < (3, 5):
                    raise _cannot(f"the scene declares #version {version}, whose camera rules (modifiers "
                                  f"applied in order) povh3d does not reproduce")
                out += [own(toks[i].start), ("\n" + _statement(body, scene) + "\n", None)]
            at = toks[close].end
            i = close + 1
            continue
        i += 1
    out.append(own(len(text)))
    return out


def source_line(lines: tuple[tuple[int, str, int], ...], line: int, scene_name: str) -> str:
    """Where line ``line`` of a ``camera_script`` came from: ``"NAME line N"`` (the scene, or the file it
    includes as NAME), or povh3d's rewrite of a camera statement (file line 0 in ``lines``)."""
    starts = [entry for entry in lines if entry[0] <= line]
    if not starts or starts[-1][2] == 0:
        return f"povh3d's rewrite of a camera statement of {scene_name} or a file it includes"
    start, name, first = starts[-1]
    return f"{name or scene_name} line {first + line - start}"


def _plain(body: str, ident: str) -> str:
    inner = tokens(body)
    if inner and inner[0].text not in _KEYWORDS and not inner[0].text.startswith("#"):
        raise _cannot(f"its camera {ident!r} is declared as a copy of {inner[0].text!r}, which povh3d "
                      "cannot follow")
    return body


def _statement(body: str, scene: _Scene) -> str:
    """A ``camera { ... }`` statement as prints; ``camera { Name mods }`` starts from Name's kept values."""
    inner = tokens(body)
    if not inner or inner[0].text in _KEYWORDS or inner[0].text.startswith("#"):
        return _rewrite(body)
    ident = inner[0].text
    if ident not in scene.declarations:
        raise _cannot(f"it starts from the camera identifier {ident!r}, whose declaration povh3d cannot find")
    cases = "\n".join(f"#case ({d.number})\n{replay_code(d.store, d.items)}\n#break"
                      for d in scene.declarations[ident])
    replay = f"#switch ({_which(ident, scene)})\n{cases}\n#end"
    # camera { Name mods }: the camera declared as Name, then (POV-Ray >= 3.5) its modifiers.
    return _rewrite(body[inner[0].end:], replay=replay)
