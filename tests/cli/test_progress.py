"""Progress on a terminal (issue 17): the CLI run in a pseudo-terminal shows the share of
pixels POV-Ray reports, the frames and the time left; nothing without a terminal or with -q."""

from __future__ import annotations

import io
import os
import pty
import re

import pytest

from povh3d.cli.progress import StatusLine, status_text
from tests.conftest import REPO, SAMPLE
from tests.support.cli import cli_command, run_subprocess

# 960x544 antialiased on one thread: a few seconds, long enough for several reports.
SLOW = ("--lenses", "120x68", "--ppl", "8x8", "--quality", "normal", "--threads", "1", "--no-cache")
_STATUS = re.compile(r"povh3d: +(\d+)% \|[# ]+\| (\d+)/(\d+) shots +\d+:\d\d, (about \d+:\d\d left|estimating)")


def run_in_pty(args: list[str]) -> tuple[int, str]:
    """Run a command with stdin, stdout and stderr on a new pseudo-terminal; its exit code and output."""
    pid, fd = pty.fork()
    if pid == 0:  # the child: the command, with this checkout first on the path
        os.chdir(REPO)
        os.environ["PYTHONPATH"] = str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")
        os.execv(args[0], args)
    chunks = []
    while True:
        try:
            data = os.read(fd, 65536)
        except OSError:  # EIO: the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(fd)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status), b"".join(chunks).decode("utf-8", "replace")


@pytest.fixture(scope="module")
def shown(tmp_path_factory):
    out = tmp_path_factory.mktemp("progress") / "o.png"
    return out, run_in_pty(cli_command("render", SAMPLE, *SLOW, "-o", out))


@pytest.mark.povray
def test_terminal_shows_pixel_share_shots_and_time_left(shown):
    out, (code, text) = shown
    assert code == 0, text
    statuses = [m for m in _STATUS.finditer(text)]
    shares = [int(m[1]) for m in statuses]
    assert statuses, text
    # inside the one POV-Ray run: shares strictly between 0 and 100 %, rising, with a time estimate
    inside = [s for s in shares if 0 < s < 100]
    assert inside and inside == sorted(inside), shares
    assert any("about" in m[4] for m in statuses if 0 < int(m[1]) < 100)
    assert statuses[-1][2] == statuses[-1][3] == "1"  # the last report: 1/1 shots
    # the status line is erased before the result line, which stands alone
    result = text.rsplit("\x1b[K", 1)[1]
    assert result.strip().startswith(str(out)) and "960x544" in result


@pytest.mark.povray
def test_quiet_and_pipes_show_nothing(tmp_path):
    code, text = run_in_pty(cli_command("render", SAMPLE, *SLOW[:4], "--quality", "draft", "-q",
                                        "-o", tmp_path / "q.png"))
    assert code == 0 and "%" not in text and "\x1b[K" not in text
    piped = run_subprocess("render", SAMPLE, *SLOW[:4], "--quality", "draft", "-o", tmp_path / "p.png")
    assert piped.code == 0 and piped.err == ""


def test_status_text_share_count_and_estimate():
    assert status_text(0, 4, 3.0).endswith("0/4 shots  0:03, estimating time left")
    line = status_text(3, 4, 30.0)
    assert " 75% |###############     | 3/4 shots  0:30, about 0:10 left" in line
    assert "1:00:00, about 0:00 left" in status_text(4, 4, 3600.0)
    assert "2.5" not in status_text(2.5, 4, 1.0) and "2/4" in status_text(2.5, 4, 1.0)


def test_status_line_redraws_in_place_and_erases_itself():
    stream = io.StringIO()
    line = StatusLine(stream, interval=0.0)
    line(1, 2)
    line(2, 2)
    line.close()
    text = stream.getvalue()
    assert text.count("\r") == 3 and text.endswith("\r\x1b[K") and "\n" not in text
    quiet = io.StringIO()
    StatusLine(quiet).close()  # nothing drawn, nothing to erase
    assert quiet.getvalue() == ""


@pytest.mark.povray
def test_convert_mesh_shows_its_steps_on_a_terminal(tmp_path):
    model = REPO / "sample_models" / "letter_l.stl"
    code, text = run_in_pty(cli_command("convert-mesh", model, "-o", tmp_path / "l.inc"))
    assert code == 0, text
    assert re.search(r"povh3d: +\d+% \|[# ]+\| \d/4 steps", text), text
    assert text.rsplit("\x1b[K", 1)[1].strip().startswith(str(tmp_path / "l.inc"))
    code, text = run_in_pty(cli_command("convert-mesh", model, "-o", tmp_path / "q.inc", "-q"))
    assert code == 0 and "steps" not in text and "\x1b[K" not in text


def test_a_new_phase_starts_its_own_clock(monkeypatch):
    clock = iter([0.0, 0.0, 10.0, 10.0, 12.0])
    monkeypatch.setattr("povh3d.cli.progress.time.monotonic", lambda: next(clock))
    stream = io.StringIO()
    line = StatusLine(stream, interval=0.0)  # t = 0
    line(1, 4)                               # t = 0: the probe's first render
    line(4, 4)                               # t = 10
    line(0, 1)                               # t = 10: the render itself, a new total
    line(0.5, 1)                             # t = 12: 2 s for half: about 2 s left, not 12
    assert stream.getvalue().rsplit("\r", 1)[1].startswith(status_text(0.5, 1, 2.0))
