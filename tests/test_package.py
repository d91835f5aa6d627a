"""The package as users of Python libraries expect it: ``python -m povh3d``, a LICENSE, the
optional groups of pyproject.toml, and the one line that names a missing group."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib

import numpy as np
import pytest

from povh3d._version import __version__
from povh3d.errors import MissingExtra, param
from povh3d.extras import EXTRAS, require
from tests.conftest import REPO, SAMPLE
from tests.support.cli import one_error_line

PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]


def _names(requirements: list[str]) -> set[str]:
    return {re.split(r"[<>=\[ ;]", r, maxsplit=1)[0].lower() for r in requirements}


@pytest.mark.povray
def test_python_dash_m_povh3d_is_the_command():
    done = subprocess.run([sys.executable, "-m", "povh3d", "--version"], cwd=REPO, capture_output=True, text=True,
                          timeout=60, check=False)
    assert done.returncode == 0 and done.stdout.strip() == f"povh3d {__version__}", done
    done = subprocess.run([sys.executable, "-m", "povh3d", "nope"], cwd=REPO, capture_output=True, text=True,
                          timeout=60, check=False)
    assert done.returncode == 2 and "invalid choice" in done.stderr  # the same parser, errors and all


def test_license_is_mit_as_pyproject_says():
    text = (REPO / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "povh3d contributors" in text
    assert PYPROJECT["license"] == {"text": "MIT"}


def test_extras_table_is_pyprojects():
    groups = PYPROJECT["optional-dependencies"]
    for extra, distributions in EXTRAS.items():
        assert _names(groups[extra]) == set(distributions), extra
    everything = set().union(*EXTRAS.values())
    assert groups["all"] == [f"povh3d[{','.join(EXTRAS)}]"]
    assert "povh3d" in _names(groups["test"]) and "povh3d[all]" in groups["test"]  # the tests use every group
    assert not everything & _names(PYPROJECT["dependencies"])  # an optional package is not also core
    assert {"numpy", "jinja2", "pillow", "trimesh", "pyvista"} <= _names(PYPROJECT["dependencies"])


@pytest.fixture
def without(monkeypatch):
    """``without("scipy")``: that package (and its submodules) cannot be imported, as if it were not
    installed (``None`` in ``sys.modules``); povh3d's modules are imported afresh, as by a new process."""
    def hide(*tops: str) -> None:
        for module in list(sys.modules):
            if module.split(".")[0] in tops or module.startswith(("povh3d.calibration", "povh3d.commands.calibration")):
                monkeypatch.delitem(sys.modules, module)
        for top in tops:
            monkeypatch.setitem(sys.modules, top, None)
        # a package keeps its imported submodules as attributes: 'from ..commands import calibration' reads them
        for package, name in (("povh3d", "calibration"), ("povh3d.commands", "calibration")):
            if package in sys.modules:
                monkeypatch.delattr(sys.modules[package], name, raising=False)
    return hide


def test_require_names_the_extra(without):
    assert require("json", "cluster", "x").__name__ == "json"  # negative control: present, imported
    without("distributed")
    with pytest.raises(MissingExtra, match=r"^scheduler needs distributed, which is not installed: "
                                           r"pip install 'povh3d\[cluster\]'$") as caught:
        require("distributed", "cluster", param("scheduler"))
    assert isinstance(caught.value, ImportError) and caught.value.name == "distributed"
    with pytest.raises(ValueError, match="not one of"):
        require("json", "nope", "x")


def test_a_failure_inside_a_present_package_is_not_renamed(tmp_path, monkeypatch):
    (tmp_path / "povh3d_broken_pkg").mkdir()
    (tmp_path / "povh3d_broken_pkg" / "__init__.py").write_text("import povh3d_not_a_module_anywhere\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ModuleNotFoundError) as caught:  # a broken install, not a missing extra
        require("povh3d_broken_pkg", "mesh", "x")
    assert not isinstance(caught.value, MissingExtra)
    with pytest.raises(MissingExtra):
        require("povh3d_no_such_pkg", "mesh", "x")


@pytest.mark.parametrize("hidden, args, extra", [
    ("scipy", ["calibrate", "{tmp}/white.png", "-o", "{tmp}/grid.json"], "calibration"),
    ("distributed", ["render", str(SAMPLE), "--scheduler", "tcp://127.0.0.1:1", "-o", "{tmp}/o.png"], "cluster"),
    ("nrrd", ["layout", "{tmp}/v.nrrd", "-o", "{tmp}/l.png"], "volume"),
    ("lxml", ["convert-mesh", "{tmp}/m.3mf", "-o", "{tmp}/m.inc"], "mesh"),
    ("imageio_ffmpeg", ["render", str(SAMPLE), "--frames", "0:1", "--video", "{tmp}/v.mp4", "-o", "{tmp}/a.png"],
     "video"),
    ("fast_simplification", None, "mesh"),
    ("skimage", None, "analysis"),
])
def test_a_command_of_a_missing_group_says_which_extra_in_one_line(tmp_path, cli, without, hidden, args, extra):
    from povh3d.image.io import write_png

    write_png(tmp_path / "white.png", np.full((32, 32, 3), 255, np.uint8))
    (tmp_path / "m.3mf").write_bytes(b"PK not read: the group is checked first")
    (tmp_path / "v.nrrd").write_bytes(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n" + bytes(8))
    without(hidden)
    if args is None:  # the library functions behind the commands
        from povh3d.image.metrics import ssim
        from povh3d.mesh.simplify import simplify_part

        call = {"fast_simplification": lambda: simplify_part(_big_part(), 4),
                "skimage": lambda: ssim(np.zeros((8, 8), np.uint8), np.zeros((8, 8), np.uint8))}[hidden]
        with pytest.raises(MissingExtra, match=re.escape(f"pip install 'povh3d[{extra}]'")):
            call()
        return
    line = one_error_line(cli(*[a.format(tmp=tmp_path) for a in args]), 7)
    assert line.endswith(f"pip install 'povh3d[{extra}]'"), line
    assert not list(tmp_path.glob("a*.png"))  # refused before any work


def _big_part():
    from povh3d.mesh.load import Part

    rng = np.random.default_rng(0)
    return Part(name="p", vertices=rng.random((30, 3)), faces=rng.integers(0, 30, (40, 3)))


def test_a_star_import_hides_no_builtin():
    namespace: dict = {}
    exec("from povh3d import *", namespace)
    assert "map" not in namespace and "extract" in namespace


@pytest.mark.povray
def test_import_povh3d_loads_no_command_until_one_is_used():
    probe = ("import sys, povh3d; dir(povh3d); before = 'numpy' in sys.modules or 'povh3d.api' in sys.modules; "
             "povh3d.extract; print(before, 'povh3d.api' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", probe], cwd=REPO, capture_output=True, text=True, timeout=60,
                          check=False)
    assert done.stdout.split() == ["False", "True"], done  # the second: the probe sees a load


def test_all_is_every_command_but_map():
    import povh3d

    assert set(povh3d._COMMANDS) - set(povh3d.__all__) == {"map"}


def _recipe(makefile: str, target: str) -> tuple[set[str], list[str]]:
    """A Makefile target's prerequisites and its recipe lines."""
    lines = makefile.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith(f"{target}:"))
    prerequisites = set(lines[head].split(":", 1)[1].split("##")[0].split())
    recipe = []
    for line in lines[head + 1:]:
        if not line.startswith("\t"):
            break
        recipe.append(line.strip())
    return prerequisites, recipe


def test_make_test_runs_ruff_and_mypy_first():
    makefile = (REPO / "Makefile").read_text(encoding="utf-8")
    needs, _ = _recipe(makefile, "test")
    _, lint = _recipe(makefile, "lint")
    assert "lint" in needs  # CI runs make test (.ci/run): a lint or type error fails it
    assert "$(BIN)/ruff check povh3d tests benchmarks" in lint and "$(BIN)/mypy" in lint
    # the reader itself: a test target without lint is seen as one
    assert "lint" not in _recipe("test: venv\n\tpytest\nlint: venv\n\tmypy\n", "test")[0]


def test_type_checker_settings_keep_default_strictness():
    tool = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["tool"]
    mypy = tool["mypy"]
    assert mypy["packages"] == ["povh3d"] and mypy["python_version"] == "3.11"
    # no blanket silence: missing stubs are ignored module by module, errors never
    assert not mypy.get("ignore_errors") and not mypy.get("ignore_missing_imports")
    for override in mypy.get("overrides", []):
        assert set(override) == {"module", "ignore_missing_imports"}, override
    assert {"ruff", "mypy"} <= _names(PYPROJECT["optional-dependencies"]["test"])
    assert "ruff" in tool and tool["ruff"]["lint"]["select"]
