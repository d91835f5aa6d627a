"""The one cache: content-addressed entries, one header, one damage policy.

Every cache of povh3d keeps its entries here: the engine's rendered frames and
scene cameras, the whole outputs of ``renderer/output_cache.py`` and the manifests of
converted models and volumes (``renderer/content/model.py``, ``renderer/content/volume.py``) and
Jinja's compiled templates (``scene/templates.py``).  It sits at
the package root beside ``system.py`` (not in ``engine/`` or ``povray/``) because
every layer keeps something in it, the command line reads the output cache before
NumPy or the engine is imported, and a root module that all layers may use needs
no layer crossing.  It imports only the standard library, ``errors``, ``system``
and the atomic writers of ``image/io.py`` (which load NumPy only when decoding).

- **Key:** ``content_key(*parts)``, the sha256 of the parts' canonical JSON:
  everything that decides the entry's content.
- **Place:** ``entry_path(root, kind, key, suffix)``: ``root/kind/ab/<key><suffix>``
  (``kind`` empty: ``root/ab/...``, where the frames have always been).
- **Header:** one line ``povh3d-cache 1 <key> <sha256 of the body>``, then the body.
  ``store`` writes it atomically (a temporary file renamed into place).
- **Damage policy:** ``load`` checks the header, the key and the hash, then hands
  the body to the reader's parser.  A truncated, altered or foreign entry (or a body
  its parser refuses: a ``ValueError``, ``KeyError``, ``TypeError``, ``EOFError`` or
  ``InputError``) is reported once (a ``Povh3dWarning``), removed and a miss; never
  an error of the command.
- **Folder:** ``cache_root`` is the one fallback (``cache_dir`` if given, else
  ``system.default_cache_dir()``); ``cache_folder`` makes a folder in it, or, when
  the cache cannot be written, warns once and hands out a folder of this run.
"""

from __future__ import annotations

from . import jsontext
import functools
import hashlib
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from .errors import InputError, OutputError, warn
from .system import default_cache_dir

MAGIC = b"povh3d-cache 1 "
T = TypeVar("T")


def content_key(*parts: Any) -> str:
    """sha256 of the parts' canonical JSON (sorted keys, exact float repr)."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def cache_root(cache_dir: str | Path | None = None) -> Path:
    """``cache_dir``, else ``$POVH3D_CACHE``, else the user's cache folder (``system.default_cache_dir``)."""
    return Path(cache_dir) if cache_dir else default_cache_dir()


def entry_path(root: str | Path, kind: str, key: str, suffix: str = ".entry") -> Path:
    """``root/kind/ab/<key><suffix>``: where the entry of ``key`` lives."""
    base = Path(root) / kind if kind else Path(root)
    return base / key[:2] / f"{key}{suffix}"


def frame_body(key: str, body: bytes) -> bytes:
    """The header line and ``body``: an entry's whole bytes."""
    return MAGIC + f"{key} {hashlib.sha256(body).hexdigest()}\n".encode("ascii") + body


def entry_body(key: str, data: bytes) -> bytes:
    """The body of an entry's bytes ``data``; ``InputError`` saying why when it is not ``key``'s whole entry."""
    header, newline, body = data.partition(b"\n")
    if not newline or not header.startswith(MAGIC):
        raise InputError("no povh3d cache header")
    fields = header[len(MAGIC):].decode("ascii", "replace").split()
    if len(fields) != 2 or fields[0] != key:
        raise InputError("it names another key")
    if hashlib.sha256(body).hexdigest() != fields[1]:
        raise InputError(f"its content hash does not match ({len(body)} bytes)")
    return body


def load(path: Path, key: str, parse: Callable[[bytes], T], *, again: str = "making it again") -> T | None:
    """``parse(body)`` of the entry at ``path``; None when it is missing, or damaged (then warned and removed).

    An ``OSError`` other than a missing file (an unreadable folder, an entry that
    cannot be removed) is raised: whether that disables a cache is its owner's call.
    """
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    try:
        return parse(entry_body(key, data))
    except (InputError, ValueError, KeyError, TypeError, IndexError, EOFError) as exc:
        warn(f"the cache entry {str(path)!r} was damaged ({exc}); removed it, {again}")
        path.unlink(missing_ok=True)
        return None


def store(path: Path, key: str, body: bytes) -> None:
    """Write the entry of ``key`` at ``path`` atomically; ``OSError`` or ``OutputError`` when it cannot."""
    from .image.io import atomic_path

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(frame_body(key, body))


def json_and_bytes(meta: dict[str, Any], data: bytes = b"") -> bytes:
    """A body of a JSON line and raw bytes (an image, an array): one entry holds both."""
    return json.dumps(meta, separators=(",", ":")).encode("utf-8") + b"\n" + data


def split_json(body: bytes) -> tuple[dict[str, Any], bytes]:
    """The JSON object and the bytes of a ``json_and_bytes`` body; ``ValueError`` if it is not one."""
    line, newline, data = body.partition(b"\n")
    meta = jsontext.loads(line)
    if not newline or not isinstance(meta, dict):
        raise ValueError("no JSON line")
    return meta, data


def cache_folder(folder: Path, noun: str) -> Path:
    """``folder`` made; an unusable cache (read-only, full) is one warning and a folder of this run."""
    from .image.io import check_writable

    try:
        folder.mkdir(parents=True, exist_ok=True)
        check_writable(folder / "manifest.entry")
        return folder
    except (OSError, OutputError) as exc:
        import tempfile

        from .system import owned_prefix

        warn(f"the {noun} cache {str(folder.parent.parent)!r} cannot be used ({exc}); working without it")
        return Path(tempfile.mkdtemp(prefix=owned_prefix("povh3d-")))  # swept after this run ends


_PACKAGE = Path(__file__).resolve().parent


@functools.cache
def code_stamp() -> str:
    """Names, sizes and modification times of povh3d's source files and templates, hashed: in every
    key of what povh3d's own code makes (a POV-Ray run's options, a template), so an entry made by
    other code is never read (the version number alone stays while the code changes)."""
    h = hashlib.sha256()
    folders = [_PACKAGE, _PACKAGE / "templates", _PACKAGE.parent / "templates"]
    while folders:
        folder = folders.pop()
        try:
            entries = sorted(os.scandir(folder), key=lambda e: e.name)
        except OSError:
            continue
        for entry in entries:
            if entry.is_dir() and entry.name not in ("__pycache__", "templates"):
                folders.append(Path(entry.path))
            elif entry.name.endswith((".py", ".pov", ".inc", ".j2", ".toml", ".txt")):
                stat = entry.stat()
                h.update(f"{entry.path}|{stat.st_size}|{stat.st_mtime_ns}\n".encode())
    return h.hexdigest()
