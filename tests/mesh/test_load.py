"""Binary STL and PLY read straight with NumPy (issue 17) give what trimesh's readers give."""

from __future__ import annotations

import numpy as np
import trimesh

from povh3d.mesh import load
from povh3d.mesh.load import load_model


def _stl(tmp_path, attributes: int = 0):
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=7.5)
    path = tmp_path / "ball.stl"
    data = bytearray(mesh.export(file_type="stl"))
    if attributes:
        data[84 + 48:84 + 50] = attributes.to_bytes(2, "little")  # first triangle's attribute bytes
    path.write_bytes(bytes(data))
    return path


def _through_trimesh(path, monkeypatch, **kw):
    with monkeypatch.context() as patch:
        patch.setattr(load, "_binary_stl", lambda *a: None)
        patch.setattr(load, "_binary_ply", lambda *a: None)
        return load_model(path, **kw)


def test_fast_binary_stl_equals_trimesh(tmp_path, monkeypatch):
    path = _stl(tmp_path)
    assert load._binary_stl(path, path.read_bytes(), load.FORMATS[".stl"], None) is not None
    for unit in (None, "cm"):
        fast, slow = load_model(path, unit=unit), _through_trimesh(path, monkeypatch, unit=unit)
        (a,), (b,) = fast.parts, slow.parts
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
        assert a.name == b.name and a.colour_space == b.colour_space and a.normals is b.normals is None
        assert fast.mm_per_unit == slow.mm_per_unit and fast.files == slow.files and fast.missing == slow.missing


def test_other_stl_dialects_go_to_trimesh(tmp_path):
    path = _stl(tmp_path, attributes=0x7C1F)  # a colour in the attribute bytes
    assert load._binary_stl(path, path.read_bytes(), load.FORMATS[".stl"], None) is None
    ascii_stl = tmp_path / "a.stl"
    ascii_stl.write_bytes(trimesh.creation.box().export(file_type="stl_ascii").encode())
    assert load._binary_stl(ascii_stl, ascii_stl.read_bytes(), load.FORMATS[".stl"], None) is None
    assert load_model(ascii_stl).parts[0].triangles == 12


def _ply(tmp_path, name: str, **kw) -> object:
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=7.5)
    mesh.vertices += np.random.default_rng(0).normal(0, 0.1, mesh.vertices.shape)
    path = tmp_path / name
    path.write_bytes(trimesh.exchange.ply.export_ply(mesh, **kw))
    return path


def test_fast_binary_ply_equals_trimesh(tmp_path, monkeypatch):
    for path in (_ply(tmp_path, "plain.ply"), _ply(tmp_path, "normals.ply", vertex_normal=True)):
        assert load._binary_ply(path, path.read_bytes(), load.FORMATS[".ply"], None) is not None
        for unit in (None, "cm"):
            fast, slow = load_model(path, unit=unit), _through_trimesh(path, monkeypatch, unit=unit)
            (a,), (b,) = fast.parts, slow.parts
            np.testing.assert_array_equal(a.vertices, b.vertices)
            np.testing.assert_array_equal(a.faces, b.faces)
            assert (a.normals is None) == (b.normals is None) == (path.name == "plain.ply")
            if a.normals is not None:
                np.testing.assert_array_equal(a.normals, b.normals)
            assert a.name == b.name and a.colour_space == b.colour_space and a.vertex_colors is b.vertex_colors
            assert fast.mm_per_unit == slow.mm_per_unit and fast.files == slow.files


def test_other_ply_layouts_go_to_trimesh(tmp_path):
    ascii_ply = _ply(tmp_path, "a.ply", encoding="ascii")
    coloured = tmp_path / "c.ply"
    mesh = trimesh.creation.box()
    mesh.visual.vertex_colors = [255, 0, 0, 255]
    coloured.write_bytes(trimesh.exchange.ply.export_ply(mesh))
    quads = tmp_path / "q.ply"  # one quad: a face of 4 indices
    quads.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                      b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                      + np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "<f4").tobytes()
                      + bytes([4]) + np.array([0, 1, 2, 3], "<i4").tobytes())
    for path in (ascii_ply, coloured, quads):
        assert load._binary_ply(path, path.read_bytes(), load.FORMATS[".ply"], None) is None
    assert load_model(coloured).parts[0].vertex_colors is not None
    assert load_model(quads).parts[0].triangles == 2  # trimesh splits the quad


def test_obj_objects_and_groups_are_parts(tmp_path, monkeypatch):
    # one part per object (o) and group (g), named after it, as object masks need; a file with more
    # groups than masks tell apart is read by material, as trimesh reads it by default
    box = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf {a} {b} {c}\nf {a} {b} {d}\n"
    text = "".join(f"{key} {name}\n" + box.format(a=4 * n + 1, b=4 * n + 2, c=4 * n + 3, d=4 * n + 4)
                   for n, (key, name) in enumerate([("o", "lid"), ("g", "handle"), ("g", "body")]))
    (tmp_path / "pot.obj").write_text(text)
    parts = load_model(tmp_path / "pot.obj").parts
    # a group inside an object is named after both (trimesh)
    assert sorted(p.name for p in parts) == ["lid", "lid_body", "lid_handle"] and all(p.triangles == 2 for p in parts)
    monkeypatch.setattr(load, "MAX_SPLIT_PARTS", 2)
    assert [p.triangles for p in load_model(tmp_path / "pot.obj").parts] == [6]
