"""Whole outputs remembered: a still rendered again with nothing changed is its
stored image and sidecar, copied without importing the render machinery.

The frame cache (``renderer.shots.cache``) already spares POV-Ray on a re-run, but the
command still imports NumPy and the engine, decodes the frame and encodes the
output PNG again (about 0.3 s at 1920x1080).  This cache keys the whole request
to the finished files:

- every option of the request, by name (paths resolved), except ``-q``;
- the scene's digest (its text and every file it reads, ``scene.scene``);
- the POV-Ray binary (path, size, modification time: its version follows) and
  the ``POVH3D_POVRAY`` / ``POVH3D_SANDBOX`` settings;
- povh3d itself: its version and the names, sizes and modification times of
  its source files and templates, so an edited checkout never answers with an
  image an older code made.

An entry ``root/outputs/ab/<key>.output`` is one entry of the one cache
(``povh3d.cache``: its header, its hash, its damage policy) whose body is a JSON
line (the sidecar record, the command's summary line and the warnings the render
gave, which a hit gives again) and the PNG bytes.  A damaged entry is reported,
removed and the request rendered, never answered from it.

``povh3d render`` and ``povh3d.render`` both use it (their entries apart: the command keys its
options, the function its arguments).  Only stills of a ``.pov`` scene use it: an animation, a mesh model or a
volume (their conversions have their own caches), extra outputs (``--views-dir``,
``--depth-maps``, ``--video``), a Looking Glass preset (its quilt beside the image), a Dask
scheduler, a calibration file or a
scene that computes file names while it parses (they cannot be hashed) take
the normal path every time, as does ``--no-cache``.
"""

from __future__ import annotations

from .. import jsontext
import hashlib
import os
import warnings
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import cache
from .._version import __version__
from ..display.looking_glass import DEVICES
from ..errors import Povh3dError, Povh3dWarning, raw_message
from ..image.io import sidecar_path, write_png_bytes_pair
from ..jsontext import JSONValue
from ..mesh.formats import is_mesh_file
from ..scene.scene import load_scene
from ..system import binary_key, find_povray
from ..volume.sources import is_volume_source

#: Options that change nothing in the files written.
_IGNORED = ("func", "quiet", "no_cache")
#: Options whose use sends a request down the normal path (see the module docstring).
_UNCACHED = ("frames", "video", "views_dir", "depth_maps", "scheduler", "calibration", "objects")


@dataclass(frozen=True)
class Hit:
    """A request answered from the cache: what the command prints."""

    summary: str
    warnings: tuple[str, ...]
    record: dict[str, JSONValue]   # the sidecar written, as JSON


def request_key(scene: str | Path, output: Path, options: Mapping[str, Any],
                include_dirs: Sequence[str | Path] = ()) -> str | None:
    """The key of a render of ``scene`` into ``output``; None when it cannot use this cache.

    ``options``: every other value that shapes the files written, as plain values (the
    command line's options, by name); a name in ``_UNCACHED`` given sends the render down
    the normal path.  Nothing heavy is imported: a hit is answered before NumPy loads.
    """
    if options.get("no_cache") or any(options.get(name) for name in _UNCACHED) or is_mesh_file(str(scene)) \
            or is_volume_source(scene) or options.get("preset") in DEVICES:
        return None   # (a Looking Glass preset also writes its quilt, which no entry holds)
    try:
        povray = binary_key(find_povray())
    except Povh3dError:
        return None  # the render says what is missing
    if povray is None:
        return None
    loaded = load_scene(scene, tuple(include_dirs))  # a missing scene: the same one-line error
    if loaded.computed_names or not loaded.reproducible:
        return None  # the render says why it is not cached
    kept = {k: v for k, v in options.items() if k not in _IGNORED}
    kept.update(scene=str(loaded.path), include=[str(d) for d in loaded.include_dirs],
                output=os.path.abspath(output))
    parts = {"povh3d": [__version__, cache.code_stamp()], "options": kept, "scene": loaded.digest,
             "povray": povray, "env": {k: os.environ.get(k) for k in ("POVH3D_POVRAY", "POVH3D_SANDBOX")}}
    return cache.content_key(parts)


def api_key(source: str | Path, output: str | Path, inputs: Mapping[str, Any]) -> str | None:
    """The key of ``povh3d.render(source, output, **inputs)``; None when it cannot use this cache.

    ``inputs`` are the call's own arguments (a lens array by its value); the same rules as the
    command line's (``request_key``), kept apart from its entries by an ``api`` mark.
    """
    kept = {k: (repr(v) if k == "lens_array" else v) for k, v in inputs.items()}
    include = kept.pop("include_dirs", ()) or ()
    return request_key(source, Path(output), {"api": True, **kept}, tuple(include))


@contextmanager
def warnings_kept() -> Iterator[list[str]]:
    """The lines of the ``Povh3dWarning``s given inside the block (still shown as they come), for
    this cache to give again on a hit."""
    given: list[str] = []
    shown = warnings.showwarning

    def keep(message: Any, category: type[Warning], filename: str, lineno: int, file: Any = None,
             line: str | None = None) -> None:
        if issubclass(category, Povh3dWarning):
            given.append(raw_message(message) if isinstance(message, Warning) else str(message))
        shown(message, category, filename, lineno, file, line)

    warnings.showwarning = keep
    try:
        yield given
    finally:
        warnings.showwarning = shown


def _entry_path(key: str, cache_dir: Path | None = None) -> Path:
    return cache.entry_path(cache.cache_root(cache_dir), "outputs", key, ".output")


def answer(key: str, output: Path, cache_dir: Path | None = None) -> Hit | None:
    """Write the stored image and sidecar of ``key`` to ``output`` (as a pair, atomically); None on a miss.

    A damaged entry is reported, removed and a miss.
    """
    try:
        stored = cache.load(_entry_path(key, cache_dir), key, _parse, again="rendering again")
    except OSError:
        return None
    if stored is None:
        return None
    hit, image = stored
    timings = hit.record.get("timings")
    record = {**hit.record, "timings": {**(timings if isinstance(timings, Mapping) else {}), "output_from_cache": True}}
    write_png_bytes_pair(output, image, record)
    return Hit(hit.summary, hit.warnings, record)


def _parse(body: bytes) -> tuple[Hit, bytes]:
    """The entry's record (the sidecar as povh3d wrote it), summary and warnings, and the PNG bytes of
    its body; ``ValueError`` unless it is whole."""
    meta, image = cache.split_json(body)
    if not {"record", "summary", "warnings"} <= meta.keys() or not isinstance(meta["record"], dict):
        raise ValueError("not an output entry")
    return Hit(str(meta["summary"]), tuple(str(w) for w in meta["warnings"]), meta["record"]), image


def keep(key: str, output: Path, summary: str, warnings: list[str], cache_dir: Path | None = None) -> None:
    """Remember the image and sidecar just written to ``output`` (best effort: a cache that
    cannot be written only costs the next run its speed)."""
    try:
        image = output.read_bytes()
        record = jsontext.loads(sidecar_path(output).read_text(encoding="utf-8"))
        if record.pop("image_sha256", None) != hashlib.sha256(image).hexdigest():
            return  # replaced meanwhile by another process: nothing trustworthy to keep
        body = cache.json_and_bytes({"record": record, "summary": summary, "warnings": warnings}, image)
        cache.store(_entry_path(key, cache_dir), key, body)
    except (OSError, ValueError, Povh3dError):  # never fail the render that was just written
        return
