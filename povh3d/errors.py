"""One error hierarchy for povh3d.

Library code raises these; the CLI turns each into one red line and a non-zero
exit.  Messages name the problem and the fix, so they are complete sentences
that a user can act on without a traceback.
"""

from __future__ import annotations


class Povh3dError(Exception):
    """Base class of every error povh3d raises on purpose."""

    exit_code = 1


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


class Povh3dWarning(UserWarning):
    """Something the user should know that does not stop the work (an empty render, a
    cache that cannot be used).  Library code issues it with ``warnings.warn``; the
    CLI prints it as one yellow line."""


def warn(message: str) -> None:
    """Issue ``message`` as a ``Povh3dWarning`` (the one channel for warnings)."""
    import warnings

    warnings.warn(message, Povh3dWarning, stacklevel=2)
