"""The user's POV-Ray scene: where it is, what it reads, and a digest of it all.

A scene may ``#include`` files and read images or fonts beside it.  Every file a
string literal in the scene (or, recursively, in what it includes) names and
that exists beside the scene or in an include folder is part of its content:
the cache key changes when any of them does.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

from .errors import InputError

_STRING = re.compile(r'"([^"\n]{1,400})"')
_COMMENTS = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_GAMMA = re.compile(r"\bassumed_gamma\b")


@dataclass(frozen=True)
class Scene:
    """A scene file, its include folders and the files it depends on.

    Attributes
    ----------
    path : Path               the scene, absolute
    include_dirs : tuple[Path, ...]   the scene's folder first, then the user's
    files : tuple[Path, ...]  the scene and every file it was found to read
    digest : str              sha256 over the files' names and contents
    sets_assumed_gamma : bool
    """

    path: Path
    include_dirs: tuple[Path, ...]
    files: tuple[Path, ...]
    digest: str
    sets_assumed_gamma: bool


def _read_text(path: Path) -> str:
    return path.read_bytes().decode("latin-1")  # POV-Ray sources are bytes; never fail on encoding


def load_scene(path: str | Path, include_dirs: tuple[str | Path, ...] = ()) -> Scene:
    """Find a scene and the files it reads; raise InputError when it is not there."""
    scene = Path(path)
    if not scene.exists():
        raise InputError(f"scene file {str(path)!r} does not exist; check the path")
    if not scene.is_file():
        raise InputError(f"scene {str(path)!r} is not a file; give a .pov file")
    scene = scene.resolve()
    dirs = [scene.parent]
    for d in include_dirs:
        d = Path(d).resolve()
        if not d.is_dir():
            raise InputError(f"include folder {str(d)!r} does not exist; check --include")
        if d not in dirs:
            dirs.append(d)

    seen: dict[Path, None] = {}
    pending = [scene]
    sets_gamma = False
    while pending:
        current = pending.pop()
        if current in seen:
            continue
        seen[current] = None
        if current.suffix.lower() not in (".pov", ".inc", ".mcr", ".ini", ".txt", ".csv"):
            continue  # images, fonts, density files: hash them, do not parse them
        try:
            text = _COMMENTS.sub("", _read_text(current))
        except OSError as exc:
            raise InputError(f"cannot read {str(current)!r}: {exc.strerror}") from None
        sets_gamma = sets_gamma or bool(_GAMMA.search(text))
        for name in _STRING.findall(text):
            for base in [current.parent, *dirs]:
                candidate = base / name
                if candidate.is_file():
                    pending.append(candidate.resolve())
                    break

    h = hashlib.sha256()
    for f in sorted(seen):
        h.update(str(f.relative_to(scene.parent) if f.is_relative_to(scene.parent) else f).encode())
        h.update(b"\0")
        h.update(f.read_bytes())
        h.update(b"\0")
    return Scene(scene, tuple(dirs), tuple(sorted(seen)), h.hexdigest(), sets_gamma)
