"""The ``povh3d`` command is bin/povh3d, a shell launcher that starts Python with SIGINT, SIGTERM
and SIGHUP blocked until povh3d.cli's handlers are in place (issue 25, the start-up window): a
signal while the interpreter starts is one line and exit 130, never Python's traceback nor a
silent end by the signal.

Each test installs the launcher as pip does, into the scripts folder of a virtual environment
(made without pip: a second or less) whose ``python3`` runs this checkout; a ``sitecustomize``
module on PYTHONPATH, which ``site`` imports while the interpreter starts, after Python's own
SIGINT handler and before any code of povh3d's, sends the process the signal: the window, every
time."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from tests.conftest import REPO, SAMPLE

pytestmark = pytest.mark.povray

# What ``site`` imports while the interpreter starts: the signal the test asks for, sent to the
# process itself, and the prefix the interpreter took (which Python the launcher chose).
_SITECUSTOMIZE = """
import os, sys
if os.environ.get("POVH3D_TEST_PREFIX_FILE"):
    with open(os.environ["POVH3D_TEST_PREFIX_FILE"], "w") as f:
        f.write(sys.prefix)
if os.environ.get("POVH3D_TEST_SIGNAL"):
    os.kill(os.getpid(), int(os.environ["POVH3D_TEST_SIGNAL"]))
    for _ in range(100000):  # bytecode, where Python runs its handler of a delivered signal
        pass
"""

# pip's console script, the command before the launcher
_CONSOLE_SCRIPT = """#!{python}
import sys
from povh3d.cli.main import main
if __name__ == '__main__':
    sys.argv[0] = sys.argv[0].removesuffix('.exe')
    sys.exit(main())
"""


@pytest.fixture(scope="module")
def env_bin(tmp_path_factory) -> Path:
    """The bin folder of a virtual environment holding the launcher and, as ``povh3d-console``,
    pip's console script; its site-packages reach this checkout and the running one's packages."""
    root = tmp_path_factory.mktemp("env")
    venv.EnvBuilder(with_pip=False, symlinks=True).create(root)
    bin_folder = root / "bin"
    site_packages, = (root / "lib").glob("python3*/site-packages")
    (site_packages / "povh3d_checkout.pth").write_text(f"{REPO}\n{sysconfig.get_paths()['purelib']}\n")
    shutil.copy2(REPO / "bin" / "povh3d", bin_folder / "povh3d")
    console = bin_folder / "povh3d-console"
    console.write_text(_CONSOLE_SCRIPT.format(python=bin_folder / "python3"))
    console.chmod(0o755)
    (root / "hooks").mkdir()
    (root / "hooks" / "sitecustomize.py").write_text(_SITECUSTOMIZE)
    return bin_folder


def _run(command: list[str | Path], env_bin: Path, **env: str) -> subprocess.CompletedProcess:
    environment = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    environment.update(PYTHONPATH=str(env_bin.parent / "hooks"), **env)
    return subprocess.run([str(c) for c in command], capture_output=True, text=True, env=environment,
                          timeout=120, check=False)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_a_signal_while_python_starts_is_one_line(env_bin, signum):
    done = _run([env_bin / "povh3d", "--version"], env_bin, POVH3D_TEST_SIGNAL=str(int(signum)))
    assert (done.returncode, done.stderr, done.stdout) == (130, "povh3d: error: interrupted\n", ""), done


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 1), (signal.SIGTERM, -signal.SIGTERM),
                                          (signal.SIGHUP, -signal.SIGHUP)])
def test_negative_control_the_console_script_dies_there(env_bin, signum, code):
    # The same moment through pip's console script: Python's traceback ("Failed to import the
    # site module", exit 1) for SIGINT, an end by the signal without a word for the others.
    done = _run([env_bin / "povh3d-console", "--version"], env_bin, POVH3D_TEST_SIGNAL=str(int(signum)))
    assert done.returncode == code, done
    assert ("Traceback" in done.stderr) == (signum == signal.SIGINT), done.stderr
    assert "interrupted" not in done.stderr


def test_the_launcher_is_the_command(env_bin, tmp_path):
    """Arguments, output and exit codes pass through; the Python is the one beside the launcher,
    also through a link to it from another folder (pipx, uv), and the current folder is not on
    sys.path (a ``povh3d`` folder there is not imported)."""
    (tmp_path / "povh3d").mkdir()
    (tmp_path / "povh3d" / "__init__.py").write_text("raise SystemExit('imported from the current folder')\n")
    link_folder = tmp_path / "links"
    link_folder.mkdir()
    (link_folder / "povh3d").symlink_to(env_bin / "povh3d")
    prefix_file = tmp_path / "prefix"
    for launcher in (env_bin / "povh3d", link_folder / "povh3d"):
        prefix_file.unlink(missing_ok=True)
        done = subprocess.run([str(launcher), "--version"], cwd=tmp_path, capture_output=True, text=True,
                              env={**os.environ, "PYTHONPATH": str(env_bin.parent / "hooks"),
                                   "POVH3D_TEST_PREFIX_FILE": str(prefix_file)}, timeout=120, check=False)
        assert (done.returncode, done.stdout.split()[0], done.stderr) == (0, "povh3d", ""), done
        assert prefix_file.read_text() == str(env_bin.parent)  # this environment's Python, not PATH's
    done = _run([env_bin / "povh3d", "render", "--lenses", "3x3"], env_bin)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "povh3d: error:" in done.stderr, done


# POV-Ray's stand-in: records the signal mask it was started with (``SigBlk``; POV-Ray sets its
# own at once, and a shell clears it), then runs POV-Ray.
_MASK_PROBE = """#!{python}
import os, sys
with open({log!r}, "a") as log:
    log.write([l for l in open("/proc/self/status") if l.startswith("SigBlk:")][0])
os.execv("/usr/bin/povray", ["povray", *sys.argv[1:]])
"""


@pytest.mark.parametrize("marker, blocked", [("1", False), ("", True)])
def test_povray_starts_with_no_signal_blocked(env_bin, tmp_path, marker, blocked):
    """The mask goes to every child: povh3d.cli unblocks before any starts.  The control starts
    Python with the signals blocked but without the launcher's mark, which povh3d.cli reads before
    it unblocks: the probe then sees them blocked."""
    log = tmp_path / "masks"
    probe = tmp_path / "povray-probe"
    probe.write_text(_MASK_PROBE.format(python=sys.executable, log=str(log)))
    probe.chmod(0o755)
    blocking = ["env", "--block-signal=INT", "--block-signal=TERM", "--block-signal=HUP",
                f"POVH3D_SIGNALS_BLOCKED={marker}"]
    done = _run([*blocking, env_bin / "python3", "-P", "-m", "povh3d", "render", SAMPLE, "-o", tmp_path / "o.png",
                 "--preset", "demo", "--lenses", "6x4", "--ppl", "4", "--quality", "draft", "-q", "--no-cache"],
                env_bin, POVH3D_POVRAY=str(probe), POVH3D_SANDBOX="off", POVH3D_CACHE=str(tmp_path / "cache"))
    assert done.returncode == 0, done
    masks = {int(line.split()[1], 16) for line in log.read_text().splitlines()}
    wanted = (1 << signal.SIGINT - 1) | (1 << signal.SIGTERM - 1) | (1 << signal.SIGHUP - 1)
    assert masks and all((mask & wanted == wanted) if blocked else mask == 0 for mask in masks), masks


def test_without_a_python_beside_or_block_signal_it_still_runs(env_bin, tmp_path):
    """No Python beside the launcher (``pip install --user``): the ``python3`` on PATH.  An ``env``
    without ``--block-signal`` (busybox): Python is started without it, as before the launcher;
    the control is the same run with the real env, where the signal from ``site`` waits."""
    alone = tmp_path / "user-bin"
    alone.mkdir()
    shutil.copy2(REPO / "bin" / "povh3d", alone / "povh3d")
    old_env = tmp_path / "old-env"
    old_env.mkdir()
    (old_env / "env").write_text('#!/bin/sh\ncase $1 in --block-signal*) echo "env: unrecognized option" >&2; '
                                 'exit 1;; esac\nexec /usr/bin/env "$@"\n')
    (old_env / "env").chmod(0o755)
    prefix_file = tmp_path / "prefix"
    path = f"{env_bin}{os.pathsep}/usr/bin{os.pathsep}/bin"
    done = _run([alone / "povh3d", "--version"], env_bin, PATH=path, POVH3D_TEST_PREFIX_FILE=str(prefix_file))
    assert (done.returncode, done.stderr) == (0, ""), done
    assert prefix_file.read_text() == str(env_bin.parent)
    for folder, code in ((old_env, 1), (None, 130)):
        done = _run([alone / "povh3d", "--version"], env_bin, PATH=f"{folder}{os.pathsep}{path}" if folder else path,
                    POVH3D_TEST_SIGNAL=str(int(signal.SIGINT)))
        assert done.returncode == code, done
        assert ("Traceback" in done.stderr) == (folder is not None), done.stderr
