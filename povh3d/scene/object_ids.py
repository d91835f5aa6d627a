"""The mask copy of a scene: every top-level object painted one flat colour that is its id.

POV-Ray has no per-object id output, and a texture on a wrapper never overrides the textures
inside it.  So the copy is made from the scene's text: every texture-like block inside a
statement (``texture``, ``pigment``, ``finish``, ``normal``, ``material``, ``interior``...) is
removed, the blocks that are a ``#declare``'s value are kept (unused), the atmosphere and the
background go, and each top-level object statement ends with one texture of pure emission whose
colour codes its id (``id_colour``).  Rendered without antialiasing, every pixel is the id of the
object its ray first hits.

The code: object ``k``'s 24-bit number ``k * ID_MULTIPLIER mod 2**24`` split into three bytes,
each the 8-bit sRGB code of one channel, its pigment the linear value of that code.  POV-Ray
writes exactly those codes (8 bits) or 257 times them (16 bits), so the id is read back by
integer arithmetic (``hyper.ids``): the number times the multiplier's inverse.  A colour that is
no id (black is the background, 0) decodes past ``MAX_OBJECTS`` but for one colour in 16,777
(1000 in 2**24); every grey, and every colour of one channel or of two equal ones, does (the
red below included).

What it cannot split: objects made by a macro or a loop at the top level, objects in included
files with their own textures, ``mesh2`` texture lists; their pixels carry a colour that is no
id and ``decode_ids`` marks them ``UNRESOLVED``.

Pure: text in, text out.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..errors import ConfigError
from .camera import _OPENERS, CameraError, Token, _closing_brace, _depths, tokens

OBJECTS = frozenset(("sphere box cylinder cone torus plane union difference intersection merge object mesh "
                     "mesh2 blob text lathe sor prism superellipsoid height_field isosurface parametric polygon "
                     "disc triangle smooth_triangle bicubic_patch julia_fractal cubic quartic poly polynomial "
                     "sphere_sweep ovus lemon quadric").split())
_SURFACE = frozenset(("texture pigment finish normal material interior interior_texture").split())
_ATMOSPHERE = frozenset(("fog sky_sphere background rainbow media").split())
MAX_OBJECTS = 1000            # of the 2**24 codes: a colour that is no id passes for one at 1000 / 2**24
UNRESOLVED = 65535
ID_MULTIPLIER = 0x9E3779      # odd (invertible mod 2**24); neighbouring ids get unlike colours
# objects no top-level statement paints (made by macros, in include files) show pure red: no id
# (#version first: before it POV-Ray reads an older language, where emission is not a finish)
_GAMMA = re.compile(r"\bassumed_gamma\s+(?:srgb\b|[0-9.+\-*/() ]+)", re.I)
_UNSPLIT = "#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n#default { texture { pigment { rgb <1, 0, 0> } finish { emission 1 diffuse 0 ambient 0 } } }\n"
_ID_FINISH = "finish { emission 1 diffuse 0 ambient 0 specular 0 phong 0 reflection 0 }"


class ObjectsError(ConfigError):
    """The scene's objects cannot be told apart."""


@dataclass(frozen=True)
class MaskScene:
    text: str
    names: dict[int, str]      # id -> the object's identifier (object { Name }) or "keyword_LINE"


def id_code(ident: int) -> tuple[int, int, int]:
    """The 8-bit sRGB codes (R, G, B) of object ``ident`` (1..MAX_OBJECTS)."""
    number = (int(ident) * ID_MULTIPLIER) & 0xFFFFFF
    return number >> 16, (number >> 8) & 0xFF, number & 0xFF


def id_colour(ident: int) -> str:
    """The linear ``rgb <r, g, b>`` vector POV-Ray writes as object ``ident``'s codes (sRGB output)."""
    return "<" + ", ".join(repr(_srgb_to_linear(c / 255)) for c in id_code(ident)) + ">"


def _srgb_to_linear(v: float) -> float:
    # IEC 61966-2-1, as POV-Ray's sRGB output encodes it (its inverse): each code comes back exactly
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4


def _block_end(toks: list[Token], opening: int) -> int:
    try:
        return _closing_brace(toks, opening)
    except CameraError:   # its message speaks of the camera; here any block is meant
        raise ObjectsError("the scene has a block without its closing brace; fix the scene") from None


def _macro_bodies(toks: list[Token]) -> list[bool]:
    """Whether each token is inside a ``#macro`` body (its objects are made where it is called)."""
    stack: list[str] = []
    out = []
    for tok in toks:
        if tok.text in _OPENERS:
            stack.append(tok.text)
        elif tok.text == "#end" and stack:
            stack.pop()
        out.append("#macro" in stack)
    return out


def mask_scene(text: str) -> MaskScene:
    """The mask copy of a scene's text (see the module docstring)."""
    toks = tokens(text)
    depth_of = {i: b for i, b, _ in _depths(toks)}
    in_macro = _macro_bodies(toks)
    cut: list[tuple[int, int]] = []           # character spans removed
    ends: list[tuple[int, int]] = []          # (offset of a top-level object's closing brace, id)
    names: dict[int, str] = {}
    i = 0
    while i < len(toks):
        t = toks[i].text
        opens = i + 1 < len(toks) and toks[i + 1].text == "{"
        declared = i > 0 and toks[i - 1].text == "="
        if opens and not declared and t in _SURFACE | (_ATMOSPHERE if depth_of[i] == 0 else frozenset()):
            j = _block_end(toks, i + 1)
            cut.append((toks[i].start, toks[j].end))
            i = j + 1
            continue
        if opens and not declared and depth_of[i] == 0 and t in OBJECTS and not in_macro[i]:
            j = _block_end(toks, i + 1)
            ident = len(names) + 1
            inner = toks[i + 2].text if t == "object" and i + 2 < j else ""
            line = text.count("\n", 0, toks[i].start) + 1
            names[ident] = inner if re.match(r"^[A-Za-z_]\w*$", inner) and inner not in OBJECTS \
                else f"{t}_{line}"
            ends.append((toks[j].start, ident))
        i += 1
    if not names:
        raise ObjectsError("the scene has no top-level object statements to tell apart (its objects come from "
                           "macros, loops or included files); give them each a top-level statement")
    if len(names) > MAX_OBJECTS:
        raise ObjectsError(f"the scene has {len(names)} top-level objects; object masks tell at most "
                           f"{MAX_OBJECTS} apart")
    inserts = {at: f" texture {{ pigment {{ rgb {id_colour(k)} }} {_ID_FINISH} }} " for at, k in ends}
    out, pos = [], 0
    for at in sorted([(s, e, None) for s, e in cut] + [(a, a, v) for a, v in inserts.items()]):
        start, end, insert = at
        if start < pos:                       # an insert inside a removed span cannot happen: objects
            continue                          # are never inside surface blocks
        out.append(text[pos:start])
        if insert is not None:
            out.append(insert)
        pos = end
    out.append(text[pos:])
    # the ids are linear colours: the scene's own assumed_gamma would bend them, and POV-Ray keeps
    # the first one it reads, so it goes and povh3d's comes first
    body = _GAMMA.sub(" ", "".join(out))
    return MaskScene(_UNSPLIT + body + "\nbackground { rgb 0 }\n", names)
