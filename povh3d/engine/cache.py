"""A content-addressed store of rendered images that cannot return a wrong one.

The key of an image is a hash of everything that decides its pixels: tool and
POV-Ray versions, the scene and every file it reads, the script's camera and
settings.  An entry ``root/ab/<key>.entry`` is one file: a header line
``povh3d-cache 1 <key> <sha256 of the PNG bytes>`` and the PNG bytes.  It is
written atomically (a temporary file renamed into place), and on every read the
key and the hash are checked and the PNG decoded: a truncated, emptied or
altered entry is reported once (a ``Povh3dWarning``), removed and rendered
again, never returned.

A cache that cannot be used (a read-only folder, a ``HOME`` that cannot be
written, a full disk) costs one warning; the render goes on without it.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, Povh3dError, warn
from ..system import default_cache_dir  # noqa: F401 - defined there so light modules need no NumPy
from ..image.io import atomic_path, decode_png

_MAGIC = b"povh3d-cache 1 "


def content_key(*parts: Any) -> str:
    """sha256 of the parts' canonical JSON (sorted keys, exact float repr)."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class ImageCache:
    """Entries by key under ``root/ab/<key>.entry``, checked on every read.

    ``load`` and ``store`` never raise for a fault of the cache itself: the first
    one disables the cache for this object with one warning.
    """

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.usable = True

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.entry"

    def load(self, key: str) -> np.ndarray | None:
        """The image stored under ``key``, or None (missing, damaged and removed, or no cache)."""
        if not self.usable:
            return None
        path = self.path(key)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            self._give_up(f"cannot read {str(path)!r} ({exc.strerror})")
            return None
        try:
            return self._decode(key, data, path)
        except InputError as exc:
            warn(f"the cache entry {str(path)!r} was damaged ({exc}); removed it, rendering that frame again")
            try:
                path.unlink(missing_ok=True)
            except OSError:
                self._give_up(f"cannot remove the damaged entry {str(path)!r}")
            return None

    @staticmethod
    def _decode(key: str, data: bytes, path: Path) -> np.ndarray:
        header, newline, body = data.partition(b"\n")
        if not newline or not header.startswith(_MAGIC):
            raise InputError("no povh3d cache header")
        fields = header[len(_MAGIC):].decode("ascii", "replace").split()
        if len(fields) != 2 or fields[0] != key:
            raise InputError("it names another key")
        if hashlib.sha256(body).hexdigest() != fields[1]:
            raise InputError(f"its content hash does not match ({len(body)} bytes)")
        return decode_png(body, str(path))

    def store(self, key: str, source: str | Path) -> None:
        """Store the PNG file ``source`` under ``key`` (atomically; a failure disables the cache)."""
        if not self.usable:
            return
        dest = self.path(key)
        try:
            body = Path(source).read_bytes()
            dest.parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(dest) as tmp:
                tmp.write_bytes(_MAGIC + f"{key} {hashlib.sha256(body).hexdigest()}\n".encode("ascii") + body)
        except (OSError, Povh3dError) as exc:
            self._give_up(str(exc) if isinstance(exc, Povh3dError) else f"{exc.strerror or exc}")

    def _give_up(self, why: str) -> None:
        self.usable = False
        warn(f"the image cache {str(self.root)!r} cannot be used: {why}; rendering without it "
             "(set POVH3D_CACHE to a writable folder, or pass --no-cache)")
