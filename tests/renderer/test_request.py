"""One request, one path: stills and animations, scenes and models, the CLI and the Python
API go through ``renderer.render.render`` alike, so an animation frame is exactly the still."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

import povh3d
from povh3d.cli.main import main
from povh3d.display.display import Display
from povh3d.errors import ConfigError
from povh3d.image.io import read_png

REPO = Path(__file__).resolve().parents[2]
BLOB = REPO / "sample_models" / "blob.ply"
SMALL = ["--grid", "square", "--lenses", "10x8", "--ppl", "4", "--pixel-pitch", "0.1", "--focal", "1.5"]
SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.05, 0.05, 0.1> }
light_source { <-20, 30, -60> rgb 1 }
sphere { <0.3, -0.2, 1.0>, 1.2 pigment { checker rgb <1, 0.3, 0.1> rgb <0.2, 0.6, 1> scale 0.4 } }
plane { z, 4 pigment { rgb <0.3, 0.8, 0.3> } }
"""


def run(args: list[str]) -> int:
    try:
        return main([str(a) for a in args])
    except SystemExit as exc:
        return int(exc.code)


@pytest.fixture()
def scene(tmp_path: Path) -> Path:
    path = tmp_path / "scene.pov"
    path.write_text(SCENE)
    return path


def sidecar(path: Path) -> dict:
    return json.loads(path.with_suffix(".json").read_text())


def still_and_frame(tmp_path: Path, source: Path, *options: str) -> tuple[Path, Path]:
    """Render ``source`` as a still and as the one frame of ``--frames 1:1``; both paths."""
    still, frames = tmp_path / "still.png", tmp_path / "anim.png"
    assert run(["render", source, "-o", still, "--quality", "draft", *options]) == 0
    assert run(["render", source, "-o", frames, "--quality", "draft", "--frames", "1:1", *options]) == 0
    return still, tmp_path / "anim_0001.png"


@pytest.mark.povray
def test_a_frame_with_a_mapping_is_the_mapped_panel(tmp_path, scene):
    mapping = ["--mapping", "slanted", "--subpixels-per-lens", "4.5", "--views", "9", "--slant-tan", "0.1667"]
    still, frame = still_and_frame(tmp_path, scene, "--preset", "demo", *mapping)
    assert read_png(frame).shape[:2] == (240, 320)            # the panel, not the view-space image
    assert np.array_equal(read_png(frame), read_png(still))
    assert sidecar(frame)["kind"] == "panel" and sidecar(frame)["mapping"] == "slanted"
    # Negative control: the unmapped render of the same display is another image.
    assert run(["render", scene, "-o", tmp_path / "plain.png", "--quality", "draft", "--preset", "demo"]) == 0
    assert not np.array_equal(read_png(tmp_path / "plain.png"), read_png(frame))


@pytest.mark.povray
def test_a_frame_of_a_mesh_model_is_the_staged_model(tmp_path):
    still, frame = still_and_frame(tmp_path, BLOB, *SMALL)
    image = read_png(frame)
    assert np.array_equal(image, read_png(still))
    assert len(np.unique(image.reshape(-1, image.shape[2]), axis=0)) > 10   # the model was seen, not a blank
    assert sidecar(frame)["model"]["model"].endswith("blob.ply")


@pytest.mark.povray
def test_a_frame_keeps_the_single_stage_options(tmp_path, scene):
    still, frame = still_and_frame(tmp_path, scene, *SMALL, "--method", "single-stage", "--lenslet", "spherical")
    assert sidecar(frame)["single_stage"]["lenslet"]["shape"] == "spherical"
    assert np.array_equal(read_png(frame), read_png(still))


@pytest.mark.povray
def test_single_stage_defaults_to_the_conic_lenslet(tmp_path, scene):
    out = tmp_path / "ss.png"
    assert run(["render", scene, "-o", out, "--quality", "draft", *SMALL, "--method", "single-stage"]) == 0
    assert sidecar(out)["single_stage"]["lenslet"]["shape"] == "conic"


@pytest.mark.povray
def test_auto_quality_is_chosen_once_for_an_animation(tmp_path, monkeypatch):
    moving = tmp_path / "moving.pov"
    moving.write_text(SCENE.replace("<0.3, -0.2, 1.0>", "<0.3 + clock, -0.2, 1.0>"))
    calls = []
    import povh3d.renderer.methods.auto as auto_module  # renderer.render imports it where the quality is resolved

    real = auto_module.resolve_auto
    monkeypatch.setattr(auto_module, "resolve_auto", lambda *a, **k: calls.append(1) or real(*a, **k))
    out = tmp_path / "auto.png"
    assert run(["render", moving, "-o", out, *SMALL, "--quality", "auto", "--max-error", "20",
                "--frames", "0:2"]) == 0
    assert len(calls) == 1
    records = [sidecar(tmp_path / f"auto_{n:04d}.png") for n in range(3)]
    assert {r["quality"]["setting"] for r in records} == {records[0]["quality"]["auto"]["chosen"]}
    assert [r["animation"]["clock"] for r in records] == [0.0, 0.5, 1.0]


@pytest.mark.povray
def test_the_python_api_gives_the_cli_image(tmp_path, scene):
    assert run(["render", scene, "-o", tmp_path / "cli.png", "--quality", "draft", "--preset", "demo"]) == 0
    record = povh3d.render(scene, tmp_path / "api.png", preset="demo", quality="draft")
    assert record["display"]["preset"] == "demo"
    assert np.array_equal(read_png(tmp_path / "api.png"), read_png(tmp_path / "cli.png"))
    array = povh3d.presets.lens_array("demo", ppl=4)
    povh3d.render(scene, tmp_path / "four.png", lens_array=array, quality="draft")
    assert sidecar(tmp_path / "four.png")["lens_array"]["views"] == [4, 4]


@pytest.mark.parametrize("call, name", [
    (lambda p: povh3d.render(p, p.with_suffix(".png"), qualty="draft"), "qualty"),
    (lambda p: povh3d.presets.lens_array("demo", foccal=2.0), "foccal"),
    (lambda p: povh3d.RenderRequest(p, Display(povh3d.presets.lens_array("demo")), p.with_suffix(".png"),
                                    method_options={"lenslet": "conic"}), "lenslet"),
])
def test_unknown_names_are_refused_by_name(tmp_path, scene, call, name):
    with pytest.raises(ConfigError, match=name):
        call(scene)


@pytest.mark.povray
def test_import_povh3d_loads_nothing_heavy():
    import subprocess
    code = "import povh3d, sys; print(sorted(m for m in ('numpy', 'jinja2', 'PIL', 'trimesh') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
    # Every public name is in __all__ but map: a star import must not hide the builtin map.
    assert set(povh3d.__all__) == {"__version__", *povh3d._PUBLIC, *povh3d._MODULES} - {"map"}
    assert "map" in dir(povh3d) and callable(povh3d.map)


@pytest.mark.povray
def test_a_failed_render_leaves_the_previous_output(tmp_path, scene):
    out = tmp_path / "good.png"
    assert run(["render", scene, "-o", out, "--quality", "draft", *SMALL]) == 0
    before = out.read_bytes(), out.with_suffix(".json").read_bytes()
    broken = tmp_path / "broken.pov"
    broken.write_text("sphere { <0, 0, 1>, 1 pigment { rgb 1 }\n")   # unclosed
    assert run(["render", broken, "-o", out, "--quality", "draft", *SMALL]) != 0
    assert (out.read_bytes(), out.with_suffix(".json").read_bytes()) == before
