"""PNG images and JSON sidecars, written atomically.

8-bit PNGs go through Pillow (fast); 16-bit through pypng, because Pillow opens
16-bit RGB PNGs as 8-bit without a word (docs/geometry.md, "Files").  Every write
goes to a temporary file in the destination folder and is renamed into place,
so a failure or Ctrl-C never leaves a half-written image.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import png
from PIL import Image

from ..errors import InputError, OutputError


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success."""
    path = Path(path)
    tmp = _temp_beside(path)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def check_writable(path: str | Path) -> None:
    """Fail early, before any rendering, when ``path`` cannot be written.

    Writes and removes a temporary file beside ``path``; an existing ``path`` is
    never touched (a failed render must not cost the user the previous output).
    """
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"the output {str(path)!r} is a folder; give a file name inside it")
    os.unlink(_temp_beside(path))


def _temp_beside(path: Path) -> Path:
    """A new empty hidden file in ``path``'s folder (same file system: a rename is atomic)."""
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"output folder {str(folder)!r} does not exist; create it first")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=folder)
    except OSError as exc:
        raise OutputError(f"cannot write in {str(folder)!r}: {exc.strerror}; choose a writable folder") from None
    os.close(fd)
    return Path(tmp)


def read_png(path: str | Path) -> np.ndarray:
    """A PNG as ``(H, W, C)`` uint8 or uint16, keeping the file's bit depth."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"image {str(path)!r} does not exist; check the path")
    try:
        reader = png.Reader(filename=str(path))
        width, height, rows, info = reader.asDirect()
        if info["bitdepth"] > 8:
            planes = info["planes"]
            data = np.vstack([np.asarray(r, dtype=np.uint16) for r in rows])
            return data.reshape(height, width, planes)
        with Image.open(path) as im:
            im.load()
            if im.mode not in ("RGB", "RGBA", "L", "LA"):
                im = im.convert("RGBA" if "A" in im.getbands() else "RGB")
            arr = np.asarray(im)
    except (png.FormatError, png.ChunkError, OSError, ValueError) as exc:
        raise InputError(f"cannot read {str(path)!r} as a PNG image: {exc}") from None
    return arr[..., None] if arr.ndim == 2 else arr


def write_png(path: str | Path, image: np.ndarray) -> None:
    """Write ``(H, W[, C])`` uint8 or uint16 as PNG, atomically."""
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[..., 0]
    if image.dtype == np.uint8:
        with atomic_path(path) as tmp:
            Image.fromarray(image).save(tmp, format="PNG", compress_level=1)
    elif image.dtype == np.uint16:
        planes = 1 if image.ndim == 2 else image.shape[2]
        writer = png.Writer(width=image.shape[1], height=image.shape[0], bitdepth=16,
                            greyscale=planes in (1, 2), alpha=planes in (2, 4), compression=1)
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            writer.write(fh, image.reshape(image.shape[0], -1))
    else:
        raise ValueError(f"write_png takes uint8 or uint16 images, got {image.dtype}")


def sidecar_path(image_path: str | Path) -> Path:
    """``name.json`` beside ``name.png``."""
    return Path(image_path).with_suffix(".json")


def write_sidecar(image_path: str | Path, record: dict[str, Any]) -> Path:
    path = sidecar_path(image_path)
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(record, indent=2, sort_keys=False) + "\n", encoding="utf-8")
    return path


def read_sidecar(image_path: str | Path) -> dict[str, Any] | None:
    path = sidecar_path(image_path)
    if not path.is_file():
        return None
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
