"""PNG images and JSON sidecars, written atomically.

8-bit PNGs are read by Pillow (fast); 16-bit ones by ``png_codec`` (libpng
through imagecodecs), because Pillow opens 16-bit RGB PNGs as 8-bit without a word
(docs/geometry.md, "Files"), and pypng, which reads them right, took seconds per
megapixel.  ``png_codec`` writes both.  Every write
goes to a temporary file in the destination folder and is renamed into place,
so a failure or Ctrl-C never leaves a half-written image, and the file gets the
mode the umask gives (``0o666 & ~umask``), like any file the user's programs
write.

An image and its sidecar are replaced as a pair (``write_image_pair``): both are
written to temporary names, then the image is renamed into place and the sidecar
last.  The sidecar records the SHA-256 of its image (``image_sha256``) and
``read_sidecar`` checks it, so a crash between the two renames (new image, old
sidecar) is detected on read, and a new sidecar can never sit beside an old
image: it is renamed only after its image is in place.
"""

from __future__ import annotations

from .. import jsontext
import contextlib
import hashlib
import io
import json
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError, OutputError, param, plain
from ..system import deferred_signals

if TYPE_CHECKING:  # NumPy, Pillow and pypng are imported where images are coded: a cached
    import numpy as np  # output is copied as bytes without them (renderer/output_cache.py)

    from ..jsontext import JSONObject, JSONValue
    from .sidecar import Sidecar


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` on success.

    An ``OSError`` while writing (a full disk, a file-size limit) becomes an
    ``OutputError`` naming ``path``; the existing ``path`` is left as it was.
    """
    path = Path(path)
    tmp: Path | None = None
    try:
        with deferred_signals():   # a SIGTERM between the file's creation and this try left it behind
            tmp = _temp_beside(path)
        yield tmp
        _chmod(tmp)
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        if isinstance(exc, OSError):
            raise _write_error(path, exc) from None
        raise


def _write_error(path: Path, exc: OSError) -> OutputError:
    why = exc.strerror or str(exc)
    return OutputError(f"cannot write {str(path)!r}: {why}; free some space or choose another folder "
                       "(the previous file, if any, is unchanged)")


def file_mode() -> int:
    """The mode a new file gets under the current umask (``0o666 & ~umask``)."""
    try:  # Linux >= 4.7: read it without changing it (os.umask is process-wide)
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def _chmod(path: Path) -> None:
    # mkstemp creates 0600; the finished file gets what the umask gives.
    with contextlib.suppress(OSError):
        os.chmod(path, file_mode())


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def check_writable(path: str | Path) -> None:
    """Fail early, before any rendering, when ``path`` cannot be written.

    Writes and removes a temporary file beside ``path``; an existing ``path`` is
    never touched (a failed render must not cost the user the previous output).
    """
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"the output {str(path)!r} is a folder; give a file name inside it")
    with deferred_signals():   # the probe's file never outlives a signal
        os.unlink(_temp_beside(path))


#: The keys every sidecar povh3d writes holds (``write_image_pair``, ``write_sidecar``): a ``NAME.json``
#: without them is the user's own file (a calibration, notes), never replaced by a sidecar.
SIDECAR_KEYS = ("povh3d_version", "image_sha256")


def is_povh3d_record(path: str | Path, keys: tuple[str, ...] = SIDECAR_KEYS) -> bool:
    """Whether ``path`` is a JSON object holding every one of ``keys`` (a file povh3d wrote)."""
    try:
        with open(path, "rb") as fh:
            record = json.loads(fh.read(1 << 24))
    except (OSError, ValueError, RecursionError):
        return False
    return isinstance(record, dict) and all(k in record for k in keys)


def _same(a: Path, b: Path) -> bool:
    """Whether two names reach one file (links followed; a name not there yet by its resolved path)."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def _inside(path: Path, folder: Path) -> bool:
    return Path(os.path.realpath(path)).is_relative_to(os.path.realpath(folder))


def check_output(path: str | Path, inputs: Iterable[str | Path] = (), *, what: str = "output",
                 sidecar: bool = True) -> Path:
    """Refuse, before any work, an output that would write over a file the command did not make or
    reads: ``path`` (and with ``sidecar`` its ``NAME.json``) being one of ``inputs``, or a ``NAME.json``
    there that is not a povh3d sidecar (``SIDECAR_KEYS``: a calibration, the user's notes).  Then
    ``check_writable``.  Returns ``path``."""
    path = Path(path)
    sources = [Path(p) for p in inputs]
    side = sidecar_path(path) if sidecar else None
    for target in (path, side):
        if target is None:
            continue
        for source in sources:
            if _same(target, source):
                also = "" if target == path else f" (its sidecar {str(target)!r})"
                raise OutputError(f"the {what} {str(path)!r}{also} would write over {str(source)!r}, which this "
                                  "command reads; choose another output name")
    if side is not None and side != path and side.exists() and not is_povh3d_record(side):
        raise OutputError(f"{str(side)!r} is not a povh3d sidecar, and the {what} {str(path)!r} would replace it "
                          "with one; move it or choose another output name")
    check_writable(path)
    return path


def with_sidecar(path: str | Path) -> tuple[Path, Path]:
    """An image a command reads and its sidecar: what its outputs must not be (``check_output``)."""
    return Path(path), sidecar_path(path)


def check_output_folder(folder: str | Path, inputs: Iterable[str | Path] = (), *, what: str = "output folder") -> Path:
    """Refuse, before any work, an output folder that is one of ``inputs`` or holds one (it is replaced whole)."""
    folder = Path(folder)
    for source in inputs:
        source = Path(source)
        if _same(folder, source) or _inside(source, folder):
            raise OutputError(f"the {what} {str(folder)!r} holds {str(source)!r}, which this command reads, and "
                              "is replaced whole; choose another folder")
    return folder


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


def read_image(path: str | Path) -> np.ndarray:
    """A PNG, or a binary PPM as POV-Ray writes its frames (``image.ppm``), by its content, as
    ``(H, W, C)`` uint8 or uint16, keeping the file's bit depth."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"image {str(path)!r} does not exist; check the path")
    return decode_image(path, str(path))


def read_png(path: str | Path) -> np.ndarray:
    """A PNG as ``(H, W, C)`` uint8 or uint16, keeping the file's bit depth (a POV-Ray frame, a PPM:
    ``read_image``)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"image {str(path)!r} does not exist; check the path")
    return decode_png(path, str(path))


def decode_image(source: Path | bytes, name: str) -> np.ndarray:
    """A PNG or PPM file, or its bytes, as ``(H, W, C)``; an ``InputError`` naming ``name`` if damaged."""
    from .ppm import MAGIC, decode_ppm

    if isinstance(source, Path):
        with open(source, "rb") as fh:
            head = fh.read(len(MAGIC))
    else:
        head = source[:len(MAGIC)]
    if head != MAGIC:
        return decode_png(source, name)
    try:
        return decode_ppm(source, name)
    except MemoryError:
        raise InputError(f"{name!r} is too large to read into memory") from None
    except ValueError as exc:
        raise InputError(f"cannot read {name!r} ({exc}); render it again") from None


def decode_png(source: Path | bytes, name: str) -> np.ndarray:
    """A PNG file or PNG bytes as ``(H, W, C)``; an ``InputError`` naming ``name`` if damaged."""
    from . import png_codec

    if isinstance(source, Path):
        with open(source, "rb") as fh:
            head = fh.read(26)
    else:
        head = source[:26]
    check_png_memory(head, name)
    try:
        data = source.read_bytes() if isinstance(source, Path) else source
        # libpng (png_codec) reads 8- and 16-bit grey and RGB(A), every POV-Ray frame; Pillow, whose
        # import costs a render more than its frames, only the layouts it leaves (palette, interlaced).
        arr = png_codec.decode(data)
        if arr is None:
            arr = _decode_png16(data) if head[24:25] == b"\x10" else _decode_pillow(data)
    except MemoryError:
        raise InputError(f"{name!r} is too large to read into memory") from None
    except Exception as exc:  # noqa: BLE001 - zlib, libpng, pypng and Pillow raise many kinds on a damaged file
        raise InputError(f"cannot read {name!r} as a PNG image ({type(exc).__name__}: {exc}); "
                         "check that it is a complete PNG file") from None
    return arr[..., None] if arr.ndim == 2 else arr


def _decode_pillow(data: bytes) -> np.ndarray:
    """8 bits or fewer in a layout ``png_codec`` leaves (palette, interlaced, 1-4 bits): Pillow, as RGB(A) or grey."""
    import numpy as np
    from PIL import Image

    # Pillow's own bound (a two-line DecompressionBombWarning past 89 Mpixels, an error past twice that)
    # knows nothing of the memory there is: check_png_memory is the bound here, from the header.
    Image.MAX_IMAGE_PIXELS = None
    with Image.open(io.BytesIO(data)) as im:
        im.load()
        picture: Image.Image = im
        if im.mode not in ("RGB", "RGBA", "L", "LA"):
            picture = im.convert("RGBA" if "A" in im.getbands() else "RGB")
        return np.asarray(picture)


def png_size(head: bytes) -> tuple[int, int, int] | None:
    """(width, height, bytes per pixel once decoded) from the first 26 bytes of a PNG; None if not a PNG."""
    if len(head) < 26 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    width, height = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
    return width, height, 4 * (2 if head[24] == 16 else 1)   # Pillow keeps RGB in 4 bytes; a palette becomes RGB(A)


def check_png_memory(head: bytes, name: str) -> None:
    """Refuse, from its header, a PNG whose decoding needs more than the memory budget (``--max-memory``
    or the memory available): a small file may hold a huge image (a PNG bomb), so the size is read first."""
    from ..system import memory_budget, memory_limit

    size = png_size(head)
    budget = memory_budget()
    if size is None or budget is None:
        return   # not a PNG: the decoder says so
    width, height, per_pixel = size
    need = 2 * width * height * per_pixel   # the decoded image and its array
    if need > budget:
        whose = f"your {param('max_memory')} limit" if budget == memory_limit() else "the memory available"
        raise InputError(f"{name!r} is a {width}x{height} image: reading it needs about {need / 2**30:.3g} GiB "
                         f"of memory, more than {whose} ({budget / 2**30:.3g} GiB); give a smaller image or "
                         f"raise {param('max_memory')}")


def _decode_png16(data: bytes) -> np.ndarray:
    """16 bits per channel in a layout ``png_codec`` leaves (interlaced, palette): pypng (Pillow reads 8 bits)."""
    import numpy as np
    import png

    width, height, rows, info = png.Reader(bytes=data).asDirect()
    return np.vstack([np.asarray(r, dtype=np.uint16) for r in rows]).reshape(height, width, info["planes"])


def write_png(path: str | Path, image: np.ndarray) -> None:
    """Write ``(H, W[, C])`` uint8 or uint16 as PNG, atomically."""
    with atomic_path(path) as tmp:
        _encode_png(tmp, image)


def _encode_png(path: Path, image: np.ndarray) -> None:
    import numpy as np

    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[..., 0]
    if image.dtype in (np.uint8, np.uint16) and image.ndim in (2, 3):
        from . import png_codec

        with open(path, "wb") as fh:
            png_codec.encode(fh, image)
    else:
        raise ValueError(f"write_png takes uint8 or uint16 images, got {image.dtype}")


def write_image_pair(path: str | Path, image: np.ndarray, record: Sidecar | JSONObject) -> None:
    """Replace ``path`` and its sidecar together (see the module docstring for the order).

    Both are written to temporary names first; on any failure neither the old
    image nor the old sidecar is touched.
    """
    _replace_pair(Path(path), lambda tmp: _encode_png(tmp, image), record)


def write_png_bytes_pair(path: str | Path, data: bytes, record: Sidecar | JSONObject) -> None:
    """``write_image_pair`` for an image already encoded: ``data`` are the PNG file's bytes."""
    _replace_pair(Path(path), lambda tmp: tmp.write_bytes(data), record)


def _replace_pair(path: Path, write: Any, record: Sidecar | JSONObject) -> None:
    side = sidecar_path(path)
    held = contextlib.ExitStack()
    with held:
        with atomic_path(side) as side_tmp:
            with atomic_path(path) as image_tmp:
                write(image_tmp)
                _write_json(side_tmp, {**_as_json(record), "image_sha256": file_sha256(image_tmp)})
                # Ctrl-C or SIGTERM between the two renames would leave the new image beside the old
                # sidecar: from here a signal waits until both are in place (SIGKILL cannot: read_sidecar
                # detects that pair by its image_sha256)
                held.enter_context(deferred_signals())
            # the image is in place; the sidecar is renamed when this block ends


def _as_json(record: Sidecar | JSONObject) -> JSONObject:
    from .sidecar import Sidecar

    return record.to_json() if isinstance(record, Sidecar) else record


def _write_json(path: Path, record: JSONObject) -> None:
    path.write_text(json.dumps(plain(record), indent=2, sort_keys=False) + "\n", encoding="utf-8")


def sidecar_path(image_path: str | Path) -> Path:
    """``name.json`` beside ``name.png``."""
    return Path(image_path).with_suffix(".json")


def write_sidecar(image_path: str | Path, record: Sidecar | JSONObject) -> Path:
    """Write the sidecar of an image already in place (it records the image's SHA-256)."""
    path = sidecar_path(image_path)
    record = _as_json(record)
    if Path(image_path).is_file():
        record = {**record, "image_sha256": file_sha256(image_path)}
    with atomic_path(path) as tmp:
        _write_json(tmp, record)
    return path


def read_sidecar_record(image_path: str | Path) -> Sidecar | None:
    """The sidecar of ``image_path`` as a ``Sidecar``, every key it knows checked (``image.sidecar``);
    None when there is none.  A wrong type or a missing ``kind`` is an ``InputError`` naming the file
    and the key, as an unreadable one is (``read_sidecar``)."""
    from .sidecar import Sidecar

    record = read_sidecar(image_path)
    return None if record is None else Sidecar.from_json(record, source=sidecar_path(image_path))


def read_sidecar(image_path: str | Path) -> dict[str, JSONValue] | None:
    """The sidecar of ``image_path`` as parsed JSON (``read_sidecar_record``: typed and checked);
    None when there is none.

    An unreadable or malformed sidecar, or one whose ``image_sha256`` is not the
    image's (the image was replaced after it), is an ``InputError``: a sidecar
    that describes another image must not be trusted.
    """
    path = sidecar_path(image_path)
    if not path.is_file():
        return None
    try:
        record = jsontext.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"cannot read the sidecar {str(path)!r}: {exc.strerror}") from None
    except ValueError as exc:
        raise InputError(f"the sidecar {str(path)!r} is corrupt ({exc}); delete it or write it again") from None
    if not isinstance(record, dict):
        raise InputError(f"the sidecar {str(path)!r} is corrupt (not a JSON object); delete it or write it again")
    digest = record.get("image_sha256")
    image = Path(image_path)
    if digest is None and image.suffix.lower() != ".json" and image.is_file():
        from ..errors import warn
        # every sidecar povh3d writes holds it: this one was written by hand, or for another image
        warn(f"the sidecar {str(path)!r} has no image_sha256, so nothing says it describes {str(image)!r}; "
             "if it was written for another image, delete it or render the image again")
    if isinstance(digest, str) and image.suffix.lower() != ".json" and image.is_file() \
            and file_sha256(image) != digest:
        raise InputError(f"the sidecar {str(path)!r} describes another image than {str(image)!r} "
                         "(the image was replaced); delete the sidecar or render the image again")
    return renamed_keys(record)


#: Sidecar keys renamed since povh3d wrote them (old -> new): sidecars on users' disks still read.
RENAMED_KEYS = {"display_frame": "placement"}   # issue 36: the display's place in the scene


def renamed_keys(record: dict[str, jsontext.JSONValue]) -> dict[str, jsontext.JSONValue]:
    """``record`` (a sidecar) with its keys of an older povh3d under their current names."""
    for old, new in RENAMED_KEYS.items():
        if old in record and new not in record:
            record[new] = record.pop(old)
    return record
