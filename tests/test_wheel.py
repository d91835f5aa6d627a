"""The wheel as a user installs it: built from this tree, installed with its core dependencies
only into a fresh virtual environment, run from a folder outside the repository.

What it proves: the package data ships (templates, presets), a plain ``pip install`` renders
the bundled sample, and nothing on the render or start-up path needs an optional group.
It downloads the core dependencies from PyPI (about a minute); pip's cache makes reruns faster.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.conftest import REPO, SAMPLE

OPTIONAL = ("distributed", "pydicom", "nrrd", "scipy", "skimage", "imageio_ffmpeg",
            "fast_simplification", "lxml", "networkx")


def _run(command: list[str], cwd: Path, env: dict[str, str] | None = None, timeout: int = 900):
    done = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout, check=False)
    assert done.returncode == 0, f"{' '.join(command)} failed ({done.returncode}):\n{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> tuple[Path, Path]:
    """(python, work folder): a fresh venv holding the wheel and its core dependencies only."""
    root = tmp_path_factory.mktemp("wheel")
    _run([sys.executable, "-m", "pip", "wheel", str(REPO), "--no-deps", "-q", "-w", str(root / "dist")], cwd=root)
    wheel, = (root / "dist").glob("povh3d-*.whl")
    venv.EnvBuilder(with_pip=True, clear=True).create(root / "env")
    python = root / "env" / "bin" / "python"
    # --no-compile: byte-compiling VTK and matplotlib at install is most of the install's CPU;
    # what the test imports compiles as it is imported.
    _run([str(python), "-m", "pip", "install", "-q", "--no-compile", "--disable-pip-version-check", str(wheel)],
         cwd=root)
    work = root / "work"
    work.mkdir()
    return python, work


def _clean_env(tmp: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env["POVH3D_CACHE"] = str(tmp / "cache")
    return env


@pytest.mark.slow
def test_wheel_installs_lean_and_renders_the_sample(installed):
    python, work = installed
    env = _clean_env(work)
    shutil.copy(SAMPLE, work / "scene.pov")
    # Nothing of the repository may be on the path: the installed copy answers.
    where = _run([str(python), "-c", "import povh3d, sys; print(povh3d.__file__)"], cwd=work, env=env)
    assert str(REPO) not in where.stdout and "site-packages" in where.stdout, where.stdout
    probe = ("import importlib.util, json; "
             f"print(json.dumps([m for m in {OPTIONAL!r} if importlib.util.find_spec(m)]))")
    assert json.loads(_run([str(python), "-c", probe], cwd=work, env=env).stdout) == []  # core only
    _run([str(python), "-c", "import povh3d.cli.main, povh3d.api"], cwd=work, env=env)
    _run([str(python), "-m", "povh3d", "--version"], cwd=work, env=env)
    povh3d = python.parent / "povh3d"
    _run([str(povh3d), "render", "scene.pov", "--preset", "demo", "--quality", "draft", "-q", "-o", "out.png"],
         cwd=work, env=env)
    # The command is the launcher (bin/povh3d): a SIGINT while Python starts (sent from `site`,
    # before any code of povh3d's) waits for povh3d's handlers (tests/cli/test_launcher.py).
    assert povh3d.read_text().startswith("#!/bin/sh\n") and os.access(povh3d, os.X_OK)
    (work / "hooks").mkdir()
    (work / "hooks" / "sitecustomize.py").write_text("import os, signal\nos.kill(os.getpid(), signal.SIGINT)\n"
                                                     "for _ in range(100000): pass\n")
    done = subprocess.run([str(povh3d), "--version"], cwd=work, env={**env, "PYTHONPATH": str(work / "hooks")},
                          capture_output=True, text=True, timeout=60, check=False)
    assert (done.returncode, done.stderr) == (130, "povh3d: error: interrupted\n"), done
    image = np.asarray(Image.open(work / "out.png"))
    record = json.loads((work / "out.json").read_text())
    assert record["kind"] == "h3d" and record["display"]["preset"] == "demo"
    assert list(image.shape[1::-1]) == record["lens_array"]["panel"]["size_px"]  # (W, H) in the sidecar
    assert record["image_sha256"] == hashlib.sha256((work / "out.png").read_bytes()).hexdigest()
    assert image.std() > 5  # a scene, not a blank frame
    metadata = _run([str(python), "-c", "from importlib.metadata import metadata; m = metadata('povh3d'); "
                     "print(m['License'], m.get_all('License-File'))"], cwd=work, env=env).stdout
    assert "MIT" in metadata and "LICENSE" in metadata


@pytest.mark.slow
def test_a_command_of_a_missing_group_names_the_extra(installed):
    python, work = installed
    white = work / "white.png"
    Image.fromarray(np.full((64, 64, 3), 255, np.uint8)).save(white)
    done = subprocess.run([str(python), "-m", "povh3d", "calibrate", str(white), "-o", str(work / "grid.json")],
                          cwd=work, env=_clean_env(work), capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 7, done.stderr
    assert done.stderr.strip().count("\n") == 0, done.stderr  # one line, no traceback
    assert "pip install 'povh3d[calibration]'" in done.stderr
