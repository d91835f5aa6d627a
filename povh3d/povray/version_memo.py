"""POV-Ray's version remembered across runs, so a render does not start
``povray --version`` (about 0.2 s) every time.

The version of a binary is stored in a small JSON file of the cache folder,
keyed on the binary's resolved path, size and modification time: replacing
or upgrading POV-Ray changes the key, so a stale version is never used.  The
memory is only an optimisation: an unreadable or unwritable file is ignored
and the version is asked again.

Where the memory does not know the binary (a first run, a cache folder just
emptied), ``probe_early`` starts ``povray --version`` as the command starts, so
the probe's 0.2 s (nearly all of it POV-Ray waiting) passes beside povh3d's own
start-up instead of before its first render; ``process.povray_version`` takes
its answer (``taken_probe``), and a probe nobody took is stopped at exit.
"""

from __future__ import annotations

from .. import jsontext
import atexit
import json
import os
import subprocess
import tempfile
from collections.abc import Callable
from pathlib import Path

from ..system import binary_key

FILE_NAME = "povray-version.json"
#: Entries kept: one per binary seen, a handful at most on any machine.
_MAX_ENTRIES = 16
#: ``povray --version`` runs started early (``probe_early``), by binary, until taken.
_PROBES: dict[str, subprocess.Popen[str]] = {}


def probe_early(binary: str, folder: str | Path) -> None:
    """Start ``binary --version`` now unless the memory in ``folder`` knows the binary (or a probe runs)."""
    key = binary_key(binary)
    if key is None or binary in _PROBES:
        return
    known = _read(Path(folder) / FILE_NAME).get(key)
    if isinstance(known, str) and known:
        return
    try:
        _PROBES[binary] = subprocess.Popen([binary, "--version"], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                           stderr=subprocess.STDOUT, text=True, errors="replace")
    except OSError:
        return   # asked again, the usual way, where the error is said
    if len(_PROBES) == 1:
        atexit.register(_stop_probes)


def taken_probe(binary: str) -> subprocess.Popen[str] | None:
    """The early probe of ``binary``, now the caller's to finish, or None."""
    return _PROBES.pop(binary, None)


def _stop_probes() -> None:
    """At exit: no probe outlives the command (one nobody took: a command that failed first)."""
    for probe in _PROBES.values():
        if probe.poll() is None:
            probe.kill()
        probe.wait()
        if probe.stdout is not None:
            probe.stdout.close()
    _PROBES.clear()


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
    """Atomically (a rename), so parallel renders never read half a file; errors ignored."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".version-", dir=path.parent)
    except OSError:
        return
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(data, f)
        os.replace(tmp, path)
    except OSError:
        try:
            os.unlink(tmp)
        except OSError:
            pass
