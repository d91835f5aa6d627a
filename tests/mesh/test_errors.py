"""Bad input to convert-mesh: one clear message, the right exit code, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
import trimesh

from povh3d.errors import ConfigError, InputError, OutputError
from povh3d.image.colour import srgb_to_linear
from povh3d.renderer.content.convert_mesh import convert_mesh
from povh3d.mesh.identifiers import check_identifier, identifier_from_path, pov_keywords
from tests.conftest import SAMPLES
from tests.support.cli import one_error_line


def only(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()}


def test_missing_file(tmp_path, cli):
    result = cli("convert-mesh", tmp_path / "nope.obj", "-o", tmp_path / "x.inc")
    code, err = result.code, result.err
    assert code == InputError.exit_code and "does not exist" in err and err.count("\n") == 1
    assert only(tmp_path) == set()


def test_unknown_extension(tmp_path, cli):
    (tmp_path / "m.fbx").write_bytes(b"x")
    result = cli("convert-mesh", tmp_path / "m.fbx", "-o", tmp_path / "x.inc")
    code, err = result.code, result.err
    assert code == InputError.exit_code and "'.fbx'" in err and ".obj" in err
    assert only(tmp_path) == {"m.fbx"}


@pytest.mark.parametrize("name, data", [
    ("bad.ply", b"garbage, not a ply\n"),
    ("bad.glb", b"glTF\x02\x00\x00\x00garbage"),
    ("bad.off", b"OFF\n3 1 0\n0 0 0\n1 0\n"),
    ("empty.stl", b""),
    ("short.stl", b"\x00" * 40),
])
def test_corrupt_files(tmp_path, name, data):
    (tmp_path / name).write_bytes(data)
    with pytest.raises(InputError, match=name):
        convert_mesh(tmp_path / name, tmp_path / "x.inc")
    assert only(tmp_path) == {name}


def test_truncated_binary_stl(tmp_path):
    whole = trimesh.creation.box().export(file_type="stl")
    (tmp_path / "t.stl").write_bytes(whole[:300])
    with pytest.raises(InputError, match="truncated binary STL: its header counts 12 triangles"):
        convert_mesh(tmp_path / "t.stl", tmp_path / "x.inc")
    assert only(tmp_path) == {"t.stl"}


def test_empty_mesh(tmp_path):
    (tmp_path / "e.obj").write_text("# no faces\nv 0 0 0\n")
    with pytest.raises(InputError, match="contains no triangles"):
        convert_mesh(tmp_path / "e.obj", tmp_path / "x.inc")
    assert only(tmp_path) == {"e.obj"}


def test_nonfinite_and_degenerate_faces_dropped_with_counts(tmp_path, cli):
    lines = ["v 0 0 0", "v 1 0 0", "v 0 1 0", "v nan 0 0", "v inf 1 1", "v 2 0 0",
             "f 1 2 3", "f 1 2 4", "f 2 3 5", "f 4 5 1", "f 1 2 6", "f 1 1 3"]
    (tmp_path / "d.obj").write_text("\n".join(lines) + "\n")
    result = cli("convert-mesh", tmp_path / "d.obj", "-o", tmp_path / "d.inc")
    err = result.err
    assert result.code == 0
    assert "dropped 3 faces with non-finite (NaN or infinite) vertices" in err
    assert "dropped 2 degenerate faces" in err  # collinear 1-2-6 and repeated 1-1-3
    text = (tmp_path / "d.inc").read_text()
    assert "nan" not in text.lower() and "inf" not in text.lower().replace("finish", "")
    # All faces degenerate or non-finite: an empty mesh, with the count in the message.
    (tmp_path / "all.obj").write_text("v 0 0 0\nv 1 0 0\nv nan 0 0\nf 1 2 3\n")
    with pytest.raises(InputError, match="all 1 were dropped"):
        convert_mesh(tmp_path / "all.obj", tmp_path / "all.inc")
    assert not (tmp_path / "all.inc").exists()


def test_missing_texture_warns_and_uses_base_colour(tmp_path, cli):
    for name in ("letter_f.obj", "letter_f.mtl"):
        (tmp_path / name).write_bytes((SAMPLES / name).read_bytes())  # no letter_f.png
    result = cli("convert-mesh", tmp_path / "letter_f.obj")
    assert result.code == 0
    err = result.err
    assert "texture 'letter_f.png' named by the model is missing; rendering with the base colour" in err
    text = (tmp_path / "letter_f.inc").read_text()
    assert "image_map" not in text and "srgb" not in text
    assert f"rgb <{float(srgb_to_linear(0.8))!r}, " in text  # the base colour, decoded: parses in any scene


@pytest.mark.parametrize("name", ["sphere", "mesh2", "x", "pi", "clock", "rgb", "union", "texture"])
def test_keyword_identifier_refused(tmp_path, cli, name):
    assert name in pov_keywords()
    result = cli("convert-mesh", SAMPLES / "letter_l.stl", "-o", tmp_path / "x.inc", "--name", name)
    code, err = result.code, result.err
    assert code == ConfigError.exit_code and "is a POV-Ray keyword" in err
    assert only(tmp_path) == set()


@pytest.mark.parametrize("name", ["9lives", "my-model", "a b", ""])
def test_invalid_identifier_refused(name):
    with pytest.raises(ConfigError, match="not a POV-Ray identifier"):
        check_identifier(name)


@pytest.mark.parametrize("path, ident", [("teapot.obj", "Teapot"), ("my car.v2.stl", "My_car_v2"),
                                         ("3dbenchy.stl", "M_3dbenchy"), ("---.ply", "Model")])
def test_identifier_from_path(path, ident):
    assert identifier_from_path(path) == ident
    assert check_identifier(ident) == ident


def test_unwritable_output_folder(tmp_path, cli):
    result = cli("convert-mesh", SAMPLES / "letter_f.obj", "-o", tmp_path / "no" / "x.inc")
    code, err = result.code, result.err
    assert code == OutputError.exit_code and "does not exist" in err


def test_failure_after_textures_removes_them(tmp_path, monkeypatch):
    """The include is written last; if that fails, the texture written before it goes too."""
    import povh3d.renderer.content.convert_mesh as convert

    for name in ("letter_f.obj", "letter_f.mtl", "letter_f.png"):
        (tmp_path / name).write_bytes((SAMPLES / name).read_bytes())
    real = convert.atomic_path

    def failing(path):
        raise OutputError("disk full")

    monkeypatch.setattr(convert, "atomic_path", failing)
    with pytest.raises(OutputError):
        convert_mesh(tmp_path / "letter_f.obj", tmp_path / "f.inc")
    assert only(tmp_path) == {"letter_f.obj", "letter_f.mtl", "letter_f.png"}
    monkeypatch.setattr(convert, "atomic_path", real)


def test_bad_options(tmp_path):
    with pytest.raises(ConfigError, match="fit_depth"):
        convert_mesh(SAMPLES / "blob.ply", tmp_path / "x.inc", fit_depth=-1.0)
    with pytest.raises(ConfigError, match="max_triangles"):
        convert_mesh(SAMPLES / "blob.ply", tmp_path / "x.inc", max_triangles=0)
    flat = tmp_path / "flat.obj"
    flat.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ConfigError, match="flat in z"):
        convert_mesh(flat, tmp_path / "x.inc", fit_depth=5.0)
    assert only(tmp_path) == {"flat.obj"}


@pytest.mark.povray
def test_converted_include_parses_in_a_scene_without_assumed_gamma(tmp_path):
    """POV-Ray refuses ``srgb`` before ``assumed_gamma`` is set; a converted include must
    parse in any scene, here one with no global_settings at all (POV-Ray run directly)."""
    import subprocess

    for name in ("letter_f.obj", "letter_f.mtl"):
        (tmp_path / name).write_bytes((SAMPLES / name).read_bytes())  # no texture: the base colour
    convert_mesh(tmp_path / "letter_f.obj", tmp_path / "letter_f.inc", name="Letter")
    (tmp_path / "s.pov").write_text('#version 3.7;\ncamera { location <0, 0, -100> look_at 0 }\n'
                                    'light_source { <0, 0, -100> rgb 1 }\n#include "letter_f.inc"\n'
                                    'object { Letter }\n')
    done = subprocess.run(["povray", "+Is.pov", "+Oout.png", "+W16", "+H16", "-D", "-V"], cwd=tmp_path,
                          capture_output=True, text=True, check=False, timeout=60)
    assert done.returncode == 0, done.stderr[-800:]
    assert "sRGB" not in done.stderr and (tmp_path / "out.png").is_file()


@pytest.mark.povray   # the command as a process: --max-memory is the run's
def test_a_model_past_the_memory_budget_is_refused_before_it_is_read(tmp_path, cli):
    """The reading's memory is estimated from the file's size before trimesh reads it (issue 38:
    povh3d's own process is bounded too); the control, the same model with room, converts."""
    mesh = trimesh.creation.icosphere(subdivisions=5)   # 20,480 faces: about 1.5 MB of OBJ
    model = tmp_path / "ball.obj"
    mesh.export(model)
    size = model.stat().st_size
    small = f"{max(1, (12 * size) // 2**20 - 1)}M"   # under the estimate of 12 bytes a byte of file
    line = one_error_line(cli("convert-mesh", model, "-o", tmp_path / "ball.inc", "--max-memory", small), 2)
    assert "reading ball.obj" in line and "--max-memory" in line, line
    assert not (tmp_path / "ball.inc").exists()
    ok = cli("convert-mesh", model, "-o", tmp_path / "ball.inc", "--max-memory", "2G")
    assert ok.code == 0, ok.err
    assert (tmp_path / "ball.inc").is_file()
