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
#: Never imported by a render of a scene file, on any path (issue 37): a JIT compiler (numba and its
#: llvmlite: 0.3-6 s to import and load) or what only other commands use.
NOT_BY_RENDER = {"numba", "llvmlite", "scipy", "matplotlib", "trimesh", "dask", "distributed", "skimage", "pyvista",
                 "vtkmodules", "cv2"}

# Runs the command line in a fresh interpreter, then reports which heavy packages it imported.
_WRAPPER = """
import json, sys
{prelude}
from povh3d.cli.main import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
sys.stderr.write("\\nMODULES " + json.dumps(sorted({{m if {whole} else m.split('.')[0] for m in sys.modules}})))
"""


def imported_by(*args: str, prelude: str = "", whole: bool = False) -> set[str]:
    """The top-level packages the command imported (``whole``: every module, by its full name)."""
    done = subprocess.run([sys.executable, "-c", _WRAPPER.format(prelude=prelude, whole=whole), *args], cwd=REPO,
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
@pytest.mark.parametrize("module", ["scipy.ndimage", "numba"])
def test_the_probe_sees_a_heavy_import(module):
    # negative control: the same probe reports scipy or numba when something does import it
    assert module.split(".")[0] in imported_by("--help", prelude=f"import {module}")


@pytest.mark.povray
def test_render_imports_no_jit_plotting_or_cluster_package(tmp_path):
    # a whole draft render: NumPy, PIL and Jinja, but no numba, SciPy, Matplotlib, trimesh or Dask
    used = imported_by("render", str(SAMPLE), "--lenses", "12x8", "--ppl", "4x4", "--quality", "draft",
                       "-q", "-o", str(tmp_path / "o.png"))
    assert (tmp_path / "o.png").is_file()
    assert used & NOT_BY_RENDER == set()


#: Not imported by a render of the sample (a POV-Ray scene, native frame) either: what only some of its paths
#: use.  Pillow (15-25 ms) and libpng (``imagecodecs``, 3-4 ms): POV-Ray's frames are PPM (``image.ppm``), its
#: PNG only zlib's (``image.png_codec``); ``numpy.ma`` (7-13 ms, through NumPy's ``quantile`` and ``unique``);
#: the object masks' pass.
NOT_BY_SAMPLE_RENDER = {"PIL", "imagecodecs", "numpy.ma", "povh3d.renderer.passes.object_masks"}


@pytest.mark.povray
def test_render_of_the_sample_imports_only_its_own_path(tmp_path):
    args = ("render", str(SAMPLE), "--lenses", "12x8", "--ppl", "4x4", "--quality", "draft", "--no-cache", "-q",
            "-o", str(tmp_path / "o.png"))
    used = imported_by(*args, whole=True)
    assert (tmp_path / "o.png").is_file()
    assert used & NOT_BY_SAMPLE_RENDER == set()
    assert {"jinja2", "numpy", "numpy.linalg", "povh3d.image.ppm"} <= used   # negative control: the probe sees the whole names


CAMERA_SCENE = """#version 3.7;
camera { location <0, 1, -6> look_at <0, 0, 0> }
light_source { <4, 6, -8> rgb 1 }
sphere { <0, 0, 0>, 1 pigment { rgb <1, 0.4, 0.2> } }
plane { y, -1 pigment { checker rgb 1 rgb 0.3 } }
"""


@pytest.mark.povray
# (a plain render of a camera scene runs no depth pass: --depth-report asks for it)
@pytest.mark.parametrize("extra", [["--depth-report"], ["--depth-maps", "maps", "--depth-format", "png"],
                                   ["--dataset", "hci"], ["--preset", "ipad-retina"]],
                         ids=["camera", "depth-maps-png", "dataset", "slanted-mapping"])
def test_render_paths_that_read_16_bit_passes_or_gather_pixels_import_no_jit(tmp_path, extra):
    # A scene camera (its depth pass is a 16-bit PPM), 16-bit depth maps, a panel mapping's gather:
    # the paths that imported numba before (image/png_codec.py, image/kernels.py).
    scene = tmp_path / "cam.pov"
    scene.write_text(CAMERA_SCENE)
    size = [] if extra[:1] == ["--preset"] else ["--lenses", "12x8", "--ppl", "5x5"]  # odd: a dataset's centre
    used = imported_by("render", str(scene), *size, *extra, "--quality", "draft", "-q", "--no-cache",
                       "-o", str(tmp_path / "o.png"), prelude="import os; os.chdir(%r)" % str(tmp_path), whole=True)
    assert (tmp_path / "o.png").is_file()
    assert used & NOT_BY_RENDER == set()
    assert "povh3d.image.ppm" in used    # negative control: the probe sees the render's own modules


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
