"""The ``povh3d`` command line: the parser and the one place errors become messages.

Every user error becomes one red line on stderr and a non-zero exit code,
never a traceback.  Progress goes to stderr, results to stdout.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import NoReturn

from .._version import __version__
from ..errors import Povh3dError, RenderInterrupted
from . import calibration, display, render


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not usage + message
        fail(f"{message} (see '{self.prog} --help')", 2)


def fail(message: str, code: int) -> NoReturn:
    red, reset = ("\033[31m", "\033[0m") if sys.stderr.isatty() else ("", "")
    print(f"{red}povh3d: error: {message}{reset}", file=sys.stderr)
    raise SystemExit(code)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="povh3d", description="Holoscopic 3D (integral imaging) images with POV-Ray.")
    parser.add_argument("--version", action="version", version=f"povh3d {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    render.add_parsers(sub)
    display.add_parsers(sub)
    calibration.add_parsers(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return 2
    try:
        return args.func(args)
    except RenderInterrupted as exc:
        fail(str(exc) or "interrupted; every POV-Ray process was stopped", exc.exit_code)
    except KeyboardInterrupt:
        fail("interrupted", 130)
    except Povh3dError as exc:
        fail(str(exc), exc.exit_code)


if __name__ == "__main__":
    sys.exit(main())
