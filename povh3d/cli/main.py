"""The ``povh3d`` command line: the parser and the one place errors become messages.

Every user error becomes one red line on stderr and a non-zero exit code,
never a traceback.  Progress goes to stderr, results to stdout.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import signal
import sys
import threading
import warnings
from collections.abc import Sequence
from typing import NoReturn

from .._version import __version__
from ..errors import Povh3dError, Povh3dWarning, RenderInterrupted, raw_message
from .flags import flags, learn
from . import calibration, display, hyper, layout, render, replay
from .options import finite_float, warn


#: A value that starts with a minus and a digit (``-50,-40,-30``, ``-.5``): argparse takes only a bare
#: negative number for a value, and a list such as ``--display-normal -50,-40,-30`` for an option.
_NEGATIVE_VALUE = re.compile(r"-\.?[0-9]")


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.register("type", float, finite_float)

    def _parse_optional(self, arg_string: str):
        if _NEGATIVE_VALUE.match(arg_string):  # no povh3d option starts with a digit
            return None
        return super()._parse_optional(arg_string)

    def error(self, message: str) -> NoReturn:  # one line, not usage + message
        fail(f"{message} (see '{self.prog} --help')", 2)


def fail(message: str, code: int) -> NoReturn:
    red, reset = ("\033[31m", "\033[0m") if sys.stderr.isatty() else ("", "")
    print(f"{red}povh3d: error: {flags(message)}{reset}", file=sys.stderr)
    raise SystemExit(code)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="povh3d", description="Holoscopic 3D (integral imaging) images with POV-Ray.")
    parser.add_argument("--version", action="version", version=f"povh3d {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    render.add_parsers(sub)
    display.add_parsers(sub)
    calibration.add_parsers(sub)
    layout.add_parsers(sub)
    hyper.add_parsers(sub)
    replay.add_parsers(sub)
    for command in sub.choices.values():
        command.add_argument("--max-memory", metavar="SIZE", default=None,
                             help="most memory the command and each POV-Ray it starts may use, e.g. 4G "
                                  "(default: the memory available; also POVH3D_MAX_MEMORY)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command ``argv`` (None: ``sys.argv``, the command line's own run)."""
    try:
        return _main(argv)
    finally:
        if argv is None:
            # The work is done and said: a signal from here on would end the interpreter's shutdown
            # by signal (exit -15, no word), once Python has put back the default actions.  Ignored
            # (process-wide: NumPy's threads take signals too), the exit code is the run's.
            with contextlib.suppress(ValueError, OSError):
                for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
                    signal.signal(signum, signal.SIG_IGN)


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    learn(parser, getattr(args, "command", None))   # a library message's parameters, shown as flags
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    _RECEIVED.clear()
    try:
        with (_signals_as_interrupt(then_ignore=argv is None), _warnings_as_lines(),
              _memory_limit(getattr(args, "max_memory", None))):
            code = args.func(args)
        if _RECEIVED:  # its KeyboardInterrupt was swallowed (raised in a callback): still a stop
            raise _Stopped
        return code
    except RenderInterrupted as exc:
        fail(raw_message(exc) or "interrupted; every POV-Ray process was stopped", exc.exit_code)
    except Exception as exc:
        if _RECEIVED or _raised_by_a_stop(exc):
            # The stop, whatever became of it on the way: wrapped (3.11's "Error calling
            # __set_name__", an ImportError from an import in C) or a later failure of what it
            # cut short (a module left half imported, read again; a swallowed import error).
            fail("interrupted", 130)
        _fail_on(exc)
    except KeyboardInterrupt:
        fail("interrupted", 130)


def _fail_on(exc: Exception) -> NoReturn:
    if isinstance(exc, Povh3dError):
        fail(raw_message(exc), exc.exit_code)
    if isinstance(exc, MemoryError):
        fail("out of memory; use a smaller panel (--lenses, --ppl) or close other programs", 1)
    if isinstance(exc, OSError):  # the environment's fault (a full disk, a permission), not the user's input
        where = f" {exc.filename!s}:" if exc.filename else ""
        fail(f"{where} {exc.strerror or exc}".strip(), 1)
    if os.environ.get("POVH3D_DEBUG"):  # a bug: still one line, the traceback on request
        raise exc
    fail(f"internal error (a bug in povh3d, please report it): {type(exc).__name__}: {exc}; "
         "set POVH3D_DEBUG=1 for the traceback", 70)


def _raised_by_a_stop(exc: BaseException) -> bool:
    """Whether a KeyboardInterrupt is ``exc`` or in its chain (``__cause__``, ``__context__``, an
    exception group's members): an error raised while a stop propagated."""
    pending: list[BaseException | None] = [exc]
    seen: set[int] = set()
    while pending:
        current = pending.pop()
        if current is None or id(current) in seen:
            continue
        if isinstance(current, KeyboardInterrupt):
            return True
        seen.add(id(current))
        pending += [current.__cause__, current.__context__, *getattr(current, "exceptions", ())]
    return False


_RECEIVED: list[int] = []   # the signals that stopped this run


class _Stopped(KeyboardInterrupt):
    """A signal ``main`` handles, as Ctrl-C: a KeyboardInterrupt to every ``except`` on the way.

    Not KeyboardInterrupt itself: CPython marks one that ends code run by ``exec`` or ``eval`` (a
    dataclass's or namedtuple's generated methods, while a command imports its modules) as unhandled
    even when it is caught later, and ``python -m povh3d.cli`` then ended by SIGINT (-2) after the
    one line: 7 of 150 SIGTERMs in a render's first 0.9 s.  CPython compares the exception's exact
    type, so a subclass is not marked."""


def _interrupt(signum: int, frame: object) -> None:
    _RECEIVED.append(signum)
    raise _Stopped


@contextlib.contextmanager
def _signals_as_interrupt(*, then_ignore: bool = False):
    """SIGTERM and SIGHUP stop a run as Ctrl-C does: every child stopped, every temporary
    folder removed, no output replaced (they raise KeyboardInterrupt themselves: a shell
    starts a background job with SIGINT ignored, and SIGTERM must still stop it).  Afterwards
    the handlers of ``povh3d.cli`` are back, or, ``then_ignore`` (the command line's own run),
    the signals are ignored: the run is over, and its line ("interrupted" or another) is the
    only one (povh3d.cli's handler would add a second "interrupted")."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {}
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        if signum != signal.SIGINT or signal.getsignal(signum) is not signal.SIG_IGN:
            previous[signum] = signal.signal(signum, _interrupt)
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, signal.SIG_IGN if then_ignore else handler)


@contextlib.contextmanager
def _memory_limit(size: str | None):
    """``--max-memory``: kept in ``POVH3D_MAX_MEMORY`` for the run (``renderer.budget``, the POV-Ray
    processes' own limit) and put back after it (``main`` also runs in-process, in tests)."""
    if size is None:
        yield
        return
    from ..renderer.budget import LIMIT_ENV, parse_size

    parse_size(size)  # a bad size is one line before any work
    previous = os.environ.get(LIMIT_ENV)
    os.environ[LIMIT_ENV] = size
    try:
        yield
    finally:
        if previous is None:
            os.environ.pop(LIMIT_ENV, None)
        else:
            os.environ[LIMIT_ENV] = previous


@contextlib.contextmanager
def _warnings_as_lines():
    """Print every ``Povh3dWarning`` as one yellow line (library code never prints)."""
    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, Povh3dWarning):
            warn([raw_message(message) if isinstance(message, Warning) else str(message)])
        else:
            original(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        original = warnings.showwarning
        warnings.simplefilter("always", Povh3dWarning)
        warnings.showwarning = show
        yield


if __name__ == "__main__":
    sys.exit(main())
