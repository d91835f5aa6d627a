"""Issue 21's smaller words: each a wrong or missing line before (the orthographic camera's advice, an
unlit but self-lit scene, the summary's time, a missing include in the camera's run, focal blur)."""

from __future__ import annotations

import json
import re
import shlex

import pytest

pytestmark = pytest.mark.povray   # every test renders

TINY = ["--preset", "demo", "--lenses", "6x4", "--ppl", "4", "--quality", "draft", "-q"]
LIGHT = "light_source { <0, 20, -50> rgb 1 }\n"


def _scene(tmp_path, text, name="s.pov"):
    scene = tmp_path / name
    scene.write_text("#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n" + text)
    return scene


def test_the_orthographic_cameras_advice_is_options_that_work(tmp_path, cli):
    scene = _scene(tmp_path, "camera { orthographic location <-50, -40, -30> look_at 0 right 8*x up 6*y }\n"
                   + LIGHT + "sphere { 0, 1 pigment { rgb 1 } }\n")
    refused = cli("render", scene, "-o", tmp_path / "a.png", *TINY)
    assert refused.code != 0 and refused.err.strip().count("\n") == 0
    advice = re.findall(r"--display-\S+(?: [^-\s]\S*)?", refused.err)
    assert len(advice) == 4, refused.err
    options = [word for part in advice for word in shlex.split(part)]
    followed = cli("render", scene, "-o", tmp_path / "b.png", *TINY, *options)
    assert followed.code == 0, followed.err
    assert "placement explicit (centre 0,0,0, 3.333 units/mm)" in followed.out   # 8 units over the 2.4 mm panel


def test_a_self_lit_scene_without_light_source_has_no_black_warning(tmp_path, cli):
    lit = _scene(tmp_path, "sphere { <0, 0, 3>, 30 pigment { rgb 1 } finish { ambient 1 diffuse 0 } }\n")
    result = cli("render", lit, "-o", tmp_path / "a.png", *TINY)
    assert result.code == 0 and "light_source" not in result.err, result.err
    dark = _scene(tmp_path, "sphere { <0, 0, 3>, 30 pigment { rgb 1 } }\n", "d.pov")   # negative control
    assert "has no light_source" in cli("render", dark, "-o", tmp_path / "d.png", *TINY).err


def test_the_summary_time_is_the_whole_time(tmp_path, cli):
    scene = _scene(tmp_path, "camera { location <0, 0, -20> look_at 0 angle 30 }\n" + LIGHT
                   + "sphere { 0, 1 pigment { rgb 1 } }\n")
    out = tmp_path / "a.png"
    result = cli("render", scene, "-o", out, *TINY)
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    said = float(re.search(r"  ([0-9.]+) s \(", result.out)[1])
    t = record["timings"]
    assert said == round(t["total_seconds"], 2)
    assert t["total_seconds"] >= t["render_seconds"] + record["placement"]["evaluation_seconds"]


def test_a_missing_include_in_the_cameras_run_names_the_users_file(tmp_path, cli):
    scene = _scene(tmp_path, "camera { location <0, 0, -20> look_at 0 }\n#include \"nothere.inc\"\n",
                   "mine.pov")
    result = cli("render", scene, "-o", tmp_path / "a.png", *TINY)
    assert result.code != 0 and "mine.pov line 4" in result.err and "scene.pov" not in result.err, result.err


def test_focal_blur_is_named_in_one_warning(tmp_path, cli):
    scene = _scene(tmp_path, "camera { location <0, 0, -20> look_at 0 aperture 0.4 blur_samples 20 "
                   "focal_point 0 }\n" + LIGHT + "sphere { 0, 1 pigment { rgb 1 } }\n")
    out = tmp_path / "a.png"
    result = cli("render", scene, "-o", out, *TINY)
    assert result.code == 0
    lines = [line for line in result.err.splitlines() if "not reproduced" in line]
    assert len(lines) == 1 and "aperture" in lines[0] and "focal_point" in lines[0]
    record = json.loads(out.with_suffix(".json").read_text())["placement"]
    assert record["camera"]["dropped"] == ["aperture", "blur_samples", "focal_point"]
