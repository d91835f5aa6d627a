"""Start-up cost: a command imports only what it uses (issue 17), and the commands whose
dependencies are imported late still fail with one line."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.conftest import REPO, SAMPLE
from tests.support.cli import one_error_line

HEAVY = ("scipy", "numba", "matplotlib", "trimesh", "dask", "skimage", "pyvista", "vtkmodules")

# Runs the command line in a fresh interpreter, then reports which heavy packages it imported.
_WRAPPER = """
import json, sys
{prelude}
from povh3d.cli.main import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
sys.stderr.write("\\nMODULES " + json.dumps(sorted({{m.split('.')[0] for m in sys.modules}})))
"""


def imported_by(*args: str, prelude: str = "") -> set[str]:
    done = subprocess.run([sys.executable, "-c", _WRAPPER.format(prelude=prelude), *args], cwd=REPO,
                          capture_output=True, text=True, timeout=120, check=False)
    line = done.stderr.rsplit("MODULES ", 1)
    assert len(line) == 2, done.stderr
    return set(json.loads(line[1]))


@pytest.mark.povray
@pytest.mark.parametrize("args", [["--help"], ["render", "--help"], ["--version"], ["presets"],
                                  ["convert-mesh", "--help"], ["calibrate", "--help"], ["map", "--help"],
                                  ["layout", "--help"]])
def test_help_and_listing_import_no_heavy_package(args):
    assert imported_by(*args) & set(HEAVY) == set()


@pytest.mark.povray
def test_help_and_presets_do_not_even_import_numpy():
    assert "numpy" not in imported_by("--help")
    assert "numpy" not in imported_by("presets")


@pytest.mark.povray
def test_the_probe_sees_a_heavy_import():
    # negative control: the same probe reports scipy when something does import it
    assert "scipy" in imported_by("--help", prelude="import scipy.ndimage")


@pytest.mark.povray
def test_render_imports_no_plotting_or_cluster_package(tmp_path):
    # a whole draft render: NumPy, PIL and Jinja, but no SciPy, Matplotlib, trimesh or Dask
    used = imported_by("render", str(SAMPLE), "--lenses", "12x8", "--ppl", "4x4", "--quality", "draft",
                       "-q", "-o", str(tmp_path / "o.png"))
    assert (tmp_path / "o.png").is_file()
    assert used & {"scipy", "matplotlib", "trimesh", "dask", "skimage"} == set()


@pytest.mark.parametrize("args, fragment", [
    (["calibrate", "missing-white.png", "-o", "grid.json"], "missing-white.png"),
    (["undistort", "missing.png", "--grid", "missing-grid.json", "-o", "out.png"], "missing"),
    (["borders", "missing.png", "--grid", "g.json", "-o", "o.png", "--fill", "nearest"], "missing"),
    (["viewpoints", "missing.png", "--grid", "g.json", "-o", "views", "--ppl", "4"], "missing"),
    (["stitch", "a.png", "b.png", "--grid", "g.json", "-o", "o.png"], ".png"),
    (["convert-mesh", "missing-model.stl"], "missing-model.stl"),
    (["convert-mesh", "model.xyz"], ".xyz"),
])
def test_lazily_imported_commands_fail_with_one_line(args, fragment, tmp_path, cli):
    assert fragment in one_error_line(cli(*args, cwd=tmp_path))
