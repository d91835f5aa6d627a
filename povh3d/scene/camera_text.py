"""A camera the scene text alone decides: one ``camera { ... }`` statement of literal values.

Most scenes write their camera as numbers: ``camera { location <-8, 4, -14> angle 40
right x*image_width/image_height look_at <-2, 0, -4> }``.  Such a camera needs no POV-Ray run
to be known: ``literal_camera`` reads its modifiers as ``scene.camera.parse_log`` would from
the run (the same items, so ``camera_from_items`` applies the same rules).  Anything else
returns None and the camera is evaluated by POV-Ray (``renderer.passes.scene_camera``): a
second camera word anywhere the parse may reach (an include holding one, a declared camera: but
``camera { NAME }`` reads the one ``#declare NAME = camera { ... }`` of literal values before it, as
POV-Ray's scene templates write theirs), a camera inside braces or a directive (``#if``, a macro), an include whose name is computed,
a ``#version`` before 3.5, any identifier, transform, type other than perspective or modifier
outside the plain ones, and a vector of other than three components.

Pure: text in, items out; reading the included files is the caller's ``read`` function.
"""

from __future__ import annotations

import operator
import re
from collections.abc import Callable

from .camera import _VECTORS, CameraError, _closing_brace, _depths, _version, tokens

_PART = re.compile(r"//[^\n]*|/\*.*?\*/|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[A-Za-z_]\w*|\S", re.S)
_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}

Value = float | tuple[float, float, float]


class _NotLiteral(Exception):
    pass


def literal_camera(main: str, read: Callable[[str], str | None], size: tuple[int, int]
                   ) -> list[tuple[str, list[float] | str]] | None:
    """The items of the scene's one literal camera (``image_width x image_height`` = ``size``), or None."""
    from .camera_script import _literal_includes, _Scene

    toks = tokens(main)
    for i, t in enumerate(toks[:-1]):
        if t.text == "#version":
            number = "".join(x.text for x in toks[i + 1:i + 5]).split(";")[0]
            if not re.fullmatch(r"\d+(\.\d*)?", number) or _version(number) < (3, 5):
                return None
        if t.text == "#include" and not toks[i + 1].text.startswith('"'):
            return None   # a computed name: what it holds is known only to the parse
    scene = _Scene(read)
    if any(scene.holds_camera(name) for name in _literal_includes(toks)):
        return None
    sites = [i for i, t in enumerate(toks) if t.text == "camera"]
    uses = [i for i in sites if not (i > 0 and toks[i - 1].text == "=")]
    if len(uses) != 1 or any(i + 1 >= len(toks) or toks[i + 1].text != "{" for i in sites):
        return None
    depth = {i: (braces, directives) for i, braces, directives in _depths(toks)}
    at = uses[0]
    if depth[at] != (0, 0):
        return None
    try:
        close = _closing_brace(toks, at + 1)
        if close == at + 3 and sites != uses:   # camera { NAME }: the one declaration of NAME, before it
            at = _declared(toks, depth, sites, toks[at + 2].text, at)
            close = _closing_brace(toks, at + 1)
        elif sites != uses:
            return None
        return _items(main[toks[at + 1].end:toks[close].start], size)
    except (_NotLiteral, ArithmeticError, CameraError):
        return None


def _declared(toks: list, depth: dict[int, tuple[int, int]], sites: list[int], name: str, use: int) -> int:
    """The ``camera`` token of ``#declare name = camera { ... }``, the scene's only assignment of
    ``name``, at the top level and before ``use`` (the templates' ``#declare Camera_0 = camera {...}``
    ... ``camera { Camera_0 }``); the scene's other declared cameras are never used."""
    assigned = [i for i in range(1, len(toks) - 1) if toks[i].text == name and toks[i - 1].text in ("#declare", "#local")]
    if len(assigned) != 1 or toks[assigned[0] + 1].text != "=":
        raise _NotLiteral
    at = assigned[0] + 2
    if at not in sites or at > use or depth[assigned[0] - 1] != (0, 0) or toks[assigned[0] - 1].text != "#declare":
        raise _NotLiteral
    return at


def _items(body: str, size: tuple[int, int]) -> list[tuple[str, list[float] | str]]:
    parts = [p for p in _PART.findall(body) if not p.startswith(("//", "/*"))]
    items: list[tuple[str, list[float] | str]] = []
    names = {"image_width": float(size[0]), "image_height": float(size[1])}
    pos = 0

    def peek() -> str:
        return parts[pos] if pos < len(parts) else ""

    def take() -> str:
        nonlocal pos
        if pos >= len(parts):
            raise _NotLiteral
        pos += 1
        return parts[pos - 1]

    def expression() -> Value:
        value = term()
        while peek() in ("+", "-"):
            op, other = take(), term()
            value = _apply(op, value, other)
        return value

    def term() -> Value:
        value = factor()
        while peek() in ("*", "/"):
            op, other = take(), factor()
            value = _apply(op, value, other)
        return value

    def factor() -> Value:
        t = take()
        if t in ("-", "+"):
            value = factor()
            return _apply("*", -1.0 if t == "-" else 1.0, value)
        if t == "(":
            value = expression()
            if take() != ")":
                raise _NotLiteral
            return value
        if t == "<":
            components = [expression()]
            while peek() == ",":
                take()
                components.append(expression())
            if take() != ">" or len(components) != 3:
                raise _NotLiteral
            x, y, z = components
            if not (isinstance(x, float) and isinstance(y, float) and isinstance(z, float)):
                raise _NotLiteral
            return (x, y, z)
        if t in _AXES:
            return _AXES[t]
        if t in names:
            return names[t]
        if t[0].isdigit() or t[0] == ".":
            return float(t)
        raise _NotLiteral

    while pos < len(parts):
        t = take()
        if t == "perspective":
            items.append(("type", "perspective"))
        elif t in _VECTORS:
            value = expression()
            items.append((t, list(value) if isinstance(value, tuple) else [value] * 3))
        elif t == "angle":
            value = expression()
            if not isinstance(value, float):
                raise _NotLiteral
            items.append(("angle", [value]))
        else:
            raise _NotLiteral
    return items


_OPS = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv}


def _apply(op: str, a: Value, b: Value) -> Value:
    f = _OPS[op]
    if isinstance(a, float) and isinstance(b, float):
        return f(a, b)
    va = a if isinstance(a, tuple) else (a, a, a)   # POV-Ray promotes a float to <f, f, f>
    vb = b if isinstance(b, tuple) else (b, b, b)
    return (f(va[0], vb[0]), f(va[1], vb[1]), f(va[2], vb[2]))
