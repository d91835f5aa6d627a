"""POV-Ray's version remembered across runs, per binary (issue 17)."""

from __future__ import annotations

import pytest
import json
import os

from povh3d.renderer.shots.shots import LocalRunner
from povh3d.povray import process
from povh3d.povray.version_memo import FILE_NAME, remembered_version


def _fake_povray(tmp_path, version="3.7.0.10.unofficial"):
    """A stand-in ``povray`` that prints a version and counts its runs."""
    binary = tmp_path / "povray"
    binary.write_text(f"#!/bin/sh\necho x >> {tmp_path / 'runs'}\necho 'POV-Ray {version}' >&2\n")
    binary.chmod(0o755)
    return binary


def _runs(tmp_path) -> int:
    path = tmp_path / "runs"
    return len(path.read_text().splitlines()) if path.exists() else 0


@pytest.mark.povray
def test_asked_once_then_remembered_until_the_binary_changes(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("POVH3D_CACHE", str(cache))
    binary = _fake_povray(tmp_path)
    for _ in range(3):  # three "processes": the in-process memory is cleared each time
        process._VERSIONS.clear()
        assert LocalRunner(str(binary)).version == "3.7.0.10.unofficial"
    assert _runs(tmp_path) == 1
    assert list(json.loads((cache / FILE_NAME).read_text()).values()) == ["3.7.0.10.unofficial"]
    # an upgrade in place changes the binary's size and mtime: asked again
    _fake_povray(tmp_path, "3.7.1.0")
    os.utime(binary, ns=(1, 10**18))
    process._VERSIONS.clear()
    assert LocalRunner(str(binary)).version == "3.7.1.0"
    assert _runs(tmp_path) == 2


def test_an_unwritable_or_corrupt_memory_is_ignored(tmp_path):
    asked = []

    def ask(binary):
        asked.append(binary)
        return "3.7.0.10"

    blocker = tmp_path / "a-file"
    blocker.write_text("")
    # the folder cannot be created (a file is in the way): the version is still found, each time
    assert remembered_version("/bin/sh", blocker / "cache", ask) == "3.7.0.10"
    assert remembered_version("/bin/sh", blocker / "cache", ask) == "3.7.0.10"
    assert len(asked) == 2
    (tmp_path / FILE_NAME).write_text("{not json")
    assert remembered_version("/bin/sh", tmp_path, ask) == "3.7.0.10"
    assert remembered_version("/bin/sh", tmp_path, ask) == "3.7.0.10"
    assert len(asked) == 3  # rewritten after the corrupt read, then used
    # a binary that cannot be found is not remembered, only asked
    assert remembered_version(str(tmp_path / "nowhere"), tmp_path, ask) == "3.7.0.10"
    assert len(asked) == 4


def _slow_povray(tmp_path, seconds: float):
    """A stand-in ``povray`` that writes its pid, waits ``seconds``, prints a version and counts its runs."""
    binary = tmp_path / "povray"
    binary.write_text(f"#!/bin/sh\necho $$ > {tmp_path / 'pid'}\necho x >> {tmp_path / 'runs'}\nsleep {seconds}\n"
                      "echo 'POV-Ray 3.7.0.10.unofficial' >&2\n")
    binary.chmod(0o755)
    return binary


def test_an_early_probe_runs_beside_the_start_and_is_taken_once(tmp_path):
    """``probe_version_early`` starts the probe without waiting for it; ``povray_version`` then takes the
    probe's answer, not a second run; a binary the memory knows starts no probe (the control)."""
    binary = _slow_povray(tmp_path, 0.4)
    process._VERSIONS.clear()
    process.probe_version_early(str(binary), tmp_path / "cache")
    probe = process._PROBES[str(binary)]
    assert probe.poll() is None   # still running: the caller did not wait for it
    assert remembered_version(str(binary), tmp_path / "cache", process.povray_version) == "3.7.0.10.unofficial"
    assert _runs(tmp_path) == 1 and probe.returncode == 0 and process._PROBES == {}
    process._VERSIONS.clear()
    process.probe_version_early(str(binary), tmp_path / "cache")   # remembered now: no probe
    assert process._PROBES == {}
    assert remembered_version(str(binary), tmp_path / "cache", process.povray_version) == "3.7.0.10.unofficial"
    assert _runs(tmp_path) == 1


def test_a_probe_nobody_took_is_stopped_at_exit(tmp_path):
    """A command that fails before it renders leaves no ``povray --version`` running."""
    import subprocess
    import sys
    import time

    binary = tmp_path / "povray"   # the probe itself waits (exec): its pid is the process to be stopped
    binary.write_text(f"#!/bin/sh\necho $$ > {tmp_path / 'pid'}\nexec sleep 30\n")
    binary.chmod(0o755)
    pid_file = tmp_path / "pid"   # waited for, so the probe runs when the command ends, however loaded the machine
    code = ("from povh3d.povray.process import probe_version_early; import os, time\n"
            f"probe_version_early({str(binary)!r}, {str(tmp_path / 'cache')!r})\n"
            f"deadline = time.monotonic() + 15\n"
            f"while not (os.path.exists({str(pid_file)!r}) and os.path.getsize({str(pid_file)!r}))"
            " and time.monotonic() < deadline: time.sleep(0.02)\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=20)
    pid = int((tmp_path / "pid").read_text())
    time.sleep(0.1)
    try:
        state = open(f"/proc/{pid}/stat").read().split()[2]
    except FileNotFoundError:
        state = "gone"
    assert state in ("gone", "Z"), state   # killed (a zombie of init's until reaped), never running


def test_a_probe_the_command_did_not_take_is_stopped_when_it_ends(tmp_path, monkeypatch):
    """In one long-lived process (an API caller's, a test's): ``render`` fails before its first POV-Ray run
    (its depth maps' folder is a file); the probe it started was stopped and reaped when it ended, so none is
    left a child; the probe had started (the control)."""
    import povh3d.povray.process as process_module
    from povh3d.cli.main import main

    binary = tmp_path / "povray"
    binary.write_text("#!/bin/sh\nexec sleep 30\n")
    binary.chmod(0o755)
    monkeypatch.setenv("POVH3D_POVRAY", str(binary))
    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    probes = []
    real = process_module.probe_version_early

    def spy(*args):
        real(*args)
        probes.extend(process_module._PROBES.values())

    monkeypatch.setattr(process_module, "probe_version_early", spy)
    scene, blocker = tmp_path / "s.pov", tmp_path / "maps"
    scene.write_text("sphere { 0, 1 pigment { rgb 1 } }\n")
    blocker.write_text("")
    with pytest.raises(SystemExit) as ended:
        main(["render", str(scene), "-o", str(tmp_path / "o.png"), "--depth-maps", str(blocker)])
    assert ended.value.code != 0
    assert len(probes) == 1 and process_module._PROBES == {}
    assert probes[0].returncode is not None   # waited for: neither running nor a zombie
