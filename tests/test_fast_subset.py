"""The guard of the fast subset (tests/support/processes.py): it must see a POV-Ray start
and a povh3d child process, and let other programs run."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.support.processes import forbid_povray, is_povray_start, refused_in_children


def test_povray_and_the_povh3d_command_are_seen():
    assert is_povray_start(["povray", "+Iscene.pov"])
    assert is_povray_start("/usr/bin/povray")
    assert is_povray_start(["x", "+Iscene.pov"], executable="povray")
    assert is_povray_start([sys.executable, "-m", "povh3d.cli", "render"])
    assert is_povray_start([sys.executable, "-c", "import povh3d.cli.main"])


def test_negative_control_other_programs_are_not_povray():
    assert not is_povray_start(["true"])
    assert not is_povray_start([sys.executable, "-c", "pass"])
    assert not is_povray_start(["/bin/sh", "-c", "echo povray"])  # only the program counts, not its words


def test_the_guard_refuses_povray_and_records_it():
    start = subprocess.Popen._execute_child
    with forbid_povray() as refused:
        with pytest.raises(RuntimeError, match="pytest.mark.povray"):
            subprocess.run(["povray", "--version"], capture_output=True, check=False)
        assert subprocess.run(["true"], check=False).returncode == 0  # other programs still run
    assert refused == ["povray --version"]
    assert subprocess.Popen._execute_child is start  # left as it was found


def test_a_forked_child_that_execs_povray_is_ended_and_reported(tmp_path):
    log = tmp_path / "refused"
    with forbid_povray(log):
        pid = os.fork()
        if pid == 0:  # as pty.fork's child does
            try:
                os.execv("/bin/true", ["true"])  # not POV-Ray: runs
            finally:
                os._exit(1)
        assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0
        pid = os.fork()
        if pid == 0:
            try:
                os.execvp("povray", ["povray", "--version"])
            finally:
                os._exit(1)
        assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 70
    assert refused_in_children(log) == ["povray --version"]
    assert refused_in_children(log) == []  # read once
