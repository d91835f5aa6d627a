"""The user's POV-Ray scene: where it is, what it reads, and what that says about it.

One walk over the scene's text finds everything povh3d needs to know before it
renders:

- the files it reads: every file a string literal in the scene (or, recursively,
  in what it includes) names and that exists beside the scene or in an include
  folder.  Their names and contents make the digest, so the cache key changes
  when any of them does;
- the POV-Ray include files it names (``textures.inc`` ...), found in POV-Ray's
  own include folders: not part of the digest (they change with POV-Ray, whose
  version is in the key) but read for what follows;
- the features it uses (``features.FEATURE_WORDS``), and so which global
  settings a quality level may add;
- what makes two parses of the same files differ, or what no key can name (``volatile``): the
  machine's clock (``now``, ``datetime``), the file system (``file_exists``), text run as code
  (``Parse_String``), a file the scene writes while it parses (``#fopen ... write``): such a scene is
  never cached, neither its frames nor its whole output;
- whether it reads the animation clock: a scene that never mentions ``clock``
  or the other animation identifiers looks the same at every clock value;
- whether it sets ``assumed_gamma``, and whether its own text asks for a POV-Ray
  language before 3.7 (``#version 3.6;``): povh3d adds ``assumed_gamma 1.0`` only where
  plain POV-Ray would use it too (``Scene.adds_assumed_gamma``);
- whether it reads a file whose name is computed while POV-Ray parses
  (``#include concat(...)``): such a file cannot be found by this walk, so it
  is not in the digest; confined by the sandbox POV-Ray cannot read it, but
  unconfined it can, and the cache must not be used (``renderer.shots.shots``);
- the names POV-Ray 3.7 will ask for where the scene names a file with
  non-ASCII characters: it reads strings as ASCII and turns each non-ASCII
  byte into a space (``#include "pièce.inc"`` opens ``"pi  ce.inc"``), so the
  runner links those names to the real files in the job folder
  (``povray.job.ascii_paths``).

Comments do not count; a mention anywhere else, even in a string, does: a false
alarm only costs work, a miss would give wrong pixels.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from ..errors import InputError, param
from .features import Features, features_of_words, strip_comments, words_of

#: The UTF-8 byte-order mark an editor may write first.  POV-Ray 3.7 skips it at the start of the file it
#: is given, but not in a file it includes, as povh3d includes the scene (``source_text``, ``has_bom``).
BOM = b"\xef\xbb\xbf"

_STRING = re.compile(r'"((?:\\.|[^"\\\n]){1,400})"')
# What makes two parses of the same text differ: the clock of the machine (``now``, and ``datetime``,
# which formats it) and the file system at parse time (``file_exists``).  POV-Ray 3.7 reads no
# environment variable.  An image from such a scene is never cached.
_VOLATILE_WORDS = frozenset(("now", "datetime", "file_exists"))
# What the key cannot name: ``Parse_String`` runs text built at parse time (``concat("n","ow")`` reads the
# clock, a computed ``#include`` any file), and a file the scene writes (``#fopen F "x.inc" write``, then
# ``#include "x.inc"``) is read as the last parse left it, not as the key saw it.
_PARSE_STRING = "Parse_String"
_WRITES_FILE = re.compile(r"#\s*fopen\b[^;#]*?\b(?:write|append)\b|#\s*write\b")
# Files that are not the same twice: devices, the kernel's views of processes and hardware.
_VOLATILE_FOLDERS = ("/dev/", "/proc/", "/sys/")
# A directive or file keyword followed by anything but a string literal: a name computed at parse time.
_COMPUTED_DIRECTIVE = re.compile(r'#\s*(?:include|fopen\s+\w+|read_file)\s+[^"\s]')
_FILE_TYPES = frozenset(("png", "jpeg", "tga", "gif", "iff", "ppm", "pgm", "sys", "exr", "hdr", "tiff", "df3", "ttf"))
_COMPUTED_FILE = re.compile(r'\b(?:' + "|".join(sorted(_FILE_TYPES)) + r')\s+[A-Za-z_(]')
# Every identifier through which a scene can see the animation.
_CLOCK_WORDS = frozenset(("clock", "clock_delta", "clock_on", "frame_number", "initial_frame", "final_frame",
                          "initial_clock", "final_clock"))
# Files whose text is read for names of other files (the rest are only hashed).
_TEXT_SUFFIXES = (".pov", ".inc", ".mcr", ".ini", ".txt", ".csv")
# Files whose text is POV-Ray source: features and clock use are read from these.
_SOURCE_SUFFIXES = (".pov", ".inc", ".mcr", ".ini")


@dataclass(frozen=True)
class Scene:
    """A scene file, its include folders and what one walk over its text found.

    Attributes
    ----------
    path : Path               the scene, absolute
    include_dirs : tuple[Path, ...]   the scene's folder first, then the user's
    files : tuple[Path, ...]  the scene and every file it was found to read
    digest : str              sha256 over the files' names and contents
    sets_assumed_gamma : bool
    features : Features       found in its sources and the POV-Ray include files they name
    uses_clock : bool         whether any of those sources reads the animation clock
    animation_words : frozenset[str]   which of the animation identifiers they read (``clock``,
                              ``frame_number`` ...)
    computed_names : bool     whether the scene's own sources read a file through a name
                              computed at parse time (not in ``files`` nor the digest)
    lit : bool                whether its sources mention a light_source, emission or radiosity
    ascii_names : tuple[tuple[str, Path], ...]   (the name POV-Ray 3.7 asks for, the file) for each
                              file the scene names with non-ASCII characters (``pov_ascii_names``)
    volatile : tuple[str, ...]  what makes its image differ from one parse to the next, or what the
                              cache key cannot name: the words ``now``, ``datetime``, ``file_exists``,
                              ``Parse_String``, a ``#fopen`` for writing, or a device file it names
    legacy_version : bool     its own text's first ``#version`` is before 3.7 (``#version 3.6;``)
    """

    path: Path
    include_dirs: tuple[Path, ...]
    files: tuple[Path, ...]
    digest: str
    sets_assumed_gamma: bool
    features: Features = Features(frozenset())
    uses_clock: bool = False
    computed_names: bool = False
    lit: bool = True
    ascii_names: tuple[tuple[str, Path], ...] = ()
    animation_words: frozenset[str] = frozenset()
    volatile: tuple[str, ...] = ()
    legacy_version: bool = False

    @property
    def adds_assumed_gamma(self) -> bool:
        """Whether povh3d's header sets ``assumed_gamma 1.0`` for the scene: where it sets none and
        its language is 3.7.  POV-Ray 3.7 turns gamma correction off for a scene whose language
        at the end of parsing is older (its log: "assumed_gamma not specified, so gamma_correction
        is turned off"); the header must not change that, or every colour comes out brighter
        (``incdemo/woods/teak.pov``: 11 dB from plain POV-Ray)."""
        return not (self.sets_assumed_gamma or self.legacy_version)

    def include_text(self, name: str) -> str | None:
        """The text of the file ``#include "name"`` reads (the scene's folders, then POV-Ray's), or None."""
        found = _find(name, [*self.include_dirs, *system_include_dirs()])
        return None if found is None else source_text(found.read_bytes())

    @property
    def reproducible(self) -> bool:
        """Whether two renders of the scene's text give the same image (``volatile`` is empty)."""
        return not self.volatile


# A scene with neither shows its objects in their ambient colour only (nearly black).
_LIGHT_WORDS = frozenset(("light_source", "emission", "radiosity"))


@cache
def system_include_dirs() -> tuple[Path, ...]:
    """POV-Ray's own include folders (``/usr/share/povray-3.7/include``): beside the
    binary ``$POVH3D_POVRAY`` or ``PATH`` names, then the usual prefixes."""
    prefixes = []
    binary = os.environ.get("POVH3D_POVRAY") or shutil.which("povray")
    if binary:
        prefixes.append(Path(binary).resolve().parent.parent)
    prefixes += [Path("/usr"), Path("/usr/local")]
    found = [d for prefix in prefixes for d in sorted((prefix / "share").glob("povray-*/include"))]
    return tuple(dict.fromkeys(found))


def source_text(data: bytes) -> str:
    """The latin-1 text of POV-Ray source bytes, without a leading UTF-8 byte-order mark (POV-Ray's own
    reading of the file it is given; the bytes are the text, so decoding never fails)."""
    return data.removeprefix(BOM).decode("latin-1")


def has_bom(path: Path) -> bool:
    """Whether the file at ``path`` starts with a UTF-8 byte-order mark."""
    with open(path, "rb") as f:
        return f.read(len(BOM)) == BOM


def _read_text(path: Path) -> str | None:
    """The text of ``path`` without comments; None for binary data in a file that is not POV-Ray source."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read {str(path)!r}: {exc.strerror}") from None
    if b"\0" in data[:65536]:  # no POV-Ray source holds a NUL byte; an image or a program does
        if path.suffix.lower() not in _SOURCE_SUFFIXES:
            return None  # a data file: hashed, not read for names
        raise InputError(f"{str(path)!r} is not a text scene (it holds binary data); give a POV-Ray source file")
    return strip_comments(source_text(data))  # POV-Ray sources are bytes; never fail on encoding


def _find(name: str, folders: list[Path]) -> Path | None:
    name = os.fsdecode(name.encode("latin-1"))  # the text's bytes are the file's name
    for base in folders:
        candidate = base / name
        if candidate.is_file():
            return candidate.resolve()
    return None


_NON_ASCII = re.compile(r"[^\x00-\x7f]")


def pov_ascii_names(literal: str) -> list[str]:
    """The names POV-Ray 3.7 opens for the file name `literal` (the latin-1 text of a string's bytes).

    It replaces each non-ASCII byte by a space; after ``global_settings { charset utf8 }``,
    each non-ASCII character.  Only names relative to its working folder can be given a
    link there: an absolute name or one with ``..`` gets none.
    """
    names = {_NON_ASCII.sub(" ", literal)}
    try:
        names.add(_NON_ASCII.sub(" ", literal.encode("latin-1").decode("utf-8")))
    except UnicodeDecodeError:
        pass
    return sorted(n for n in names if not (n.startswith("/") or ".." in n.split("/")))


def _ascii_links(named: dict[str, Path]) -> tuple[tuple[str, Path], ...]:
    """(name POV-Ray asks for, file) for the non-ASCII names; two files behind one name are refused."""
    links: dict[str, Path] = {}
    for literal, file in sorted(named.items()):
        for name in pov_ascii_names(literal):
            if links.setdefault(name, file) != file:
                raise InputError(f"POV-Ray 3.7 reads file names as ASCII, so {str(links[name])!r} and "
                                 f"{str(file)!r} both look like {name!r} to it; rename one of them with ASCII "
                                 "characters only")
    return tuple(sorted(links.items()))


def load_scene(path: str | Path, include_dirs: tuple[str | Path, ...] = (),
               system_dirs: tuple[Path, ...] | None = None) -> Scene:
    """Find a scene and walk what it reads; raise InputError when it is not there.

    ``system_dirs``: POV-Ray's include folders (None: ``system_include_dirs()``).
    """
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
            raise InputError(f"include folder {str(d)!r} does not exist; check {param('include_dirs')}")
        if d not in dirs:
            dirs.append(d)
    system = list(system_include_dirs() if system_dirs is None else system_dirs)

    own: dict[Path, None] = {}        # the scene's files, in the digest
    seen: set[Path] = set()
    sources: list[frozenset[str]] = []   # the words of POV-Ray source texts, the scene's and the system's
    pending = [(scene, True)]
    sets_gamma = computed = False
    legacy = False
    named: dict[str, Path] = {}       # non-ASCII file names in the scene's text, and their files
    volatile: set[str] = set()
    while pending:
        current, is_own = pending.pop()
        if current in seen:
            continue
        seen.add(current)
        if is_own:
            own[current] = None
        suffix = current.suffix.lower()
        if suffix not in _TEXT_SUFFIXES:
            continue  # images, fonts, density files: hash them, do not parse them
        text = _read_text(current)
        if text is None:
            continue
        words = words_of(text) if suffix in _SOURCE_SUFFIXES else frozenset()
        if suffix in _SOURCE_SUFFIXES:
            sources.append(words)
        if current == scene and suffix in _SOURCE_SUFFIXES:
            legacy = _legacy_version(text)
        if is_own:
            sets_gamma = sets_gamma or "assumed_gamma" in words
            computed = computed or (suffix in _SOURCE_SUFFIXES and _computed_name(text, words))
            if words & (_VOLATILE_WORDS | {_PARSE_STRING}):  # a second look, without strings: "now" in a
                # string reads no clock
                volatile.update(words_of(_STRING.sub(" ", text)) & (_VOLATILE_WORDS | {_PARSE_STRING}))
            if suffix in _SOURCE_SUFFIXES and _WRITES_FILE.search(_STRING.sub('""', text)):
                volatile.add("#fopen ... write")
        for name in _STRING.findall(text):
            if name.startswith(_VOLATILE_FOLDERS):
                volatile.add(name)  # never hashed: reading /dev/zero would not end
                continue
            found = _find(name, [current.parent, *dirs] if is_own else [current.parent, *system])
            if found is not None:
                pending.append((found, is_own))
                if is_own and not name.isascii():
                    named[name] = found
            elif (found := _find(name, system)) is not None:
                pending.append((found, False))

    h = hashlib.sha256()
    for f in sorted(own):
        h.update(str(f.relative_to(scene.parent) if f.is_relative_to(scene.parent) else f).encode())
        h.update(b"\0")
        h.update(f.read_bytes())
        h.update(b"\0")
    return Scene(scene, tuple(dirs), tuple(sorted(own)), h.hexdigest(), sets_gamma,
                 features_of_words(sources), any(_CLOCK_WORDS & w for w in sources), computed,
                 any(_LIGHT_WORDS & w for w in sources), _ascii_links(named),
                 frozenset().union(*(_CLOCK_WORDS & w for w in sources)), tuple(sorted(volatile)), legacy)


_VERSION = re.compile(r"#\s*version\s+([0-9]+(?:\.[0-9]*)?)")


def _legacy_version(text: str) -> bool:
    """Whether the scene's first ``#version`` (a number) names a language before 3.7.  Later ones
    are the include files' save-and-restore (``#version Old_Version;``) or its own; a scene
    without one is read as 3.7 under povh3d's header."""
    found = _VERSION.search(text)
    return found is not None and float(found[1]) < 3.7


def _computed_name(text: str, words: frozenset[str]) -> bool:
    """Whether ``text`` reads a file through a name computed at parse time (not a string literal)."""
    return bool(_COMPUTED_DIRECTIVE.search(text)) or bool(words & _FILE_TYPES and _COMPUTED_FILE.search(text))
