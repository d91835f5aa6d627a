"""The rendered shots in the cache (``povh3d.cache``): a store that cannot return a wrong image.

The key of an image is a hash of everything that decides its pixels: tool and
POV-Ray versions, the scene and every file it reads, the script's camera and
settings.  An entry ``root/ab/<key>.entry`` is one ``povh3d.cache`` entry whose
body is the image file POV-Ray wrote, as it wrote it: a PPM (``image.ppm``; a PNG
for a shot with alpha).  Kept uncompressed: deflating a 420 x 560 shot as a PNG
and inflating it again cost 6 ms of CPU (8-bit) to 21 ms (16-bit), a PPM's
store and load 3.5-6 ms, for 2-10 times the disk.  On every read the key and the
hash are checked and the image decoded (PPM or PNG, by its content): a
truncated, emptied or altered entry is reported once (a ``Povh3dWarning``),
removed and rendered again, never returned.

A cache that cannot be used (a read-only folder, a ``HOME`` that cannot be
written, a full disk) costs one warning; the render goes on without it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ... import cache
from ...errors import Povh3dError, param, raw_message, warn
from ...image.io import decode_image


class ImageCache:
    """Entries by key under ``root/ab/<key>.entry``, checked on every read.

    ``load`` and ``store`` never raise for a fault of the cache itself: the first
    one disables the cache for this object with one warning.
    """

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self.usable = True

    def path(self, key: str) -> Path:
        return cache.entry_path(self.root, "", key)

    def load(self, key: str) -> np.ndarray | None:
        """The image stored under ``key``, or None (missing, damaged and removed, or no cache)."""
        if not self.usable:
            return None
        path = self.path(key)
        try:
            return cache.load(path, key, lambda body: decode_image(body, str(path)),
                              again="rendering that shot again")
        except OSError as exc:
            self._give_up(f"cannot read or remove {str(path)!r} ({exc.strerror})")
            return None

    def store(self, key: str, source: str | Path) -> None:
        """Store the image file ``source`` (PPM or PNG) under ``key`` (atomically; a failure disables the cache)."""
        if not self.usable:
            return
        try:
            cache.store(self.path(key), key, Path(source).read_bytes())
        except (OSError, Povh3dError) as exc:
            self._give_up(raw_message(exc) if isinstance(exc, Povh3dError) else f"{exc.strerror or exc}")

    def _give_up(self, why: str) -> None:
        self.usable = False
        warn(f"the image cache {str(self.root)!r} cannot be used: {why}; rendering without it "
             f"(set POVH3D_CACHE to a writable folder, or turn it off: {param('use_cache')})")
