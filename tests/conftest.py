"""Shared fixtures (an isolated image cache per test, a POV-Ray work folder, the in-process
command line), the paths the tests share, and the fast subset: ``pytest --fast`` leaves out
the tests marked ``povray`` or ``slow`` and fails any other test that starts POV-Ray
(tests/support/processes.py)."""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
from pathlib import Path

import pytest

from tests.support import processes, scheduling
from tests.support.cli import Result, run_in_process

# A test run started in the background of a non-interactive shell (nohup, `cmd &` in a CI script)
# inherits SIGINT ignored, and povh3d rightly keeps an inherited ignore, so the tests that interrupt
# a povh3d process would see it run on.  Catching SIGINT here makes every child start with the
# default action again (exec resets a caught signal, not an ignored one): the tests that want an
# ignored SIGINT set it themselves (test_reliability's ``_sigint_in_child``).
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "sample_models"
SAMPLE = SAMPLES / "sample.pov"


def pytest_addoption(parser):
    parser.addoption("--fast", action="store_true",
                     help=f"leave out the tests marked {processes.MARK!r} or 'slow' and fail any other test "
                          "that starts POV-Ray or the povh3d command as a process (make test-fast)")


def pytest_configure(config):
    if config.getoption("--fast"):
        log = Path(tempfile.mkdtemp(prefix="povh3d-fast-")) / "refused"
        guard = processes.forbid_povray(log)
        config.stash[_REFUSED] = (guard.__enter__(), log)
        config.add_cleanup(lambda: (guard.__exit__(None, None, None), shutil.rmtree(log.parent, True)))


_REFUSED = pytest.StashKey[tuple]()


def pytest_xdist_make_scheduler(config, log):
    """``--dist loadgroup``: the tests spread one by one over the workers, which keeps every worker
    busy to the end, but the tests of a module that share a module- or session-wide fixture (a
    render, a cluster, a browser) go to one worker together, so that the fixture is made once
    (tests/support/scheduling.py).

    Our own, because pytest-xdist 3.8's loadgroup marks a test's group in ``item._nodeid``,
    which pytest 9 no longer reads (its groups were lost, or no test ran)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    groups = scheduling.shared_fixture_groups(REPO, REPO / "tests")

    class SharedFixtureScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return scheduling.group_of(nodeid, groups)

    return SharedFixtureScheduling(config, log)


def pytest_collection_modifyitems(config, items):
    if not config.getoption("--fast"):
        return
    left_out = [item for item in items if any(item.get_closest_marker(m) for m in (processes.MARK, "slow"))]
    if left_out:
        config.hook.pytest_deselected(items=left_out)
        dropped = set(left_out)
        items[:] = [item for item in items if item not in dropped]


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    # A test of the fast subset that tried to start POV-Ray fails, even when the code under
    # test caught the error the guard raised.
    outcome = yield
    if _REFUSED not in item.config.stash:
        return
    refused, log = item.config.stash[_REFUSED]
    lines = refused + processes.refused_in_children(log)
    refused.clear()
    if not lines:
        return
    report = outcome.get_result()
    if os.environ.get("POVH3D_TEST_RECORD"):
        processes.record(os.environ["POVH3D_TEST_RECORD"], item.nodeid)
    report.outcome = "failed"
    report.longrepr = f"{lines[0][:120]!r} {processes.HINT}"


@pytest.fixture(autouse=True)
def _isolated_cache(tmp_path_factory, monkeypatch):
    # Never touch the user's cache; each test starts cold unless it shares this folder.
    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path_factory.mktemp("cache")))


@pytest.fixture
def workdir(tmp_path):
    """A folder for POV-Ray jobs' temporary folders (run_jobs(workdir=...))."""
    path = tmp_path / "work"
    path.mkdir()
    return path


@pytest.fixture
def cli(monkeypatch):
    """The command line in this process: ``cli(*args, cwd=None, env=None) -> Result(code, out, err)``.

    ``main`` runs with stdout and stderr captured and ``SystemExit`` caught; ``cwd`` and ``env``
    (added to the environment) hold for that one run."""
    def run(*args, cwd: str | Path | None = None, env: dict[str, str] | None = None) -> Result:
        with monkeypatch.context() as patch:
            if cwd is not None:
                patch.chdir(cwd)
            for name, value in (env or {}).items():
                patch.setenv(name, value)
            return run_in_process(*args)
    return run
