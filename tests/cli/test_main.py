"""The command line: each form of the issue works as written; bad input gives one
line, a non-zero exit and nothing half-written."""

import json

import numpy as np
import pytest

from povh3d.cli.main import main
from povh3d.image.io import read_png
from tests.conftest import SAMPLE
from tests.support.cli import one_error_line, run_subprocess

SMALL = ["--lenses", "12x8", "--ppl", "4x4", "--quality", "draft", "-q"]


@pytest.mark.povray
def test_version_presets_info(cli):
    assert run_subprocess("--version").out.startswith("povh3d ")  # the module entry point, in its own process
    assert cli("--version").out.startswith("povh3d ")
    out = cli("presets").out
    for name in ("demo", "alioscopy-42", "philips-20", "ipad-retina", "hex-5.6", "parallax-barrier-22"):
        assert name in out
    info = json.loads(cli("info", "--preset", "philips-20", "--json").out)
    assert info["lenses"][0] == 1066 and info["mapping"] == "philips"
    assert info["viewing_angle_deg"] == pytest.approx(2 * np.degrees(np.arctan(0.3825 / 2)))
    info = json.loads(cli("info", "--grid", "lenticular", "--lenses", "240", "--ppl", "8", "--rows", "1080",
                          "--json").out)
    assert info["panel"]["size_px"] == [1920, 1080] and info["views"] == [8, 1]


@pytest.mark.povray
def test_render_writes_h3d_sidecar_and_views_then_hits_cache(tmp_path, cli):
    out = tmp_path / "h3d.png"
    views = tmp_path / "views"
    result = cli("render", SAMPLE, "-o", out, "--views-dir", views, *SMALL)
    assert result.code == 0, result.err
    h3d = read_png(out)
    assert h3d.shape == (32, 48, 3)
    record = json.loads(out.with_suffix(".json").read_text())
    for key in ("lens_array", "method", "quality", "povh3d_version", "povray_version", "timings", "output_gamma"):
        assert key in record
    assert record["timings"]["shots_from_cache"] == 0
    assert (views / "v_003_002.png").is_file() and len(list(views.glob("v_*.png"))) == 16
    # interleave the written views back: the same H3D image
    result = cli("interleave", views, "-o", tmp_path / "again.png")
    assert result.code == 0, result.err
    assert np.array_equal(read_png(tmp_path / "again.png"), h3d)
    # extract is the inverse
    result = cli("extract", out, "--ppl", "4x4", "-o", tmp_path / "ex")
    assert result.code == 0, result.err
    assert np.array_equal(read_png(tmp_path / "ex" / "v_001_003.png"), read_png(views / "v_001_003.png"))
    # nothing changed: everything from the cache
    result = cli("render", SAMPLE, "-o", out, *SMALL)
    assert json.loads(out.with_suffix(".json").read_text())["timings"]["shots_from_cache"] == 1
    result = cli("render", SAMPLE, "-o", out, "--no-cache", *SMALL)
    assert json.loads(out.with_suffix(".json").read_text())["timings"]["shots_from_cache"] == 0


@pytest.mark.povray
def test_scene_may_include_files_beside_it(tmp_path, cli):
    (tmp_path / "part.inc").write_text("sphere { <0, 0, 3>, 1 pigment { rgb <1, 0, 0> } finish { emission 1 } }\n")
    scene = tmp_path / "s.pov"
    scene.write_text('#include "part.inc"\n')
    out = tmp_path / "o.png"
    result = cli("render", scene, "-o", out, *SMALL)
    assert result.code == 0, result.err
    assert read_png(out)[..., 0].max() > 200
    # editing the include invalidates the cache
    (tmp_path / "part.inc").write_text("sphere { <0, 0, 3>, 1 pigment { rgb <0, 1, 0> } finish { emission 1 } }\n")
    cli("render", scene, "-o", out, *SMALL)
    assert read_png(out)[..., 0].max() < 50


@pytest.mark.parametrize("args, fragment", [
    (["render", "missing.pov"], "does not exist"),
    (["render", SAMPLE, "--preset", "nope"], "choose one of: demo"),
    (["render", SAMPLE, "--lenses", "12y8"], "--lenses takes"),
    (["render", SAMPLE, "--ppl", "abc"], "--ppl takes"),
    (["render", SAMPLE, "--lenses", "400x300", "--panel", "320x240"], "larger than the panel"),
    (["render", SAMPLE, "-o", "/nonexistent-dir/x.png", *SMALL], "does not exist"),
    (["render", SAMPLE, "--method", "nope"], "invalid choice"),
    (["info", "--focal", "-1"], "focal length"),
    (["render", SAMPLE, "--quality", "auto", "-q"], "--quality auto needs --max-error"),
    pytest.param(["render", SAMPLE, "--lenses", "12x8", "--ppl", "4x4", "--quality", "auto", "--max-error", "99",
                  "-q", "-o", "/tmp/povh3d-never.png"], "use --max-error", marks=pytest.mark.povray),
])
def test_bad_input_is_one_line(args, fragment, cli):
    assert fragment in one_error_line(cli(*args))


@pytest.mark.povray
def test_parse_error_shows_file_and_line(tmp_path, cli):
    scene = tmp_path / "broken.pov"
    scene.write_text("sphere { <0,0,3>, 1 pigment { rgb 1 } }\nbox { <0,0,0> <1,1,1> nonsense_keyword }\n")
    out = tmp_path / "o.png"
    line = one_error_line(cli("render", scene, "-o", out, *SMALL))
    assert "broken.pov" in line and "line 2" in line
    assert not out.exists() and list(tmp_path.iterdir()) == [scene]


@pytest.mark.povray
def test_missing_include_named(tmp_path, cli):
    scene = tmp_path / "s.pov"
    scene.write_text('#include "nowhere.inc"\n')
    line = one_error_line(cli("render", scene, "-o", tmp_path / "o.png", *SMALL))
    assert "nowhere.inc" in line


def test_povray_not_installed_says_how(tmp_path, cli):
    line = one_error_line(cli("render", SAMPLE, "-o", tmp_path / "o.png", *SMALL,
                              env={"POVH3D_POVRAY": str(tmp_path / "no-povray")}))
    assert "apt-get install" in line


def test_main_returns_zero_in_process(tmp_path, capsys):
    # main itself, not the cli fixture: success is a returned 0, not a SystemExit.
    assert main(["info", "--preset", "demo", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["views"] == [8, 8]


@pytest.mark.povray
def test_quality_auto_records_its_choice(tmp_path, cli):
    out = tmp_path / "auto.png"
    result = cli("render", SAMPLE, "-o", out, "--lenses", "12x8", "--ppl", "4x4", "--quality", "auto",
               "--max-error", "28", "-q")
    assert result.code == 0, result.err
    quality = json.loads(out.with_suffix(".json").read_text())["quality"]
    assert quality["level"] == "auto" and quality["auto"]["tried"][-1]["psnr_db"] >= 28
    assert quality["setting"] == quality["auto"]["chosen"]
