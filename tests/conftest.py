"""Shared fixtures (an isolated image cache per test, a POV-Ray work folder, the in-process
command line) and the paths the tests share."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.cli import Result, run_in_process

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "sample_models"
SAMPLE = SAMPLES / "sample.pov"


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
