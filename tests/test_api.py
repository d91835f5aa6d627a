"""The commands as Python functions (povh3d/api.py): each gives the pixels its command writes,
on the same input (the command line is the oracle: it is tested against the thesis elsewhere)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import povh3d
from povh3d.renderer.records import base_record, write_image
from povh3d.renderer.outputs.views import read_views
from povh3d.calibration.gridfile import read_grid, write_grid
from povh3d.errors import ConfigError
from povh3d.image.io import read_png, write_png
from povh3d.image.refocus import contact_sheet
from povh3d.display.mappings import build_mapping
from tests.conftest import SAMPLES
from tests.support.arrays import lenticular_array, square_array
from tests.support.oracles import grid_for_lens_array
from tests.support.synth import WhiteSpec, render_white, to_uint

SQUARE = square_array(lx=10, ly=8, nx=4, ny=4)
LENTICULAR = lenticular_array(lx=6, rows=10, nx=8)


def _noise(shape: tuple[int, ...], seed: int = 0, dtype=np.uint8) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, np.iinfo(dtype).max, shape, dtype=dtype, endpoint=True)


@pytest.fixture
def square(tmp_path):
    """An H3D image of SQUARE with its sidecar: (path, image)."""
    image = _noise((SQUARE.panel.height, SQUARE.panel.width, 3), 1)
    write_image(tmp_path / "sq.png", image, base_record("h3d", SQUARE))
    return tmp_path / "sq.png", image


@pytest.fixture
def lenticular(tmp_path):
    image = _noise((LENTICULAR.panel.height, LENTICULAR.panel.width, 3), 2)
    write_image(tmp_path / "len.png", image, base_record("h3d", LENTICULAR))
    return tmp_path / "len.png", image


def _ok(result):
    assert result.code == 0, result.err
    return result


def test_every_command_function_is_exported_lazily_and_documented():
    from povh3d import _COMMANDS

    from pathlib import Path
    api_md = (Path(__file__).resolve().parents[1] / "docs" / "api.md").read_text(encoding="utf-8")
    for name in _COMMANDS:
        function = getattr(povh3d, name)
        assert function.__module__ == "povh3d.api" and function.__doc__, name
        assert f"povh3d.{name}(" in api_md, f"docs/api.md shows no example of {name}"
    assert set(_COMMANDS) <= set(dir(povh3d))


def test_read_h3d_gives_the_sidecars_lens_array(square):
    image, array = povh3d.read_h3d(square[0])
    assert np.array_equal(image, square[1]) and array == SQUARE


def test_extract_and_interleave(square, tmp_path, cli):
    path, image = square
    _ok(cli("extract", path, "-o", tmp_path / "views"))
    views = povh3d.extract(image, SQUARE)
    assert np.array_equal(views, read_views(tmp_path / "views"))
    assert np.array_equal(views, povh3d.extract(image, (4, 4)))
    _ok(cli("interleave", tmp_path / "views", "-o", tmp_path / "back.png"))
    assert np.array_equal(povh3d.interleave(views), read_png(tmp_path / "back.png"))
    with pytest.raises(ConfigError):  # negative control: the wrong lens size does not pass silently
        povh3d.extract(image[:, :-1], SQUARE)


def test_map(tmp_path, cli):
    mapping = build_mapping("philips")
    image = _noise(mapping.source((60, 36)).shape, 3)
    write_png(tmp_path / "in.png", image)
    _ok(cli("map", tmp_path / "in.png", "--mapping", "philips", "-o", tmp_path / "out.png"))
    expected = read_png(tmp_path / "out.png")
    assert np.array_equal(povh3d.map(image, "philips"), expected)
    assert np.array_equal(povh3d.map(image, mapping, panel=(60, 36)), expected)
    assert not np.array_equal(povh3d.map(image[:, ::-1], "philips"), expected)  # negative control


@pytest.mark.parametrize("mode", ["micro", "lenses"])
def test_resample(square, tmp_path, cli, mode):
    path, image = square
    _ok(cli("resample", path, "--ppl-out", "2", "--mode", mode, "-o", tmp_path / "r.png"))
    assert np.array_equal(povh3d.resample(image, (4, 4), (2, 2), mode=mode), read_png(tmp_path / "r.png"))


def test_quilt_and_unquilt(lenticular, tmp_path, cli):
    path, image = lenticular
    _ok(cli("quilt", path, "--quilt", "4x2", "-o", tmp_path / "q"))
    (quilt_path,) = (tmp_path / "q").glob("*.png")
    quilt = povh3d.quilt(image, LENTICULAR, (4, 2))
    assert np.array_equal(quilt, read_png(quilt_path))
    assert np.array_equal(povh3d.quilt(image, 8, (4, 2)), quilt)
    _ok(cli("quilt", quilt_path, "--import", "-o", tmp_path / "back.png"))
    assert np.array_equal(povh3d.unquilt(quilt, (4, 2)), read_png(tmp_path / "back.png"))


def test_refocus(square, tmp_path, cli):
    path, image = square
    _ok(cli("refocus", path, "--depth", "3", "-o", tmp_path / "f.png"))
    expected = read_png(tmp_path / "f.png")
    assert np.array_equal(povh3d.refocus(image, SQUARE, 3.0), expected)
    assert not np.array_equal(povh3d.refocus(image, SQUARE, -3.0), expected)  # negative control


def test_preview(square, tmp_path, cli):
    path, image = square
    _ok(cli("preview", path, "--frames", "5", "-o", tmp_path / "p.gif"))
    frames = povh3d.preview(image, SQUARE, frames=5)
    assert frames.shape[0] == 5
    assert np.array_equal(contact_sheet(list(frames)), read_png(tmp_path / "p.png"))


def test_info(cli):
    expected = json.loads(_ok(cli("info", "--preset", "ipad-retina", "--json")).out)
    assert json.loads(json.dumps(povh3d.info("ipad-retina"))) == expected
    assert povh3d.info(lens_array=SQUARE)["lenses"] == [10, 8]


def test_moire(tmp_path, cli):
    _ok(cli("moire", "--slant-range", "0:3:1", "-o", tmp_path / "m.png"))
    expected = json.loads((tmp_path / "m.json").read_text())["moire"]
    array = povh3d.presets.lens_array("cross-lenticular-ipad")
    sweep = povh3d.moire(array, [0.0, 1.0, 2.0, 3.0])  # 0:3:1 includes its end
    assert sweep.row_contrast.tolist() == expected["row_contrast"]
    assert sweep.period_mm.tolist() == expected["period_mm"]


@pytest.fixture
def capture(tmp_path):
    """A white image, its grid.json from the command, and a capture through the same lenses."""
    spec = WhiteSpec((160, 120), pitch_px=8.3, rotation_deg=0.4, k1=-0.02, vignetting=0.2)
    white = to_uint(render_white(spec), 8)
    write_png(tmp_path / "white.png", white)
    shot = to_uint(render_white(spec, content=lambda c, uv: 0.5 + 0.4 * np.sin(c[..., 0] / 9 + uv[..., 0])), 8)
    write_png(tmp_path / "shot.png", shot)
    return read_png(tmp_path / "white.png"), read_png(tmp_path / "shot.png")  # the command's input exactly


def test_calibrate_and_the_capture_commands(capture, tmp_path, cli):
    white, shot = capture
    _ok(cli("calibrate", tmp_path / "white.png", "-o", tmp_path / "grid.json"))
    grid = povh3d.calibrate(white)
    write_grid(tmp_path / "api.json", grid)
    mine, theirs = (json.loads((tmp_path / n).read_text()) for n in ("api.json", "grid.json"))
    for record in (mine, theirs):
        record.pop("seconds", None), record.pop("white_image", None)
    assert mine == theirs
    grid = read_grid(tmp_path / "grid.json")
    for name, extra, function in [
            ("undistort", [], lambda: povh3d.undistort(shot, grid)),
            ("borders", ["--fill", "nearest"], lambda: povh3d.borders(shot, grid, fill="nearest")),
            ("equalise", ["--size", "6"], lambda: povh3d.equalise(shot, tmp_path / "grid.json", size=6))]:
        _ok(cli(name, tmp_path / "shot.png", "--grid", tmp_path / "grid.json", "-o", tmp_path / f"{name}.png", *extra))
        assert np.array_equal(function(), read_png(tmp_path / f"{name}.png")), name
    _ok(cli("viewpoints", tmp_path / "shot.png", "--grid", tmp_path / "grid.json", "--ppl", "3", "-o", tmp_path / "v"))
    assert np.array_equal(povh3d.viewpoints(shot, grid, ppl=3), read_views(tmp_path / "v"))


def test_stitch(tmp_path, cli):
    array = square_array(lx=16, ly=8, nx=4, ny=4)
    write_grid(tmp_path / "grid.json", grid_for_lens_array(array))
    wide = _noise((32, 96, 3), 4)
    a, b = wide[:, :64], wide[:, 32:]  # the camera moved 8 lenses to the right
    write_png(tmp_path / "a.png", a)
    write_png(tmp_path / "b.png", b)
    _ok(cli("stitch", tmp_path / "a.png", tmp_path / "b.png", "--grid", tmp_path / "grid.json", "-o", tmp_path / "ab.png"))
    stitched = povh3d.stitch(a, b, tmp_path / "grid.json")
    assert np.array_equal(stitched, read_png(tmp_path / "ab.png"))
    assert np.array_equal(stitched, wide)


def test_convert_mesh(tmp_path, cli):
    _ok(cli("convert-mesh", SAMPLES / "letter_l.stl", "-o", tmp_path / "cli.inc"))
    povh3d.convert_mesh(SAMPLES / "letter_l.stl", tmp_path / "api.inc")
    assert (tmp_path / "api.inc").read_text() == (tmp_path / "cli.inc").read_text()


def test_layout(tmp_path, cli):
    _ok(cli("layout", SAMPLES / "letter_l.stl", "--size", "320x240", "-o", tmp_path / "cli.png"))
    record = povh3d.layout(SAMPLES / "letter_l.stl", tmp_path / "api.png", size=(320, 240))
    assert record["setup"] == json.loads((tmp_path / "cli.json").read_text())["setup"]
    assert np.array_equal(read_png(tmp_path / "api.png"), read_png(tmp_path / "cli.png"))
