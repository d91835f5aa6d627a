"""A content-addressed store of rendered images.

The key of an image is a hash of everything that decides its pixels: tool and
POV-Ray versions, the scene and every file it reads, the script's camera and
settings.  Entries are written atomically, so a cache shared by parallel runs
never holds half a file.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path
from typing import Any

from ..image.io import atomic_path


def default_cache_dir() -> Path:
    """``$POVH3D_CACHE``, else ``$XDG_CACHE_HOME/povh3d``, else ``~/.cache/povh3d``."""
    if os.environ.get("POVH3D_CACHE"):
        return Path(os.environ["POVH3D_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "povh3d"


def content_key(*parts: Any) -> str:
    """sha256 of the parts' canonical JSON (sorted keys, exact float repr)."""
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class ImageCache:
    """Files by key under ``root/ab/abcdef….png``."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.png"

    def get(self, key: str) -> Path | None:
        p = self.path(key)
        return p if p.is_file() else None

    def put(self, key: str, source: str | Path) -> Path:
        dest = self.path(key)
        dest.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(dest) as tmp:
            shutil.copyfile(source, tmp)
        return dest
