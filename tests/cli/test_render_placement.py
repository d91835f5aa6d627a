"""``povh3d render`` on scenes with their own camera: the summary line names the frame and the
depth, ``--fit-depth`` fits, bad frame options are one line and a non-zero exit."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

GALLERY = Path(__file__).resolve().parents[1] / "support" / "gallery"
ARRAY = ("--grid", "square", "--lenses", "24x18", "--ppl", "6x6", "--pixel-pitch", "0.2", "--focal", "2")


@pytest.mark.povray
def test_summary_names_the_camera_frame_and_fit_depth_fits(cli, tmp_path):
    out = tmp_path / "t.png"
    # --depth-report: a plain render measures no depth (tests/renderer/test_passes.py)
    plain = cli("render", str(GALLERY / "tilted.pov"), "-o", str(out), "--quality", "draft", "--depth-report", *ARRAY)
    assert plain.code == 0, plain.err
    assert "placement camera (centre 0.35,0.42,-0.1" in plain.out and "depth" in plain.out
    record = json.loads(out.with_suffix(".json").read_text())["placement"]
    assert record["source"] == "camera" and record["depth"]["empty"] is False
    fitted = cli("render", str(GALLERY / "tilted.pov"), "-o", str(tmp_path / "f.png"), "--quality", "draft",
                 "--fit-depth", "auto", *ARRAY)
    assert fitted.code == 0, fitted.err
    depth = json.loads((tmp_path / "f.json").read_text())["placement"]["depth"]
    assert depth["within_budget"]
    half = depth["depth_budget_mm"] / 2
    assert max(abs(depth["near_mm"]), abs(depth["far_mm"])) == pytest.approx(half, rel=1e-9) \
        or depth["fit"]["factor"] == 1.0


@pytest.mark.povray
def test_native_scene_summary(cli, tmp_path):
    scene = tmp_path / "s.pov"
    scene.write_text("#version 3.7;\nsphere { <0, 0, 0>, 3 pigment { rgb 1 } }\nlight_source { <0, 9, -9> rgb 1 }\n")
    result = cli("render", str(scene), "-o", str(tmp_path / "s.png"), "--quality", "draft", *ARRAY)
    assert result.code == 0 and "placement native" in result.out


@pytest.mark.parametrize("args, words", [
    (("--display-center", "0,0,0"), "needs all"),
    (("--display-center", "0,0,0", "--display-normal", "0,1,0", "--display-up", "0,1,0",
      "--display-width", "2"), "parallel"),
    (("--display-center", "0,0", "--display-normal", "0,0,1", "--display-width", "2"), "three numbers"),
    (("--fit-depth", "deep"), "--fit-depth"),
    (("--depth-scale",), "needs --fit-depth"),
    (("--depth-scale", "flat"), "--depth-scale takes a factor"),
    (("--depth-scale", "0"), "--depth-scale must be a number within"),
    (("--fit-depth", "auto", "--depth-scale", "0.5"), "both set the depth"),
    (("--placement", "camera", "--display-center", "0,0,0", "--display-normal", "0,0,1",
      "--display-width", "2"), "cannot be combined"),
])
def test_bad_placement_options_are_one_line(cli, tmp_path, args, words):
    result = cli("render", str(GALLERY / "tilted.pov"), "-o", str(tmp_path / "x.png"), *args, *ARRAY)
    assert result.code == 2 and words in result.err and result.err.strip().count("\n") == 0
    assert not (tmp_path / "x.png").exists()


@pytest.mark.povray
def test_info_reports_the_scene_depth_against_the_budget(cli):
    result = cli("info", str(GALLERY / "tilted.pov"), *ARRAY)
    assert result.code == 0, result.err
    assert "placement camera" in result.out and "depth budget +-12 mm" in result.out   # 2 N f = 2 * 6 * 2 = 24
    data = cli("info", str(GALLERY / "tilted.pov"), "--json", *ARRAY)
    report = json.loads(data.out)["scene"]
    assert report["depth_budget_mm"] == pytest.approx(24.0) and report["depth"]["empty"] is False


@pytest.mark.povray
def test_depth_maps_are_written_per_view_with_their_disparity(cli, tmp_path):
    import numpy as np

    folder = tmp_path / "depth"
    result = cli("render", str(GALLERY / "inches.pov"), "-o", str(tmp_path / "i.png"), "--quality", "draft",
                 "--depth-maps", str(folder), *ARRAY)
    assert result.code == 0, result.err
    info = json.loads((folder / "depth_maps.json").read_text())
    assert info["views"] == [6, 6] and info["placement"]["source"] == "camera"
    d = np.load(folder / "d_000_005.npy")
    p = np.load(folder / "p_000_005.npy")
    assert d.shape == (18, 24) and np.isfinite(d).mean() > 0.5
    a, b = (5 + 0.5 - 3) * 0.2 / 2, (3 - 0 - 0.5) * 0.2 / 2
    np.testing.assert_allclose(p, d / np.sqrt(a * a + b * b + 1) * 0.2 / (2 * 1.2), rtol=1e-5)
    assert sorted(x.name for x in folder.iterdir())[:2] == ["d_000_000.npy", "d_000_001.npy"]
    assert len(list(folder.glob("*.npy"))) == 2 * 36


@pytest.mark.povray
def test_fit_depth_that_cannot_fit_is_one_line_and_nothing_written(cli, tmp_path):
    # the viewpoint inside a solid the hollow copy cannot reach (an include of another folder): no fog,
    # nothing measured
    lib, folder = tmp_path / "lib", tmp_path / "scene"
    lib.mkdir()
    folder.mkdir()
    (lib / "backdrop.inc").write_text("plane { z, 10 pigment { rgb 1 } }\n")
    scene = folder / "inside.pov"
    scene.write_text("#version 3.7;\nlight_source { <0, 9, -9> rgb 1 }\n#include \"backdrop.inc\"\n"
                     "sphere { 0, 3 pigment { rgb 0.5 } }\n")
    out = tmp_path / "x.png"
    result = cli("render", str(scene), "-o", str(out), "--quality", "draft", "--fit-depth", "auto",
                 "--include", str(lib), *ARRAY)
    assert result.code == 2 and "--fit-depth cannot fit" in result.err
    assert result.err.strip().count("\n") == 0 and not out.exists() and not out.with_suffix(".json").exists()


@pytest.mark.povray
def test_depth_maps_as_16_bit_png_decode_to_the_npy_maps(cli, tmp_path):
    import numpy as np

    from povh3d.image.depth_codes import dequantise
    from povh3d.image.io import read_png

    for fmt in ("npy", "png"):
        result = cli("render", str(GALLERY / "inches.pov"), "-o", str(tmp_path / f"{fmt}.png"), "--quality",
                     "draft", "--depth-maps", str(tmp_path / fmt), "--depth-format", fmt, *ARRAY)
        assert result.code == 0, result.err
    info = json.loads((tmp_path / "png" / "depth_maps.json").read_text())
    assert info["format"] == "png" and "code 0" in info["png"]["decode"]
    assert not list((tmp_path / "png").glob("*.npy")) and len(list((tmp_path / "png").glob("*.png"))) == 72
    for prefix, kind in (("d", "depth"), ("p", "disparity")):
        scale, offset = info["png"][kind]["scale"], info["png"][kind]["offset"]
        for view in ("000_000", "003_002", "005_005"):
            codes = read_png(tmp_path / "png" / f"{prefix}_{view}.png")[..., 0]
            assert codes.dtype == np.uint16
            exact = np.load(tmp_path / "npy" / f"{prefix}_{view}.npy")
            decoded = dequantise(codes, scale, offset)
            np.testing.assert_array_equal(np.isnan(decoded), np.isnan(exact))   # no hit <-> code 0
            assert np.nanmax(np.abs(decoded - exact)) <= scale / 2 * (1 + 1e-6) + 1e-6 * abs(offset)


@pytest.mark.povray
def test_fit_depth_by_depth_scale_says_it_distorts(cli, tmp_path):
    out = tmp_path / "k.png"
    result = cli("render", str(GALLERY / "tilted.pov"), "-o", str(out), "--quality", "draft", "--fit-depth", "auto",
                 "--depth-scale", *ARRAY)
    assert result.code == 0, result.err
    record = json.loads(out.with_suffix(".json").read_text())
    frame = record["placement"]
    assert "(distorted)" in result.out and "distortion" in frame["depth_scale_note"]
    assert frame["depth"]["fit"]["by"] == "depth_scale" and frame["depth"]["within_budget"]
    assert frame["depth_scale"] == pytest.approx(1 / frame["depth"]["fit"]["factor"])
    assert record["lens_array"]["focal_mm"] == 2.0   # the display as it is; only the rays are tilted less


def test_info_reports_a_model_and_a_volume_as_the_stage_places_them(cli):
    import pyvista

    examples = Path(pyvista.__file__).parent / "examples"
    width = 24 * 6 * 0.2                      # the panel (mm); the stage fills 0.9 of it
    for source, kind in ((examples / "ant.ply", "model"), (examples / "frog_tissues.vti", "volume")):
        data = cli("info", str(source), "--json", *ARRAY)
        assert data.code == 0, data.err
        report = json.loads(data.out)["content"]
        assert report["kind"] == kind and report["depth_budget_mm"] == pytest.approx(24.0)
        size, depth = report["fit"]["size_mm"], report["depth"]
        assert max(size[0] / (0.9 * width), size[1] / (0.9 * 18 * 6 * 0.2)) == pytest.approx(1.0)
        assert depth["near_mm"] == pytest.approx(-depth["far_mm"], abs=1e-6)   # centred on the screen
        assert depth["far_mm"] - depth["near_mm"] == pytest.approx(size[2], rel=1e-6)
        text = cli("info", str(source), *ARRAY)
        assert f"{kind} " in text.out and "content depth" in text.out and "depth budget +-12 mm" in text.out


@pytest.mark.parametrize("form", ["separate", "joined"])
@pytest.mark.parametrize("option, value, attribute", [
    ("--display-normal", "-50,-40,-30", "display_normal"),
    ("--display-center", "-1,2,3", "display_center"),
    ("--bbox", "-20,-20,-20,20,20,20", "bbox"),
    ("--front-clearance", "-.5", "front_clearance"),
])
def test_a_value_starting_with_a_minus_is_a_value(option, value, attribute, form):
    """``--opt -1,2,3`` and ``--opt=-1,2,3`` both give the value (argparse alone took ``-1,2,3`` for an option)."""
    from povh3d.cli.main import build_parser

    args = [option, value] if form == "separate" else [f"{option}={value}"]
    parsed = build_parser().parse_args(["render", "s.pov", *args])
    assert str(getattr(parsed, attribute)).lstrip("-.0") != ""
    assert getattr(parsed, attribute) in (value, float(value) if attribute == "front_clearance" else value)


def test_an_unknown_option_is_still_refused(cli, tmp_path):  # negative control: a minus and a letter is an option
    result = cli("render", str(GALLERY / "tilted.pov"), "--display-normal", "-x,1,2", *ARRAY)
    assert result.code == 2 and "expected one argument" in result.err
