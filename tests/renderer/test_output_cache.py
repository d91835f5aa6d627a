"""The whole-output cache (renderer/output_cache.py): a re-run with nothing changed is the stored
image and sidecar; any change of what decides the pixels is a new render; a damaged entry is
never answered from."""

from __future__ import annotations

import pytest
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from povh3d.image.io import file_sha256, read_png
from tests.support.cli import REPO, one_error_line

pytestmark = pytest.mark.povray  # every test here starts POV-Ray

TINY = ["--lenses", "6x4", "--ppl", "4x4", "--quality", "draft", "-q"]


def _scene(folder, colour: str) -> object:
    """A flat emissive wall whose colour comes from an include beside the scene."""
    (folder / "colour.inc").write_text(f"#declare Wall = rgb <{colour}>;\n")
    scene = folder / "s.pov"
    scene.write_text('#include "colour.inc"\nlight_source { <0, 0, -100> rgb 1 }\n'
                     "plane { z, 5 pigment { Wall } finish { emission 1 diffuse 0 } }\n")
    return scene


def _entries(cache):
    return sorted((cache / "outputs").rglob("*.output"))


def test_rerun_is_answered_from_the_stored_output(tmp_path, cli):
    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    first = cli("render", scene, "-o", out, *TINY)
    assert first.code == 0, first.err
    assert "shots from cache" in first.out
    rendered = out.read_bytes()
    again = cli("render", scene, "-o", out, *TINY)
    assert again.code == 0, again.err
    assert "output from cache" in again.out
    assert out.read_bytes() == rendered
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["timings"]["output_from_cache"] is True
    assert record["image_sha256"] == file_sha256(out)  # the pair is consistent


def test_an_edited_include_renders_again(tmp_path, cli):
    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    assert cli("render", scene, "-o", out, *TINY).code == 0
    assert read_png(out)[..., 0].min() == 255  # red, emission 1
    _scene(tmp_path, "0, 0, 1")
    result = cli("render", scene, "-o", out, *TINY)
    assert "output from cache" not in result.out
    blue = read_png(out)
    assert blue[..., 0].max() == 0 and blue[..., 2].min() == 255


def test_a_changed_option_renders_again(tmp_path, cli):
    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    assert cli("render", scene, "-o", out, *TINY).code == 0
    result = cli("render", scene, "-o", out, *TINY, "--bit-depth", "16")
    assert "output from cache" not in result.out and read_png(out).dtype == np.uint16


def test_a_damaged_entry_is_never_answered_from(tmp_path, cli):
    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    assert cli("render", scene, "-o", out, *TINY).code == 0
    good = out.read_bytes()
    (entry,) = _entries(Path(os.environ["POVH3D_CACHE"]))
    data = entry.read_bytes()
    entry.write_bytes(data[:-60] + bytes(b ^ 0xFF for b in data[-60:]))  # same size: only the hash tells
    result = cli("render", scene, "-o", out, *TINY)
    assert result.code == 0 and "output from cache" not in result.out
    assert out.read_bytes() == good
    assert "output from cache" in cli("render", scene, "-o", out, *TINY).out  # stored again, whole


def test_no_cache_neither_reads_nor_writes(tmp_path, cli):
    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    assert cli("render", scene, "-o", out, "--no-cache", *TINY).code == 0
    assert not _entries(Path(os.environ["POVH3D_CACHE"]))


def test_warnings_are_given_again(tmp_path, cli):
    scene, out = tmp_path / "dark.pov", tmp_path / "o.png"
    scene.write_text("sphere { <0, 0, 5>, 1 pigment { rgb 1 } }\n")
    first = cli("render", scene, "-o", out, *TINY)
    again = cli("render", scene, "-o", out, *TINY)
    assert "output from cache" in again.out
    lines = [line for line in first.err.splitlines() if "warning" in line]
    assert lines and [line for line in again.err.splitlines() if "warning" in line] == lines


def test_a_hit_imports_no_numpy(tmp_path):
    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    code = ("import sys; from povh3d.cli.main import main; code = main(sys.argv[1:]); "
            "print('numpy' in sys.modules, 'PIL' in sys.modules, 'jinja2' in sys.modules)")
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    command = [sys.executable, "-c", code, "render", str(scene), "-o", str(out), *TINY]
    subprocess.run(command, check=True, env=env, capture_output=True)
    done = subprocess.run(command, check=True, env=env, capture_output=True, text=True)
    assert "output from cache" in done.stdout
    assert done.stdout.strip().splitlines()[-1] == "False False False"


def test_errors_stay_one_line_on_the_fast_path(tmp_path, cli):
    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    assert cli("render", scene, "-o", out, *TINY).code == 0
    elsewhere = cli("render", scene, "-o", tmp_path / "missing" / "o.png", *TINY)  # a key of its own: a miss
    assert elsewhere.code != 0 and one_error_line(elsewhere).count("does not exist") == 1
    (tmp_path / "colour.inc").unlink()  # what the scene includes is gone: no answer from the cache
    gone = cli("render", scene, "-o", out, *TINY)
    assert gone.code != 0 and "output from cache" not in gone.out
    assert "colour.inc" in one_error_line(gone)
    scene.unlink()
    missing = cli("render", scene, "-o", out, *TINY)
    assert missing.code != 0 and "does not exist" in one_error_line(missing)


def test_a_hit_into_a_removed_folder_is_one_error(tmp_path, cli):
    scene, folder = _scene(tmp_path, "1, 0, 0"), tmp_path / "out"
    folder.mkdir()
    assert cli("render", scene, "-o", folder / "o.png", *TINY).code == 0
    for path in folder.iterdir():
        path.unlink()
    folder.rmdir()
    result = cli("render", scene, "-o", folder / "o.png", *TINY)
    assert "does not exist" in one_error_line(result) and not folder.exists()


def test_the_python_api_is_answered_from_the_stored_output(tmp_path):
    import povh3d
    from povh3d.geometry.lens_array import LensArray, Panel

    scene, out = _scene(tmp_path, "1, 0, 0"), tmp_path / "o.png"
    array = LensArray("square", 6, 4, 1.0, 1.0, 3.0, Panel(24, 16, 0.25, 0.25))
    call = dict(lens_array=array, quality="draft", cache_dir=tmp_path / "cache")
    first = povh3d.render(scene, out, **call)
    rendered = out.read_bytes()
    assert "output_from_cache" not in first["timings"]
    again = povh3d.render(scene, out, **call)
    assert again["timings"]["output_from_cache"] is True
    assert out.read_bytes() == rendered
    strip = lambda record: {k: v for k, v in record.items() if k not in ("timings", "image_sha256")}  # noqa: E731
    assert strip(again) == strip(first)
    assert json.loads(out.with_suffix(".json").read_text())["image_sha256"] == file_sha256(out)
    # negative controls: another lens array, or use_cache=False, renders again
    other = povh3d.render(scene, out, **{**call, "lens_array": LensArray("square", 6, 4, 1.0, 1.0, 2.5,
                                                                           Panel(24, 16, 0.25, 0.25))})
    assert "output_from_cache" not in other["timings"]
    assert "output_from_cache" not in povh3d.render(scene, out, **{**call, "use_cache": False})["timings"]
