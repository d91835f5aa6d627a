"""A stop by signal ends the command with exit code 130 and one line, never by the signal itself
(issue 25): the run's own handlers, and the window before them while the interpreter starts."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.conftest import REPO, SAMPLE

ENV = {**os.environ, "PYTHONPATH": str(REPO)}

# The command line's own run (``main()`` reads sys.argv), whose ``presets`` command runs generated
# code, as a dataclass's methods are while a command imports its modules, and sends the process
# SIGNUM from inside it.  {control} can put back the plain KeyboardInterrupt.
_INSIDE_EXEC = """
import sys
import povh3d.cli.display as display
from povh3d.cli.main import main
cli_main = sys.modules["povh3d.cli.main"]  # povh3d.cli's attribute "main" is the function
{control}
signum = int(sys.argv[1])

def cmd_presets(args):
    exec("import os\\nos.kill(os.getpid(), %d)\\nfor _ in range(100000): pass" % signum)
    return 0

display.cmd_presets = cmd_presets
sys.argv[1:] = ["presets"]
sys.exit(main())
"""


def _run_module(folder, source: str, *args, **popen):
    """``python -m`` of ``source`` as a module, as ``python -m povh3d.cli`` runs: only there does
    CPython end the process by SIGINT (``-c`` and a script, as the ``povh3d`` command's, exit from
    within the SystemExit instead)."""
    (folder / "povh3d_run.py").write_text(source, encoding="utf-8")
    env = {**ENV, "PYTHONPATH": f"{REPO}{os.pathsep}{folder}", **popen.pop("env", {})}
    return subprocess.Popen([sys.executable, "-m", "povh3d_run", *map(str, args)], env=env, **popen)


def _run_inside_exec(folder, signum: int, control: str = "") -> tuple[int, str]:
    proc = _run_module(folder, _INSIDE_EXEC.format(control=control), int(signum), stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, text=True)
    err = proc.communicate(timeout=60)[1]
    return proc.returncode, err


@pytest.mark.povray
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_inside_generated_code_exits_130_not_by_sigint(signum, tmp_path):
    """CPython ends a process by SIGINT, after its exit code was given, when a plain KeyboardInterrupt
    left code run by exec (1 in about 20 SIGTERMs early in a render printed the line, then -2)."""
    code, err = _run_inside_exec(tmp_path, signum)
    assert code == 130, (code, err)
    assert err.splitlines() == ["povh3d: error: interrupted"], err


@pytest.mark.povray
def test_negative_control_a_plain_keyboard_interrupt_there_ends_by_sigint(tmp_path):
    # The oracle bites: with the handler raising KeyboardInterrupt itself (before the fix), the same
    # process prints the line and then ends by SIGINT.
    code, err = _run_inside_exec(tmp_path, signal.SIGTERM, control="cli_main._Stopped = KeyboardInterrupt")
    assert code == -signal.SIGINT, (code, err)
    assert err.splitlines() == ["povh3d: error: interrupted"], err


# The command line's own run, after ``povh3d.cli`` is imported (its handlers in place): "up", then
# a render whose first half second imports the modules of the work.
_RENDER = """
import sys
from povh3d.cli.main import main
sys.stderr.write("up\\n"); sys.stderr.flush()
sys.exit(main())
"""
TRIALS = 24


@pytest.mark.povray
def test_sigterm_early_in_a_render_never_ends_by_a_signal(tmp_path):
    """TRIALS SIGTERMs at random moments of a render's first 0.4 s (its imports, the scene's
    preparation, POV-Ray's start): each one ends 130 with one line, or the render finished first."""
    rng = np.random.default_rng(25)
    args = ["render", SAMPLE, "-o", tmp_path / "out.png", "--preset", "demo", "--lenses", "6x4", "--ppl", "4",
            "--quality", "draft", "-q", "--no-cache"]
    codes = []
    for _ in range(TRIALS):
        proc = _run_module(tmp_path, _RENDER, *args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           env={"POVH3D_CACHE": str(tmp_path / "cache")})
        assert proc.stderr.readline() == b"up\n"
        time.sleep(rng.uniform(0.0, 0.4))
        proc.send_signal(signal.SIGTERM)
        err = proc.communicate(timeout=60)[1].decode()
        codes.append(proc.returncode)
        assert proc.returncode in (0, 130), (proc.returncode, err)
        if proc.returncode:
            assert len(err.splitlines()) == 1 and err.startswith("povh3d: error: "), err
    assert codes.count(130) >= TRIALS // 2, codes  # the signals did land in the work


# What ``import povh3d`` imports comes before povh3d.cli's handlers (``python -m povh3d`` imports
# povh3d.cli.main, so the package first): without the launcher (bin/povh3d, which blocks the
# signals until then) a signal then is Python's (a traceback) or the default action's (an end by
# signal, silent).  It stays the standard library's import machinery.
_NEW_MODULES = ("import json, sys; before = set(sys.modules); {prelude}import povh3d; "
                "print(json.dumps(sorted(set(sys.modules) - before)))")
_AT_START = {"__future__", "importlib", "importlib._bootstrap", "importlib._bootstrap_external", "povh3d",
             "povh3d._version", "warnings"}


def _imported_by_povh3d(prelude: str = "") -> set[str]:
    done = subprocess.run([sys.executable, "-c", _NEW_MODULES.format(prelude=prelude)], capture_output=True,
                          text=True, env=ENV, timeout=60, check=True)
    return set(json.loads(done.stdout))


@pytest.mark.povray
def test_import_povh3d_before_the_handlers_stays_small():
    assert _imported_by_povh3d() <= _AT_START  # typing (7 ms of the window) was among them


@pytest.mark.povray
def test_negative_control_the_probe_sees_an_import():
    assert "typing" in _imported_by_povh3d("import povh3d.geometry.lens_array; ")


# A module whose class body sends the process SIGNUM from a descriptor's ``__set_name__``, as a
# stop can land in ``ipaddress``'s ``cached_property`` while ``povh3d.cli.main`` imports (pathlib
# imports it): CPython 3.11 wraps whatever ``__set_name__`` raises in a RuntimeError.
_SET_NAME = """
import os

class _Sends:
    def __set_name__(self, owner, name):
        if int(os.environ["SIGNUM"]):
            os.kill(os.getpid(), int(os.environ["SIGNUM"]))
            for _ in range(100000): pass

class Lens:
    pitch = _Sends()
"""

# Before ``main``, with povh3d.cli's handlers in place.  {control} can put back a handler that
# raises SystemExit(130) after the line, as povh3d.cli's did.
_BEFORE_MAIN = """
import os, signal, sys
import povh3d.cli
{control}
import povh3d_set_name
sys.exit(0)
"""

_RAISING = """
def _raising(signum, frame):
    os.write(2, b"povh3d: error: interrupted\\n")
    raise SystemExit(130)
signal.signal(int(sys.argv[1]), _raising)
"""


def _run(folder, source: str, signum: int) -> tuple[int, str]:
    (folder / "povh3d_set_name.py").write_text(_SET_NAME, encoding="utf-8")
    proc = _run_module(folder, source, int(signum), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                       env={"SIGNUM": str(int(signum))})
    err = proc.communicate(timeout=60)[1]
    return proc.returncode, err


@pytest.mark.povray
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_inside_set_name_as_the_command_starts_is_one_line(signum, tmp_path):
    """1 in 25 SIGINTs as the command started: the line, then "RuntimeError: Error calling
    __set_name__ on 'cached_property' instance 'hostmask' in 'IPv6Interface'" and exit 1."""
    code, err = _run(tmp_path, _BEFORE_MAIN.format(control=""), signum)
    assert (code, err.splitlines()) == (130, ["povh3d: error: interrupted"]), (code, err)


@pytest.mark.povray
def test_negative_control_a_raised_stop_there_is_a_traceback(tmp_path):
    code, err = _run(tmp_path, _BEFORE_MAIN.format(control=_RAISING), signal.SIGINT)
    assert code == 1 and "RuntimeError: Error calling __set_name__" in err, (code, err)
    assert err.startswith("povh3d: error: interrupted\n"), err


# In ``main``: the command imports a module the signal lands in, takes its failure for an optional
# module's (swallowed), and then fails as that absence makes it fail.  {control} sends the signal
# a second time once the "interrupted" line is out.
_IN_MAIN = """
import os, signal, sys
import povh3d.cli.display as display
from povh3d.cli.main import main
from povh3d.errors import Povh3dError
cli_main = sys.modules["povh3d.cli.main"]
{control}

def cmd_presets(args):
    try:
        import povh3d_set_name
    except Exception:
        pass
    raise Povh3dError("no presets found")

display.cmd_presets = cmd_presets
signum = int(sys.argv[1])
sys.argv[1:] = ["presets"]
sys.exit(main())
"""

_SECOND_SIGNAL = """
class _Echo:  # stderr that brings the signal again once the line is written
    def __init__(self, stream):
        self.stream, self.said = stream, ""
    def write(self, text):
        self.stream.write(text)
        self.stream.flush()
        self.said += text
        if self.said.endswith("interrupted\\n"):
            os.kill(os.getpid(), int(os.environ["SIGNUM"]))
            for _ in range(100000): pass
    def __getattr__(self, name):
        return getattr(self.stream, name)

sys.stderr = _Echo(sys.stderr)
"""


@pytest.mark.povray
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_failure_after_a_swallowed_stop_is_the_stop(signum, tmp_path):
    """An error that follows a stop (here a Povh3dError) was said as that error, exit 1."""
    code, err = _run(tmp_path, _IN_MAIN.format(control=""), signum)
    assert (code, err.splitlines()) == (130, ["povh3d: error: interrupted"]), (code, err)


@pytest.mark.povray
def test_negative_control_without_a_signal_the_error_is_its_own(tmp_path):
    code, err = _run(tmp_path, _IN_MAIN.format(control=""), 0)
    assert (code, err.splitlines()) == (1, ["povh3d: error: no presets found"]), (code, err)


@pytest.mark.povray
@pytest.mark.parametrize("control, lines", [
    ("", 1),
    # negative control: povh3d.cli's handlers put back after the run, as before, say it twice
    ("run = cli_main._signals_as_interrupt\ncli_main._signals_as_interrupt = lambda then_ignore: run()", 2)])
def test_a_second_signal_after_the_line_adds_nothing(control, lines, tmp_path):
    code, err = _run(tmp_path, _IN_MAIN.format(control=_SECOND_SIGNAL + control), signal.SIGINT)
    assert (code, err.splitlines()) == (130, ["povh3d: error: interrupted"] * lines), (code, err)
