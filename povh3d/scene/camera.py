"""The scene's own camera, evaluated by POV-Ray itself.

POV-Ray gives a script no access to a camera's vectors once it is parsed.  So
povh3d rewrites each ``camera { ... }`` statement's modifiers as ``#declare``s
whose values ``#debug`` prints (``_rewrite``; which statements, and how the
scene's includes and declared cameras are followed: ``camera_script``).  Every
expression is evaluated by POV-Ray in the scene's own declaration context (its
identifiers, macros, ``#include``d vectors, ``image_width``); directives inside
the block (``#if`` ...) stay in place, so they choose as they would in the
scene.  Python then applies POV-Ray 3.7's camera rules (``Parser::Parse_Camera``,
language version >= 3.5: right, direction, angle, up, sky, location, look_at,
then the camera's transforms) to the values of the last block the parse
printed, in ``camera_from_log``.

Pure: text in, text out; the run itself is the caller's.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError, param

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


#: The same words as ``geometry.pose.EXPLICIT_OPTIONS`` (scene/ does not import geometry/).
EXPLICIT_OPTIONS = f"{param('placement.center')} X,Y,Z {param('placement.normal')} X,Y,Z [{param('placement.up')} X,Y,Z] {param('placement.width')} UNITS"


def _cannot(reason: str) -> CameraError:
    return CameraError(f"cannot use the scene's camera ({reason}); place the display with "
                       f"{EXPLICIT_OPTIONS}, or {param('placement.mode')} native")


@dataclass(frozen=True)
class CameraScript:
    """The evaluation script and what was found on the way."""

    script: str
    cameras: int          # camera statements the parse ran (0: known only from the run's log)
    rest: str = ""        # appended (with a camera of povh3d's own, ``templates/camera_depth.pov.j2``)
                          # the same run renders the scene; the last block's values stay declared as
                          # ``Povh3d_Cam_location``, ...
    lines: tuple[tuple[int, str, int], ...] = ()   # (script line, file, its line): camera_script.source_line


def _version(text: str) -> tuple[int, ...]:
    parts = [p for p in text.strip(".").split(".") if p.isdigit()]
    return tuple(int(p) for p in parts[:2]) or (0,)


def _rewrite(body: str, store: str | None = None, replay: str = "") -> str:
    """The camera's modifiers as ``#declare``s and ``#debug`` lines, directives kept in place.

    ``store``: a declared camera (``#declare Name = camera {...}``): its values are kept as
    ``{store}_{i}`` (one a modifier) and its transform as ``{store}_T``, nothing printed, so that
    ``camera { Name ... }`` prints them later (``replay``: that code, put before the modifiers).
    """
    toks = tokens(body)
    out = ["" if store is not None else _RESET, "#declare Povh3d_Cam_T = transform { scale 1 }", replay]
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

    def keep(key: str, value: str, n: int = 3) -> str:
        # print mode: print it and declare Povh3d_Cam_<key>; store mode: keep it as {store}_{i}
        if store is not None:
            return f"#declare {store}_{i} = {value};"
        return (f"#declare Povh3d_Cam_V = {value};\n" + _debug(key, "Povh3d_Cam_V", n)
                + f"\n#declare Povh3d_Cam_{key} = Povh3d_Cam_V;")

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
            at = i
            expr, i = expression(i + 1)
            i, at = at, i
            out.append(keep(t, f"<0, 0, 0> + ({expr}\n)"))
            i = at
        elif t == "angle":
            at = i
            expr, i = expression(i + 1)
            i, at = at, i
            out.append(keep("angle", f"({expr}\n)", 1))
            i = at
        elif t in _TRANSFORMS:
            expr, i = expression(i + 1)
            out.append(f"#declare Povh3d_Cam_T = transform {{ transform Povh3d_Cam_T {t} {expr}\n}}")
        elif t in _TYPES:
            out.append(f"#declare {store}_{i} = 1;" if store is not None else f'#debug "{TAG} type {t}\\n"')
            if t not in ("perspective", "orthographic") and not open_directives:
                break   # no frame from it: its other modifiers (two angles...) need no values
                        # (an orthographic one's give the --display-* options to use instead)
            i += 1
            if i < len(toks) and (t in ("cylinder", "mesh_camera", "user_defined")):
                _, i = expression(i)
        elif t in _DROPPED:
            out.append(f"#declare {store}_{i} = 1;" if store is not None else f'#debug "{TAG} dropped {t}\\n"')
            _, i = expression(i + 1) if i + 1 < len(toks) else ("", i + 1)
        else:
            raise _cannot(f"povh3d does not know the camera modifier {t!r}")
    if store is not None:
        out.append(f"#declare {store}_T = transform {{ Povh3d_Cam_T }}")
        return "\n".join(out)
    # transforms.inc's vtransform, inlined: the scene need not include it.
    # (a camera built by a macro called twice: a function cannot be declared again without #undef)
    out.append("#ifdef (Povh3d_Cam_Fn) #undef Povh3d_Cam_Fn #end\n"
               "#declare Povh3d_Cam_Fn = function { transform { Povh3d_Cam_T } }")
    for p in ("0, 0, 0", "1, 0, 0", "0, 1, 0", "0, 0, 1"):
        out.append(f"#declare Povh3d_Cam_V = Povh3d_Cam_Fn({p});\n" + _debug("transform", "Povh3d_Cam_V"))
    out.append(f'#debug "{TAG} end\\n"')
    return "\n".join(out)


def stored_items(body: str) -> list[tuple[int, str]]:
    """``(i, key)`` of each value ``_rewrite(body, store=...)`` keeps as ``{store}_{i}``, in order: key
    a vector's name, ``angle``, ``type:<kind>`` or ``dropped:<word>``."""
    toks = tokens(body)
    found = []
    for i, tok in enumerate(toks):
        t = tok.text
        if t in _VECTORS or t == "angle":
            found.append((i, t))
        elif t in _TYPES:
            found.append((i, f"type:{t}"))
        elif t in _DROPPED:
            found.append((i, f"dropped:{t}"))
    return found


def replay_code(store: str, items: list[tuple[int, str]]) -> str:
    """Print a stored camera's values (``stored_items``) as ``_rewrite`` prints its own, each only if the
    declaration set it, and start from its transform."""
    out = []
    for i, key in items:
        var = f"{store}_{i}"
        if key.startswith("type:"):
            line = f'#debug "{TAG} type {key[5:]}\\n"'
        elif key.startswith("dropped:"):
            line = f'#debug "{TAG} dropped {key[8:]}\\n"'
        else:
            n = 1 if key == "angle" else 3
            line = (f"#declare Povh3d_Cam_V = {var};\n" + _debug(key, "Povh3d_Cam_V", n)
                    + f"\n#declare Povh3d_Cam_{key} = Povh3d_Cam_V;")
        out.append(f"#ifdef ({var})\n{line}\n#end")
    out.append(f"#declare Povh3d_Cam_T = transform {{ {store}_T }}")
    return "\n".join(out)


#: A camera statement starts from POV-Ray's defaults: no value of an earlier camera is left.
_RESET = "\n".join(f"#ifdef (Povh3d_Cam_{k}) #undef Povh3d_Cam_{k} #end" for k in (*_VECTORS, "angle")) \
    + f'\n#debug "{TAG} begin\\n"'


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
    dropped: tuple[str, ...] = ()   # modifiers a placement does not reproduce (aperture, normal ...)

    def as_record(self) -> dict:
        return {"type": self.kind, "location": list(self.location), "direction": list(self.direction),
                "right": list(self.right), "up": list(self.up),
                "look_at": None if self.look_at is None else list(self.look_at), "cameras": self.cameras,
                "dropped": list(self.dropped)}


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
        elif key == "dropped":
            items.append((key, rest[0] if rest else ""))
        elif key in ("end", "begin", "parse"):
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
    parses = [i for i, (key, _) in enumerate(items) if key == "parse"]
    if parses:   # a run of several frames parses the scene once a frame: the first parse
        items = items[parses[0]:parses[1] if len(parses) > 1 else None]
    begins = [i for i, (key, _) in enumerate(items) if key == "begin"]
    if parses and not begins:
        raise _cannot("POV-Ray's parse reaches none of its camera statements (an #if or a macro never "
                      "called), so POV-Ray would use its default camera")
    if begins:   # every camera statement the parse ran printed a block: the last one counts
        cameras = len(begins)
        items = items[begins[-1] + 1:]
    ends = [i for i, (key, _) in enumerate(items) if key == "end"]
    items = items[:ends[0] + 1] if ends else items
    if not items or items[-1][0] != "end":
        raise _cannot("POV-Ray did not reach the end of its camera block")
    return camera_from_items(items, cameras)


def camera_from_items(items: list[tuple[str, list[float] | str]], cameras: int = 1) -> SceneCamera:
    """POV-Ray 3.7's camera from one block's modifiers in order (``parse_log``'s items: ``type``,
    ``location`` ... as values), from a run's log or from the scene text (``scene.camera_text``)."""
    dropped = tuple(dict.fromkeys(str(v) for k, v in items if k == "dropped"))
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
                       cameras, dropped=dropped)
