"""The ``povh3d`` command line (argument parsing only; the work is ``povh3d.renderer``'s and ``povh3d.commands``'s)."""

import _signal  # the C module: ready at once, where ``signal`` first builds its enums
import os
import sys


def _stop_quietly(signum, frame):  # noqa: ARG001 - a signal handler's signature
    """Ctrl-C, SIGTERM or SIGHUP while the command starts or ends (outside ``main``'s own
    handling): one line and exit code 130, never a traceback nor a silent death by signal.

    The process ends here, raising nothing: nothing is under way yet (no child, no temporary
    folder, no output), and an exception raised from a handler can land anywhere.  A SystemExit
    that landed in a class body's ``__set_name__`` (``ipaddress``, imported by ``pathlib`` while
    ``povh3d.cli.main`` imports) became CPython 3.11's "RuntimeError: Error calling __set_name__",
    a traceback and exit 1 after the line.  ``os.write``: a print here could land inside another
    print and raise."""
    os.write(2, b"povh3d: error: interrupted\n")
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001, S110 - a flush interrupted mid-way ("reentrant call"): the line is out
            pass
    os._exit(130)


def _unraisable(info):
    """A stop raised inside a callback Python cannot raise from (a weakref's, in an import) would
    be printed as "Exception ignored ... Traceback" and lost.  ``main`` sees the signal it
    recorded and stops: say nothing here."""
    if isinstance(info.exc_value, KeyboardInterrupt):
        return
    _previous_hook(info)


_previous_hook = sys.unraisablehook
sys.unraisablehook = _unraisable

# Installed first, before the heavy imports below: ``main`` takes over for the work itself.  A
# signal the shell set to be ignored (SIGINT in a background job) stays ignored; a library
# user's own handlers are kept.
for _signum, _default in ((_signal.SIGINT, _signal.default_int_handler), (_signal.SIGTERM, _signal.SIG_DFL),
                          (_signal.SIGHUP, _signal.SIG_DFL)):
    try:
        if _signal.getsignal(_signum) is _default:
            _signal.signal(_signum, _stop_quietly)
    except ValueError:  # imported in a thread other than the main one: no handlers there
        break

# The ``povh3d`` launcher (bin/povh3d) starts Python with these signals blocked: one that came
# while the interpreter started is pending, and is delivered here, to the handlers above.  Before
# any thread or child process (POV-Ray, Dask) starts: both inherit the mask.
if os.environ.pop("POVH3D_SIGNALS_BLOCKED", None):
    _signal.pthread_sigmask(_signal.SIG_UNBLOCK, (_signal.SIGINT, _signal.SIGTERM, _signal.SIGHUP))

from .main import main  # noqa: E402 - after the handlers, on purpose

__all__ = ["main"]
