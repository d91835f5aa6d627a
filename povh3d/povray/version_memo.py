"""POV-Ray's version remembered across runs, so a render does not start
``povray --version`` (about 0.2 s) every time.

The version of a binary is stored in a small JSON file of the cache folder,
keyed on the binary's resolved path, size and modification time: replacing
or upgrading POV-Ray changes the key, so a stale version is never used.  The
memory is only an optimisation: an unreadable or unwritable file is ignored
and the version is asked again.  Where it does not know the binary, ``render``
starts the question early (``process.probe_version_early``).
"""

from __future__ import annotations

from .. import jsontext
import json
from collections.abc import Callable
from pathlib import Path

from ..system import binary_key

FILE_NAME = "povray-version.json"
#: Entries kept: one per binary seen, a handful at most on any machine.
_MAX_ENTRIES = 16


def remembered(binary: str, folder: str | Path) -> str | None:
    """The version the memory in ``folder`` holds for ``binary``, or None."""
    key = binary_key(binary)
    version = None if key is None else _read(Path(folder) / FILE_NAME).get(key)
    return version if isinstance(version, str) and version else None


def remembered_version(binary: str, folder: str | Path, ask: Callable[[str], str]) -> str:
    """The version of `binary`: from ``folder/povray-version.json`` if known, else ``ask(binary)``,
    then remembered there (best effort)."""
    key = binary_key(binary)
    if key is None:
        return ask(binary)
    path = Path(folder) / FILE_NAME
    known = _read(path)
    version = known.get(key)
    if isinstance(version, str) and version:
        return version
    version = ask(binary)
    known = {k: v for k, v in known.items() if k != key}
    kept = dict(list(known.items())[-(_MAX_ENTRIES - 1):])
    _write(path, {**kept, key: version})
    return version


def _read(path: Path) -> dict[str, object]:
    try:
        data = jsontext.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _write(path: Path, data: dict[str, object]) -> None:
    """Atomically (``image.io.atomic_path``: a rename, its temporary file gone on any failure or signal), so
    parallel renders never read half a file; errors ignored."""
    from ..errors import OutputError
    from ..image.io import atomic_path   # here: written once a binary, and the import graph stays shallow

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(data), encoding="utf-8")
    except (OSError, OutputError):
        pass
