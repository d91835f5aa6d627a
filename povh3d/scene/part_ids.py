"""The mask copy of a converted model's or a volume's include: every part its own id.

povh3d writes a model (``mesh.write``) and a volume's surfaces (``volume.include``) as one
``mesh2`` per part, alone or in one ``union``: an OBJ object or group, a glTF node, a 3MF
object, the surface of one label or one iso value.  The copy gives part ``n`` (the include's
``n``-th ``mesh2``) the id ``n``: every ``texture`` block inside its ``mesh2`` (its own, and
each one of its ``texture_list``, so that a face's texture index still finds one) becomes the
id's emission texture (``object_ids.id_colour``); a ``mesh2`` without one gets it.

Pure: text in, text out.  Only braces, comments and strings are scanned, not the numbers, so
a model of millions of triangles is copied at the speed of a regular expression.
"""

from __future__ import annotations

import re

from .object_ids import _ID_FINISH, MAX_OBJECTS, ObjectsError, id_colour
from ..errors import param

_SCAN = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:[^"\\\n]|\\.)*"|\bmesh2\b|\btexture\b|[{}]', re.S)


def id_texture(ident: int) -> str:
    """The emission texture whose colour codes object ``ident``'s id."""
    return f"texture {{ pigment {{ rgb {id_colour(ident)} }} {_ID_FINISH} }}"


def part_ids_include(text: str, parts: int) -> str:
    """The include ``text`` with its ``parts`` ``mesh2`` blocks painted ids 1..parts, in order.

    Raises ``ObjectsError`` when the include holds another number of ``mesh2`` blocks (it is not
    the one the names came with) or more parts than masks tell apart."""
    if parts > MAX_OBJECTS:
        raise ObjectsError(f"the model has {parts} parts; object masks tell at most {MAX_OBJECTS} apart")
    out: list[str] = []
    pos = depth = part = 0
    pending = ""                    # a keyword waiting for its opening brace
    pending_at = 0
    part_depth = texture_depth = 0  # the depth of the open mesh2 / texture block, 0: none
    texture_at = 0
    painted = False
    for match in _SCAN.finditer(text):
        tok = match.group()
        if tok[0] in '/"':
            continue
        if tok in ("mesh2", "texture"):
            pending, pending_at = tok, match.start()
            continue
        if tok == "{":
            depth += 1
            if pending == "mesh2" and not part_depth:
                part, part_depth, painted = part + 1, depth, False
            elif pending == "texture" and part_depth and not texture_depth:
                texture_depth, texture_at = depth, pending_at
            pending = ""
            continue
        if texture_depth and depth == texture_depth:     # a texture block closes: the id's instead
            out += [text[pos:texture_at], id_texture(part)]
            pos, texture_depth, painted = match.end(), 0, True
        elif part_depth and depth == part_depth:         # its mesh2 closes
            if not painted:
                out += [text[pos:match.start()], id_texture(part), "\n"]
                pos = match.start()
            part_depth = 0
        depth -= 1
        pending = ""
    if part != parts:
        raise ObjectsError(f"the converted include holds {part} mesh2 parts, not the {parts} its record names; "
                           f"render without {param('objects')} once to convert it again")
    out.append(text[pos:])
    return "".join(out)


def part_table(names: list[str]) -> dict[int, str]:
    """Ids 1..n for the parts' names in include order, each name unique (``name (2)``) and not empty."""
    table: dict[int, str] = {}
    seen: set[str] = set()
    for ident, name in enumerate(names, start=1):
        base = " ".join(str(name).split()) or f"part {ident}"
        unique, n = base, 2
        while unique in seen:
            unique, n = f"{base} ({n})", n + 1
        seen.add(unique)
        table[ident] = unique
    return table
