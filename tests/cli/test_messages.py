"""The messages issue 14 found misleading, one test each: what the line says now, and the
inputs that used to end in a traceback."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest

from povh3d.renderer.records import base_record, write_image
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.io import write_png
from tests.conftest import SAMPLE
from tests.support.cli import one_error_line

TINY = ["--preset", "demo", "--lenses", "6x4", "--ppl", "4", "--quality", "draft", "-q"]


@pytest.mark.parametrize("args, expected", [
    (["--ppl", "0"], "--ppl takes positive numbers"),
    (["--pixel-pitch", "0"], "pixel pitch (--pixel-pitch) must be positive"),
    (["--pixel-pitch", "nan"], "--pixel-pitch: takes a finite number"),
    (["--pixel-pitch", "inf"], "--pixel-pitch: takes a finite number"),
    (["--pixel-pitch", "1e300"], "between 1e-09 and 1e+09 mm"),
    (["--focal", "1e308"], "focal length must be between"),
    (["--lenses", "0x0"], "--lenses takes positive numbers"),
    (["--lenses", "100000x100000"], "use fewer lenses (--lenses)"),
])
def test_bad_numbers_are_one_line(tmp_path, cli, args, expected):
    start = time.perf_counter()
    line = one_error_line(cli("render", SAMPLE, "-o", tmp_path / "a.png", "--quality", "draft", *args), 2)
    assert expected in line and "--panel " not in line
    assert time.perf_counter() - start < 2  # refused before any allocation or render
    assert not list(tmp_path.iterdir())


def test_a_display_beyond_povray_reach_does_not_suggest_an_empty_range(tmp_path, cli):
    line = one_error_line(cli("render", SAMPLE, "-o", tmp_path / "a.png", "--quality", "draft", "--pixel-pitch", "100",
                              "--focal", "1e-9"), 2)
    assert "whatever the front clearance" in line and "between 0.01 and 0.0" not in line


@pytest.mark.povray
def test_a_refused_clearance_advises_a_command_that_runs(tmp_path, cli):
    """Issue 22: ``--focal 1e6`` put multi-ortho's view bank (whole steps of f x views) out of
    POV-Ray's reach, and the front clearance it advised was refused in turn.  Run the advice."""
    base = ["render", SAMPLE, *TINY, "--ppl", "6", "--focal", "1e6"]
    line = one_error_line(cli(*base, "-o", tmp_path / "a.png"), 2)
    method = re.search(r"--method (\S+)", line).group(1)
    clearance = re.search(r"--front-clearance ([0-9.e+-]+)", line).group(1)
    assert cli(*base, "--method", method, "--front-clearance", clearance, "-o", tmp_path / "b.png").code == 0
    assert (tmp_path / "b.png").exists()


def test_info_with_a_nan_pitch(cli):
    assert "finite" in one_error_line(cli("info", "--pixel-pitch", "nan"), 2)


@pytest.mark.parametrize("command, option", [("refocus", ["--focal", "0"]), ("refocus", ["--pixel-pitch", "-1"]),
                                             ("preview", ["--focal", "0"]), ("refocus", [])])
def test_a_zero_focal_or_pitch_for_a_display_command_is_one_line(tmp_path, cli, command, option):
    # Issue 25's fuzz: refocus --focal 0 divided by zero, an internal error (exit 70).  [] is the control.
    array = LensArray("square", 4, 3, 0.8, 0.8, 1.5, Panel(32, 24, 0.1, 0.1))
    write_image(tmp_path / "h.png", np.random.default_rng(1).integers(0, 256, (24, 32, 3), np.uint8),
                base_record("h3d", array))
    out = tmp_path / ("o.gif" if command == "preview" else "o.png")
    extra = ["--depth", "0"] if command == "refocus" else ["--frames", "2"]
    result = cli(command, tmp_path / "h.png", "-o", out, *extra, *option)
    if not option:
        assert result.code == 0 and out.exists(), result.err
        return
    assert "must be a positive finite number" in one_error_line(result, 2) and not out.exists()


def test_output_naming_a_folder(tmp_path, cli):
    (tmp_path / "out.png").mkdir()
    line = one_error_line(cli("render", SAMPLE, "-o", tmp_path / "out.png", *TINY), 4)
    assert "is a folder" in line


@pytest.mark.parametrize("command, extra", [
    ("extract", ["--ppl", "4"]), ("map", ["--mapping", "alioscopy"]), ("resample", ["--ppl", "4", "--ppl-out", "2"]),
    ("refocus", ["--ppl", "4", "--focal", "1", "--pixel-pitch", "0.1", "--depth", "1"]),
    ("preview", ["--ppl", "4", "--focal", "1", "--pixel-pitch", "0.1"]),
    ("undistort", ["--grid", "g.json"]), ("calibrate", []),
])
def test_empty_png_is_one_line(tmp_path, cli, command, extra):
    (tmp_path / "e.png").write_bytes(b"")
    out = {"calibrate": "g2.json", "preview": "p.gif", "extract": "views"}.get(command, "o.png")
    (tmp_path / "g.json").write_text("{}")
    line = one_error_line(cli(command, tmp_path / "e.png", "-o", tmp_path / out, *extra))
    assert "e.png" in line or "g.json" in line


def test_map_names_the_panel_size_option(tmp_path, cli):
    write_image(tmp_path / "odd.png", np.zeros((7, 13, 3), np.uint8), base_record("h3d"))
    line = one_error_line(cli("map", tmp_path / "odd.png", "--mapping", "alioscopy", "-o", tmp_path / "m.png"), 2)
    assert "--panel-size WxH" in line


def test_map_refuses_a_square_h3d_image(tmp_path, cli):
    array = LensArray("square", 40, 30, 0.8, 0.8, 1.5, Panel(320, 240, 0.1, 0.1))
    write_image(tmp_path / "sq.png", np.zeros((240, 320, 3), np.uint8), base_record("h3d", array))
    line = one_error_line(cli("map", tmp_path / "sq.png", "--mapping", "alioscopy", "-o", tmp_path / "m.png"), 2)
    assert "square H3D image (8x8 views)" in line and not (tmp_path / "m.png").exists()


def test_ppl_contradicting_the_sidecar(tmp_path, cli):
    array = LensArray("square", 40, 30, 0.8, 0.8, 1.5, Panel(320, 240, 0.1, 0.1))
    write_image(tmp_path / "sq.png", np.zeros((240, 320, 3), np.uint8), base_record("h3d", array))
    line = one_error_line(cli("resample", tmp_path / "sq.png", "--ppl", "8x1", "--ppl-out", "4",
                              "-o", tmp_path / "r.png"), 2)
    assert "contradicts the sidecar" in line
    # --ppl 8 means 8x8 here as in render; resample keeps the lens array for extract
    assert cli("resample", tmp_path / "sq.png", "--ppl", "8", "--ppl-out", "4", "-o", tmp_path / "r.png").code == 0
    result = cli("extract", tmp_path / "r.png", "-o", tmp_path / "v")
    assert result.code == 0, result.err
    assert len(list((tmp_path / "v").glob("v_*.png"))) == 16


def test_image_changed_after_its_sidecar(tmp_path, cli):
    array = LensArray("square", 40, 30, 0.8, 0.8, 1.5, Panel(320, 240, 0.1, 0.1))
    write_image(tmp_path / "sq.png", np.zeros((240, 320, 3), np.uint8), base_record("h3d", array))
    from PIL import Image
    Image.fromarray(np.zeros((100, 100, 3), np.uint8)).save(tmp_path / "sq.png")
    line = one_error_line(cli("refocus", tmp_path / "sq.png", "--depth", "1", "-o", tmp_path / "r.png"), 3)
    assert "describes another image" in line or "but its sidecar describes" in line


@pytest.mark.povray
def test_missing_include_is_not_blamed_on_the_sandbox(tmp_path, cli):
    scene = tmp_path / "s.pov"
    scene.write_text('#version 3.7;\nlight_source { <0, 0, -50> rgb 1 }\n#include "nothere.inc"\n')
    line = one_error_line(cli("render", scene, "-o", tmp_path / "a.png", *TINY), 6)
    assert "nothere.inc is neither beside the scene nor in an --include folder" in line
    assert "lets a scene read only" not in line


@pytest.mark.povray
def test_animation_error_names_the_animation_frame(tmp_path, cli):
    scene = tmp_path / "a.pov"
    scene.write_text('#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n#if (clock > 0.6) #error "late" #end\n'
                     "sphere { <0, 0, 3>, 5 pigment { checker rgb 1 rgb 0 scale 0.1 } finish { emission 1 } }\n")
    line = one_error_line(cli("render", scene, "-o", tmp_path / "a.png", *TINY, "--frames", "0:4"), 6)
    assert "animation frame 3 (clock 0.75)" in line
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "no staging folder left"


@pytest.mark.povray
def test_an_unclosed_brace_at_the_end_of_the_scene_names_the_scene(tmp_path, cli):
    """POV-Ray notices it only in povh3d's own script (its ``scene.pov``), which the user never sees."""
    scene = tmp_path / "mine.pov"
    scene.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\nsphere { 0, 1 pigment { rgb 1 }\n")
    line = one_error_line(cli("render", scene, "-o", tmp_path / "a.png", *TINY), 6)
    assert "past the end of mine.pov" in line and "No matching } in 'sphere'" in line and "scene.pov" not in line


@pytest.mark.povray
@pytest.mark.parametrize("text, expected", [
    ("sphere { <0, 0, 3>, 0.5 pigment { rgb 1 } }\n", "has no light_source"),
    ("light_source { <0, 0, -50> rgb 1 }\nsphere { <5000, 0, 3>, 1 pigment { rgb 1 } }\n", "as if no ray hit anything"),
])
def test_empty_render_and_no_light_warn(tmp_path, cli, text, expected):
    scene = tmp_path / "s.pov"
    scene.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n" + text)
    result = cli("render", scene, "-o", tmp_path / "a.png", *TINY)
    assert result.code == 0
    lines = [line for line in result.err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("povh3d: warning: ") and expected in lines[0]


@pytest.mark.povray
@pytest.mark.parametrize("quiet", [[], ["-q"]], ids=["", "-q"])
def test_mesh_warnings_are_one_line_each_and_kept_in_the_record(tmp_path, cli, quiet):
    """A model whose texture is missing: one warning line from convert-mesh, one from render
    MODEL (kept in the sidecar), said again when the conversion comes from the cache; -q only
    hides the progress line."""
    import json
    import shutil

    from tests.conftest import SAMPLES

    for name in ("letter_f.obj", "letter_f.mtl"):  # its texture letter_f.png left behind
        shutil.copy(SAMPLES / name, tmp_path / name)
    model = tmp_path / "letter_f.obj"
    missing = "texture 'letter_f.png' named by the model is missing"
    result = cli("convert-mesh", model, *quiet)
    lines = [line for line in result.err.splitlines() if line.strip()]
    assert result.code == 0 and "letter_f.inc" in result.out
    assert len(lines) == 1 and lines[0].startswith("povh3d: warning: ") and missing in lines[0], result.err
    for run in ("converted", "from the cache"):
        result = cli("render", model, "-o", tmp_path / "m.png", *TINY[:-1], *quiet)
        lines = [line for line in result.err.splitlines() if line.strip()]
        assert result.code == 0 and all(line.startswith("povh3d: warning: ") for line in lines), result.err
        assert sum(missing in line for line in lines) == 1, (run, result.err)
        model_record = json.loads((tmp_path / "m.json").read_text())["model"]
        assert any(missing in w for w in model_record["warnings"])
        assert model_record["conversion_from_cache"] == (run == "from the cache")


@pytest.mark.povray
def test_a_lit_scene_has_no_warning(tmp_path, cli):  # negative control of the two above
    result = cli("render", SAMPLE, "-o", tmp_path / "a.png", *TINY)
    assert result.code == 0 and "warning" not in result.err


@pytest.mark.povray
def test_a_panel_larger_than_memory_is_refused_before_rendering(tmp_path, cli, monkeypatch):
    import povh3d.system as budget_module

    monkeypatch.setattr(budget_module, "available_memory", lambda: 2**20)  # 1 MiB free
    line = one_error_line(cli("render", SAMPLE, "-o", tmp_path / "a.png", "--quality", "draft"), 2)
    assert "320x240 pixel render needs about" in line and "available" in line
    monkeypatch.setattr(budget_module, "available_memory", lambda: 2**34)  # negative control: 16 GiB
    assert cli("render", SAMPLE, "-o", tmp_path / "a.png", *TINY).code == 0


@pytest.mark.parametrize("command, extra, out", [
    ("extract", ["--ppl", "4"], "views"),
    ("resample", ["--ppl", "4", "--ppl-out", "2"], "r.png"),
    ("refocus", ["--ppl", "4", "--focal", "1", "--pixel-pitch", "0.1", "--depth", "1"], "f.png"),
    ("preview", ["--ppl", "4", "--focal", "1", "--pixel-pitch", "0.1"], "p.gif"),
    ("quilt", ["--ppl", "4", "--quilt", "2x2"], "q"),
])
def test_an_image_of_no_whole_lenses_is_one_line_and_nothing_written(tmp_path, cli, command, extra, out):
    """Issue 23's bad input: 13 x 7 pixels hold no whole 4 px lenses (nor views)."""
    write_png(tmp_path / "odd.png", np.zeros((7, 13, 3), np.uint8))
    line = one_error_line(cli(command, tmp_path / "odd.png", "-o", tmp_path / out, *extra))
    assert "13x7" in line and "whole lenses" in line and "--ppl" in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["odd.png"]
    assert line.count("check --ppl") == 1, line
