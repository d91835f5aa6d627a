"""The scene's own camera, evaluated by POV-Ray itself.

POV-Ray gives a script no access to a camera's vectors once it is parsed.  So
povh3d finds the scene's last top-level ``camera { ... }`` statement in its
text (the one POV-Ray uses: a later camera replaces an earlier one), and
writes an evaluation script: the scene's text up to that statement, then the
statement's modifiers rewritten as ``#declare``s whose values ``#debug``
prints.  Every expression is evaluated by POV-Ray in the scene's own
declaration context (its identifiers, macros, ``#include``d vectors,
``image_width``); directives inside the block (``#if`` ...) stay in place, so
they choose as they would in the scene.  Python then applies POV-Ray 3.7's
camera rules (``Parser::Parse_Camera``, language version >= 3.5: right,
direction, angle, up, sky, location, look_at, then the camera's transforms)
to the values, in ``camera_from_log``.

What cannot be isolated this way (a camera inside a ``#macro`` or ``#if``, a
camera copied from an identifier, a camera in an included file) is a
``CameraError`` whose message names the ``--display-*`` options.

Pure: text in, text out; the run itself is the caller's.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError

_TOKEN = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|#\s*[A-Za-z_]\w*|[A-Za-z_]\w*|\S', re.S)
_OPENERS = {"#if", "#ifdef", "#ifndef", "#switch", "#while", "#for", "#macro"}
_VECTORS = ("location", "look_at", "sky", "right", "up", "direction")
_TRANSFORMS = ("translate", "rotate", "scale", "matrix", "transform")
_TYPES = ("perspective", "orthographic", "fisheye", "ultra_wide_angle", "omnimax", "panoramic",
          "spherical", "cylinder", "mesh_camera", "user_defined")
_DROPPED = ("aperture", "blur_samples", "confidence", "variance", "focal_point", "normal", "bokeh")
_KEYWORDS = set(_VECTORS) | set(_TRANSFORMS) | set(_TYPES) | set(_DROPPED) | {"angle"}
TAG = "povh3d-camera"


class CameraError(ConfigError):
    """The scene's camera cannot be evaluated; the message names the --display-* options."""


@dataclass(frozen=True)
class Token:
    text: str
    start: int
    end: int


def tokens(text: str) -> list[Token]:
    """POV-Ray tokens of ``text`` (comments dropped, strings whole, directives as ``#word``)."""
    out = []
    for m in _TOKEN.finditer(text):
        t = m.group()
        if t.startswith("//") or t.startswith("/*"):
            continue
        if t.startswith("#"):
            t = "#" + t[1:].strip()
        out.append(Token(t, m.start(), m.end()))
    return out


@dataclass(frozen=True)
class CameraStatement:
    """A top-level ``camera { ... }`` statement: token indices of ``camera``, ``{`` and ``}``."""

    start: int            # character offset of the keyword
    body: tuple[int, int]  # character offsets inside the braces
    directive_depth: int   # open #if/#while/#macro... around it


def _depths(toks: list[Token]) -> Iterator[tuple[int, int, int]]:
    """``(index, brace depth, directive depth)`` of every token, the depths before it."""
    braces = directives = 0
    for i, tok in enumerate(toks):
        yield i, braces, directives
        t = tok.text
        if t in _OPENERS:
            directives += 1
        elif t == "#end":
            directives = max(0, directives - 1)
        elif t == "{":
            braces += 1
        elif t == "}":
            braces -= 1


def _closing_brace(toks: list[Token], opening: int) -> int:
    """Index of the ``}`` that closes the ``{`` at ``opening``."""
    depth = 0
    for j in range(opening, len(toks)):
        depth += {"{": 1, "}": -1}.get(toks[j].text, 0)
        if depth == 0:
            return j
    raise CameraError("the scene's camera block has no closing brace; fix the scene")


def camera_statements(toks: list[Token]) -> list[CameraStatement]:
    """Every ``camera {`` at brace depth 0 that is not a ``#declare X = camera`` value."""
    found = []
    for i, braces, directives in _depths(toks):
        if (toks[i].text == "camera" and braces == 0 and (i == 0 or toks[i - 1].text != "=")
                and i + 1 < len(toks) and toks[i + 1].text == "{"):
            j = _closing_brace(toks, i + 1)
            found.append(CameraStatement(toks[i].start, (toks[i + 1].end, toks[j].start), directives))
    return found


#: The same words as ``geometry.frame.EXPLICIT_OPTIONS`` (scene/ does not import geometry/).
EXPLICIT_OPTIONS = "--display-center X,Y,Z --display-normal X,Y,Z [--display-up X,Y,Z] --display-width UNITS"


def _cannot(reason: str) -> CameraError:
    return CameraError(f"cannot use the scene's camera ({reason}); place the display with "
                       f"{EXPLICIT_OPTIONS}, or --display-frame native")


@dataclass(frozen=True)
class CameraScript:
    """The evaluation script and what was found on the way."""

    script: str
    cameras: int          # top-level camera statements in the scene file (the last counts)
    rest: str = ""        # the scene after its last camera: appended, with a camera of povh3d's own
                          # (``templates/camera_depth.pov.j2``), the same run renders the scene; the
                          # block's last values stay declared as ``Povh3d_Cam_location``, ...


def evaluation_script(text: str) -> CameraScript | None:
    """The script that prints the last camera's values, or None when the scene has no camera."""
    toks = tokens(text)
    statements = camera_statements(toks)
    if not statements:
        if any(t.text == "camera" for t in toks):
            raise _cannot("its camera is built inside a #macro or declared and copied, which povh3d "
                          "cannot isolate")
        return None
    last = statements[-1]
    versions = [t for t in toks if t.text == "#version" and t.start < last.start]
    if versions:
        number = re.match(r"\s*([0-9.]+)", text[versions[-1].end:])
        if number and _version(number[1]) < (3, 5):
            raise _cannot(f"the scene declares #version {number[1]}, whose camera rules (modifiers applied "
                          f"in order) povh3d does not reproduce")
    if last.directive_depth:
        raise _cannot("its last camera sits inside an #if, #while or #macro")
    # A camera after the last top-level one, inside a directive, would be the one POV-Ray uses.
    if any(t.text == "camera" and t.start > last.body[1] for t in toks):
        raise _cannot("a camera after the last top-level one is built by a directive or macro")
    body = text[last.body[0]:last.body[1]]
    inner = tokens(body)
    if inner and inner[0].text not in _KEYWORDS and not inner[0].text.startswith("#"):
        # camera { Name mods }: the camera declared as Name, then (POV-Ray >= 3.5) transforms only.
        declared = _declared_camera(toks, text, inner[0].text, last.start)
        body = declared + "\n" + body[inner[0].end:]
    return CameraScript(text[:last.start] + "\n" + _rewrite(body) + "\n", len(statements), text[last.body[1] + 1:])


def _declared_camera(toks: list[Token], text: str, name: str, before: int) -> str:
    """The body of the last top-level ``#declare name = camera { ... }`` before ``before``."""
    found = None
    for i, braces, directives in _depths(toks):
        if toks[i].start >= before:
            break
        if (toks[i].text in ("#declare", "#local") and braces == 0 and i + 4 < len(toks)
                and toks[i + 1].text == name and toks[i + 2].text == "=" and toks[i + 3].text == "camera"
                and toks[i + 4].text == "{"):
            found = (i + 4, directives)
    if found is None:
        raise _cannot(f"it starts from the camera identifier {name!r}, whose top-level declaration "
                      f"povh3d cannot find")
    start, depth_at = found
    if depth_at:
        raise _cannot(f"its camera identifier {name!r} is declared inside an #if, #while or #macro")
    return text[toks[start].end:toks[_closing_brace(toks, start)].start]


def _version(text: str) -> tuple[int, ...]:
    parts = [p for p in text.strip(".").split(".") if p.isdigit()]
    return tuple(int(p) for p in parts[:2]) or (0,)


def _rewrite(body: str) -> str:
    """The camera's modifiers as ``#declare``s and ``#debug`` lines, directives kept in place."""
    toks = tokens(body)
    out = ["#declare Povh3d_Cam_T = transform { scale 1 }"]
    i, depth = 0, 0

    def expression(i: int) -> tuple[str, int]:
        # From token i up to the next modifier or directive at depth 0.
        start, d, j = i, 0, i
        while j < len(toks):
            t = toks[j].text
            if d == 0 and j > start and (t in _KEYWORDS or t.startswith("#")):
                break
            d += {"(": 1, "{": 1, ")": -1, "}": -1}.get(t, 0)
            j += 1
        if j == start:
            raise _cannot(f"a camera modifier has no value near {body[toks[i - 1].start:][:30]!r}")
        return body[toks[start].start:toks[j - 1].end], j

    if toks and toks[0].text not in _KEYWORDS and not toks[0].text.startswith("#"):
        raise _cannot(f"it starts from the camera identifier {toks[0].text!r}")
    open_directives = 0
    while i < len(toks):
        t = toks[i].text
        if t.startswith("#"):
            open_directives += 1 if t in _OPENERS else -1 if t == "#end" else 0
            if t in ("#declare", "#local"):
                j = i
                while j < len(toks) and toks[j].text != ";":
                    j += 1
                out.append(body[toks[i].start:toks[min(j, len(toks) - 1)].end])
                i = j + 1
                continue
            j = i + 1
            if t in ("#debug", "#warning", "#error") and j < len(toks):
                j += 1  # its message: a string, or a call such as concat(...)
            if j < len(toks) and toks[j].text == "(" and t not in ("#else", "#end", "#break"):
                depth = 0
                while j < len(toks):
                    depth += {"(": 1, ")": -1}.get(toks[j].text, 0)
                    j += 1
                    if depth == 0:
                        break
            out.append(body[toks[i].start:toks[j - 1].end] if j > i + 1 else t)
            i = j
        elif t in _VECTORS:
            expr, i = expression(i + 1)
            out.append(f'#declare Povh3d_Cam_V = <0, 0, 0> + ({expr}\n);\n' + _debug(t, "Povh3d_Cam_V"))
            out.append(f"#declare Povh3d_Cam_{t} = Povh3d_Cam_V;")
        elif t == "angle":
            expr, i = expression(i + 1)
            out.append(f'#declare Povh3d_Cam_F = ({expr}\n);\n' + _debug("angle", "Povh3d_Cam_F", 1))
            out.append("#declare Povh3d_Cam_angle = Povh3d_Cam_F;")
        elif t in _TRANSFORMS:
            expr, i = expression(i + 1)
            out.append(f"#declare Povh3d_Cam_T = transform {{ transform Povh3d_Cam_T {t} {expr}\n}}")
        elif t in _TYPES:
            out.append(f'#debug "{TAG} type {t}\\n"')
            if t != "perspective" and not open_directives:
                break   # not a perspective camera: its other modifiers (two angles...) need no values
            i += 1
            if i < len(toks) and (t in ("cylinder", "mesh_camera", "user_defined")):
                _, i = expression(i)
        elif t in _DROPPED:
            _, i = expression(i + 1) if i + 1 < len(toks) else ("", i + 1)
        else:
            raise _cannot(f"povh3d does not know the camera modifier {t!r}")
    # transforms.inc's vtransform, inlined: the scene need not include it.
    out.append("#declare Povh3d_Cam_Fn = function { transform { Povh3d_Cam_T } }")
    for p in ("0, 0, 0", "1, 0, 0", "0, 1, 0", "0, 0, 1"):
        out.append(f"#declare Povh3d_Cam_V = Povh3d_Cam_Fn({p});\n" + _debug("transform", "Povh3d_Cam_V"))
    out.append(f'#debug "{TAG} end\\n"')
    return "\n".join(out)


def _debug(key: str, name: str, n: int = 3) -> str:
    """``#debug`` lines of one value, a number a line: POV-Ray wraps its console at 80 columns."""
    parts = [f"{name}.{c}" for c in "xyz"] if n == 3 else [name]
    return "\n".join(f'#debug concat("{TAG} {key} ", str({p}, 0, 17), "\\n")' for p in parts)


@dataclass(frozen=True)
class SceneCamera:
    """A perspective camera as POV-Ray computes it (scene units).

    location, direction, right, up : (3,) floats after look_at and transforms
    look_at : (3,) or None         the transformed look_at point (None: not given)
    kind : str                     'perspective', 'orthographic', ...
    """

    location: tuple[float, ...]
    direction: tuple[float, ...]
    right: tuple[float, ...]
    up: tuple[float, ...]
    look_at: tuple[float, ...] | None
    kind: str = "perspective"
    cameras: int = 1
    values: dict = field(default_factory=dict, compare=False)

    def as_record(self) -> dict:
        return {"type": self.kind, "location": list(self.location), "direction": list(self.direction),
                "right": list(self.right), "up": list(self.up),
                "look_at": None if self.look_at is None else list(self.look_at), "cameras": self.cameras}


def parse_log(log: str) -> list[tuple[str, list[float] | str]]:
    """The ``povh3d-camera`` lines of a POV-Ray log, in order."""
    items: list[tuple[str, list[float] | str]] = []
    for line in log.splitlines():
        if not line.startswith(TAG + " "):
            continue
        parts = line[len(TAG) + 1:].split()
        if not parts:
            continue
        key, rest = parts[0], parts[1:]
        if key == "type":
            items.append((key, rest[0] if rest else "perspective"))
        elif key == "end":
            items.append((key, ""))
        else:  # a number a line: three make a vector (twelve the transform)
            size = {"angle": 1, "transform": 12, "depth_frame": 14}.get(key, 3)
            last = items[-1] if items else None
            if last is not None and last[0] == key and isinstance(last[1], list) and len(last[1]) < size:
                last[1].append(float(rest[0]))
            else:
                items.append((key, [float(rest[0])]))
    return items


def camera_from_log(log: str, cameras: int = 1) -> SceneCamera:
    """POV-Ray 3.7's camera (``Parser::Parse_Camera``, version >= 3.5) from the evaluated modifiers."""
    items = parse_log(log)
    ends = [i for i, (key, _) in enumerate(items) if key == "end"]
    items = items[:ends[0] + 1] if ends else items   # a run of several frames prints it once a frame
    if not items or items[-1][0] != "end":
        raise _cannot("POV-Ray did not reach the end of its camera block")
    v = {"location": np.zeros(3), "direction": np.array([0.0, 0, 1]), "up": np.array([0.0, 1, 0]),
         "right": np.array([1.33, 0, 0]), "sky": np.array([0.0, 1, 0])}
    look_at = angle = None
    kind, transform = "perspective", None
    for key, value in items:
        if key == "type":
            kind = str(value)
        elif key == "look_at":
            look_at = np.array(value)
        elif key == "angle":
            angle = float(value[0])
        elif key == "transform":
            transform = np.array(value).reshape(4, 3)
        elif key in v:
            v[key] = np.array(value)
    d, r, u, sky = v["direction"], v["right"], v["up"], v["sky"]
    if angle is not None and angle > 0:
        if angle >= 180:
            raise _cannot(f"its angle {angle} is not below 180 degrees")
        d = d / np.linalg.norm(d) * (np.linalg.norm(r) / np.tan(np.radians(angle) / 2) / 2)
    if look_at is not None:
        dl, ul, rl = np.linalg.norm(d), np.linalg.norm(u), np.linalg.norm(r)
        handed = float(np.dot(np.cross(u, d), r))
        d = look_at - v["location"]
        if np.dot(d, d) < 1e-10:
            raise _cannot("its location equals its look_at")
        d = d / np.linalg.norm(d)
        new_r = np.cross(sky, d)
        if np.all(np.abs(new_r) < 1e-10):
            new_r = r   # POV-Ray warns and keeps the supplied right vector
        r = new_r / np.linalg.norm(new_r)
        u = np.cross(d, r)
        d, r, u = d * dl, r * (rl if handed > 0 else -rl), u * ul
    loc = v["location"]
    if transform is not None:
        origin, lin = transform[0], transform[1:] - transform[0]
        loc, d, r, u = loc @ lin + origin, d @ lin, r @ lin, u @ lin
        if look_at is not None:
            look_at = look_at @ lin + origin
    tup = lambda a: tuple(float(x) for x in a)  # noqa: E731
    return SceneCamera(tup(loc), tup(d), tup(r), tup(u), None if look_at is None else tup(look_at), kind,
                       cameras)
