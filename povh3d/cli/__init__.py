"""The ``povh3d`` command line (argument parsing only; the work is ``povh3d.app``'s)."""

import _signal  # the C module: ready at once, where ``signal`` first builds its enums
import os
import sys


def _stop_quietly(signum, frame):  # noqa: ARG001 - a signal handler's signature
    """Ctrl-C, SIGTERM or SIGHUP while the command starts or ends (outside ``main``'s own
    handling): one line and exit code 130, never a traceback nor a silent death by signal.
    ``os.write``: a print here could land inside another print and raise."""
    os.write(2, b"povh3d: error: interrupted\n")
    raise SystemExit(130)


def _unraisable(info):
    """A stop raised inside a callback Python cannot raise from (a weakref's, in an import) would
    be printed as "Exception ignored ... Traceback" and lost.  Before ``main``: stop (the line is
    said).  In ``main``: say nothing; ``main`` sees the signal it recorded and stops."""
    if isinstance(info.exc_value, SystemExit):
        os._exit(130)
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

from .main import main  # noqa: E402 - after the handlers, on purpose

__all__ = ["main"]
