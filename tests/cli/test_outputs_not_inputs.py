"""No command writes over a file it did not make or over its own input (issue 38 item 1): an output that
is the scene, a file the scene reads, the image the command reads or its sidecar, or a ``NAME.json``
that is not a povh3d sidecar (a calibration), is refused in one line before any work, and the file is
left byte for byte.  ``--objects`` and ``--depth-maps`` folders are replaced whole: no old file stays
beside the new index, and a non-empty folder povh3d did not write is refused, never deleted.  Each
refusal has its control: the same command with a distinct output writes."""

from __future__ import annotations

import json

import numpy as np
import pytest

from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.io import read_sidecar
from povh3d.renderer.records import base_record, write_image
from tests.support.cli import one_error_line

# 6 x 4 square lenses of 5 x 5 pixels
LA = LensArray("square", 6, 4, 0.5, 0.5, 1.5, Panel(30, 20, 0.1, 0.1))
GRID_JSON = {"kind": "povh3d-lens-grid", "povh3d_version": "0", "table": [4, 6]}   # a calibration


def _h3d(path, seed=0):
    image = np.random.default_rng(seed).integers(0, 256, (20, 30, 3), dtype=np.uint8)
    write_image(path, image, base_record("h3d", LA))
    return path


def _bytes(*paths):
    return [p.read_bytes() for p in paths]


@pytest.mark.parametrize("command", [
    ["resample", "{h}", "--ppl-out", "3", "-o", "{h}"],
    ["refocus", "{h}", "--depth", "1", "-o", "{h}"],
    ["refocus", "{h}", "--sweep", "3", "--near", "-1", "--far", "1", "-o", "{h}"],
    ["preview", "{h}", "-o", "{d}/h.gif"],                       # its contact sheet h.png is the input
    ["map", "{h}", "--mapping", "alioscopy", "-o", "{h}"],
    ["undistort", "{h}", "--grid", "{d}/grid.json", "-o", "{h}"],
    ["undistort", "{h}", "--grid", "{d}/grid.json", "-o", "{d}/grid.png"],   # the grid as the sidecar
    ["calibrate", "{h}", "-o", "{d}/h.json"],                   # the input's sidecar
    ["extract", "{h}", "-o", "{d}"],                             # a views folder holding the input
    ["annotate", "{h}", "--objects", "{d}/masks", "--links", "{d}/l.xml", "-o", "{d}/l.xml"],
])
def test_an_output_that_is_the_input_is_refused_and_the_input_kept(tmp_path, cli, command):
    h = _h3d(tmp_path / "h.png")
    (tmp_path / "grid.json").write_text(json.dumps(GRID_JSON))
    (tmp_path / "l.xml").write_text("<links/>")
    kept = [h, h.with_suffix(".json"), tmp_path / "grid.json", tmp_path / "l.xml"]
    before = _bytes(*kept)
    result = cli(*[a.format(h=h, d=tmp_path) for a in command])
    line = one_error_line(result)
    assert "which this command reads" in line or "not a povh3d sidecar" in line, line
    assert _bytes(*kept) == before
    assert not list(tmp_path.glob("h_0*.png")) and not (tmp_path / "h.gif").exists()


@pytest.mark.parametrize("command", [
    ["resample", "{h}", "--ppl-out", "3", "-o", "{d}/out.png"],
    ["refocus", "{h}", "--depth", "1", "-o", "{d}/out.png"],
    ["preview", "{h}", "-o", "{d}/out.gif"],
    ["extract", "{h}", "-o", "{d}/views"],
])
def test_control_a_distinct_output_is_written_and_written_again(tmp_path, cli, command):
    h = _h3d(tmp_path / "h.png")
    before = _bytes(h, h.with_suffix(".json"))
    for _ in range(2):   # the second time over its own output and sidecar
        result = cli(*[a.format(h=h, d=tmp_path) for a in command])
        assert result.code == 0, result.err
    assert _bytes(h, h.with_suffix(".json")) == before
    if command[0] != "extract":
        assert read_sidecar(tmp_path / "out.png")["povh3d_version"]


def test_a_calibration_beside_the_output_is_refused_and_a_sidecar_replaced(tmp_path, cli):
    h = _h3d(tmp_path / "h.png")
    (tmp_path / "grid.json").write_text(json.dumps(GRID_JSON))
    line = one_error_line(cli("resample", h, "--ppl-out", "3", "-o", tmp_path / "grid.png"))
    assert "grid.json" in line and "not a povh3d sidecar" in line
    assert json.loads((tmp_path / "grid.json").read_text()) == GRID_JSON
    assert not (tmp_path / "grid.png").exists()
    # control: another image's sidecar (povh3d's, with its image_sha256) is replaced
    _h3d(tmp_path / "old.png", seed=1)
    assert cli("resample", h, "--ppl-out", "3", "-o", tmp_path / "old.png").code == 0
    assert read_sidecar(tmp_path / "old.png")["method"] == "resample-micro"


def test_interleave_over_one_of_its_views_is_refused(tmp_path, cli):
    h = _h3d(tmp_path / "h.png")
    assert cli("extract", h, "-o", tmp_path / "views").code == 0
    view = tmp_path / "views" / "v_000_000.png"
    before = view.read_bytes()
    assert "reads" in one_error_line(cli("interleave", tmp_path / "views", "-o", view))
    assert view.read_bytes() == before
    assert cli("interleave", tmp_path / "views", "-o", tmp_path / "back.png").code == 0   # control


def test_quilt_import_over_its_quilt_is_refused(tmp_path, cli):
    quilt = tmp_path / "x_qs4x2a1.png"
    write_image(quilt, np.zeros((10, 40, 3), np.uint8), base_record("quilt"))
    before = quilt.read_bytes()
    assert "reads" in one_error_line(cli("quilt", quilt, "--import", "-o", quilt))
    assert quilt.read_bytes() == before
    assert cli("quilt", quilt, "--import", "-o", tmp_path / "h.png").code == 0            # control


# -- render: the scene and every file it reads -------------------------------------------------------
TINY = ["--preset", "demo", "--lenses", "6x4", "--ppl", "3", "--quality", "draft", "-q"]
SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
light_source { <0, 0, -100> rgb 1 }
#fopen F "notes.json" read #fclose F
plane { z, 3 pigment { image_map { png "tex.png" } } finish { ambient 1 } }
"""


def _scene(folder):
    (folder / "s.pov").write_text(SCENE)
    write_image(folder / "tex.png", np.full((4, 4, 3), 200, np.uint8), base_record("texture"))
    (folder / "notes.json").write_text("{}")
    return folder / "s.pov"


@pytest.mark.povray
@pytest.mark.parametrize("output", ["s.png", "tex.png", "notes.png", "mine.png"])
def test_render_over_the_scene_or_what_it_reads_is_refused(tmp_path, cli, output):
    """s.png: the scene saved under a .png name; tex.png its image_map; notes.png: its sidecar notes.json
    is a file the scene reads; mine.png: beside the user's calibration mine.json."""
    scene = _scene(tmp_path)
    if output == "s.png":
        scene = scene.rename(tmp_path / "s.png")
    (tmp_path / "mine.json").write_text(json.dumps(GRID_JSON))
    files = sorted(p for p in tmp_path.iterdir() if p.is_file())
    before = _bytes(*files)
    line = one_error_line(cli("render", scene, "-o", tmp_path / output, *TINY,
                              env={"POVH3D_CACHE": str(tmp_path / "cache")}))
    assert output in line
    assert sorted(p for p in tmp_path.iterdir() if p.is_file()) == files and _bytes(*files) == before


@pytest.mark.povray
def test_control_render_beside_what_it_reads(tmp_path, cli):
    scene = _scene(tmp_path)
    before = _bytes(scene, tmp_path / "tex.png", tmp_path / "notes.json")
    env = {"POVH3D_CACHE": str(tmp_path / "cache")}
    for _ in range(2):   # the second time from the output cache, over its own sidecar
        assert cli("render", scene, "-o", tmp_path / "out.png", *TINY, env=env).code == 0
    assert _bytes(scene, tmp_path / "tex.png", tmp_path / "notes.json") == before


@pytest.mark.povray
@pytest.mark.parametrize("flag", ["--depth-maps", "--objects", "--dataset"])
def test_an_output_folder_holding_what_the_scene_reads_is_refused(tmp_path, cli, flag):
    """The folder holds the scene's texture; made by povh3d (its manifest there), it would be replaced whole."""
    scene = _scene(tmp_path)
    (tmp_path / "depth_maps.json").write_text(json.dumps({"kind": "depth_maps"}))
    (tmp_path / "objects.json").write_text(json.dumps({"kind": "objects"}))
    line = one_error_line(cli("render", scene, "-o", tmp_path / "out.png", flag, tmp_path, *TINY[:4], "--ppl", "3",
                              *TINY[6:]))
    assert "which this command reads" in line and not (tmp_path / "out.png").exists()


@pytest.mark.povray
@pytest.mark.parametrize("flag, manifest", [("--depth-maps", "depth_maps.json"), ("--objects", "objects.json")])
def test_a_folder_written_again_holds_the_new_render_only(tmp_path, cli, flag, manifest):
    scene = _scene(tmp_path)
    folder = tmp_path / "out"
    assert cli("render", scene, "-o", tmp_path / "a.png", flag, folder, *TINY).code == 0
    first = {p.relative_to(folder) for p in folder.rglob("*.*")}
    assert any("002" in str(p) for p in first)                       # 3 x 3 views: v_002_002 ...
    result = cli("render", scene, "-o", tmp_path / "a.png", flag, folder, *TINY[:4], "--ppl", "2", *TINY[6:])
    assert result.code == 0, result.err
    second = {p.relative_to(folder) for p in folder.rglob("*.*")}
    assert second < first and not any("002" in str(p) for p in second)   # no old view beside the new index
    record = json.loads((folder / manifest).read_text())
    assert record["povh3d_version"] and record["views"] in ([2, 2], [2, 2])
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.")]   # no staging folder left


@pytest.mark.povray
@pytest.mark.parametrize("flag", ["--depth-maps", "--objects"])
def test_a_folder_povh3d_did_not_write_is_refused_not_deleted(tmp_path, cli, flag):
    scene = _scene(tmp_path)
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "thesis.tex").write_text("years of work")
    line = one_error_line(cli("render", scene, "-o", tmp_path / "a.png", flag, folder, *TINY))
    assert "no povh3d" in line
    assert (folder / "thesis.tex").read_text() == "years of work" and not (tmp_path / "a.png").exists()
    (folder / "thesis.tex").unlink()                                   # control: empty, it is written
    assert cli("render", scene, "-o", tmp_path / "a.png", flag, folder, *TINY).code == 0


@pytest.mark.povray
def test_an_animation_frame_over_what_the_scene_reads_or_a_users_json_is_refused(tmp_path, cli):
    """Frames are OUT_NNNN.png: the scene's texture under a frame's name, or a frame's NAME.json the user's."""
    scene = _scene(tmp_path)
    write_image(tmp_path / "anim_0002.png", np.full((4, 4, 3), 9, np.uint8), base_record("texture"))
    scene.write_text(SCENE.replace('"tex.png"', '"anim_0002.png"'))
    before = (tmp_path / "anim_0002.png").read_bytes()
    line = one_error_line(cli("render", scene, "--frames", "1:2", "-o", tmp_path / "anim.png", *TINY))
    assert "anim_0002.png" in line and (tmp_path / "anim_0002.png").read_bytes() == before
    scene.write_text(SCENE)
    (tmp_path / "anim_0001.json").write_text(json.dumps(GRID_JSON))
    line = one_error_line(cli("render", scene, "--frames", "1:2", "-o", tmp_path / "anim.png", *TINY))
    assert "anim_0001.json" in line and "not a povh3d sidecar" in line
    assert not (tmp_path / "anim_0001.png").exists()
    (tmp_path / "anim_0001.json").unlink()                              # control: the frames are written
    assert cli("render", scene, "--frames", "1:2", "-o", tmp_path / "anim.png", *TINY).code == 0
    assert read_sidecar(tmp_path / "anim_0001.png")["animation"]
