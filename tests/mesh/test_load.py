"""Binary STL read straight with NumPy (issue 17) gives what trimesh's reader gives."""

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
