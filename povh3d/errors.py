"""One error hierarchy for povh3d.

Library code raises these; the CLI turns each into one red line and a non-zero
exit.  Messages name the problem and the fix, so they are complete sentences
that a user can act on without a traceback.

A message names a parameter, never a command-line flag: ``param("lens_rotation")`` marks the
name in the message; ``str(error)`` (Python) shows ``lens_rotation`` and the command line shows
the flag (``--lens-rotation``).  The raw message (``error.args[0]``) keeps the marks.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

_OPEN, _CLOSE = "\ue000", "\ue001"   # Unicode private-use characters: never in a user's text
_MARKED = re.compile(f"{_OPEN}([^{_CLOSE}]*){_CLOSE}")


def param(name: str) -> str:
    """``name``, a library parameter (``lens_rotation``), marked for a message: Python shows the
    name, the command line the flag it comes from."""
    return f"{_OPEN}{name}{_CLOSE}"


def render_params(message: str, as_text: Callable[[str], str] = str) -> str:
    """``message`` with each marked parameter written as ``as_text(name)`` (default: the name)."""
    return _MARKED.sub(lambda m: as_text(m.group(1)), message)


def plain(value: Any, as_text: Callable[[str], str] = str) -> Any:
    """``value`` (a record: dicts, lists, strings) with every marked parameter written as
    ``as_text(name)`` (default: the name), for JSON a user reads."""
    if isinstance(value, str):
        return render_params(value, as_text)
    if isinstance(value, dict):
        return {k: plain(v, as_text) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v, as_text) for v in value]
    if isinstance(value, tuple):
        return tuple(plain(v, as_text) for v in value)
    return value


def raw_message(error: BaseException) -> str:
    """The message of ``error`` with its parameter marks (for a message that quotes it)."""
    if isinstance(error, (Povh3dError, Povh3dWarning)) and error.args and isinstance(error.args[0], str):
        return error.args[0]
    return str(error)


class Povh3dError(Exception):
    """Base class of every error povh3d raises on purpose."""

    exit_code = 1

    def __str__(self) -> str:
        return render_params(super().__str__())


class ConfigError(Povh3dError, ValueError):
    """A parameter (lens array, panel, preset, option) is invalid."""

    exit_code = 2


class InputError(Povh3dError):
    """An input file is missing, unreadable or malformed."""

    exit_code = 3


class OutputError(Povh3dError):
    """An output cannot be written (folder missing or not writable)."""

    exit_code = 4


class PovrayNotFound(Povh3dError):
    """The POV-Ray executable cannot be found."""

    exit_code = 5


class PovrayError(Povh3dError):
    """A POV-Ray run failed; carries the command, exit code and log tail."""

    exit_code = 6

    def __init__(self, message: str, *, command: list[str] | None = None,
                 returncode: int | None = None, log_tail: str = "") -> None:
        super().__init__(message)
        self.command = command or []
        self.returncode = returncode
        self.log_tail = log_tail


class PovrayTimeout(PovrayError):
    """A POV-Ray run exceeded its time limit."""


class MissingExtra(Povh3dError, ImportError):
    """A command needs a package of an optional group (``pip install 'povh3d[GROUP]'``) that is not
    installed.  Also an ``ImportError``, so ``except ImportError`` in a caller's code still holds."""

    exit_code = 7


class RenderInterrupted(Povh3dError):
    """The user interrupted a render (Ctrl-C); every child was stopped."""

    exit_code = 130


class RenderCancelled(RenderInterrupted):
    """A caller's ``should_stop`` stopped the render (a cancelled cluster task, a render the inside-solid
    pass beside it made needless); every child was stopped."""


class Povh3dWarning(UserWarning):
    """Something the user should know that does not stop the work (an empty render, a
    cache that cannot be used).  Library code issues it with ``warnings.warn``; the
    CLI prints it as one yellow line."""

    def __str__(self) -> str:
        return render_params(super().__str__())


def warn(message: str) -> None:
    """Issue ``message`` as a ``Povh3dWarning`` (the one channel for warnings); its marked
    parameters show as names (``str(warning)``) or, on the command line, as flags."""
    import warnings

    warnings.warn(message, Povh3dWarning, stacklevel=2)
