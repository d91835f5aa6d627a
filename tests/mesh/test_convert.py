"""convert-mesh: every format round-trips exactly through the written mesh2 (no POV-Ray needed).

The expectation is trimesh's own reading of the file, taken to POV-Ray's frame
by hand here (z negated, winding reversed), compared with what a parser reads
back from the include: exact equality, not a tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from PIL import Image

from povh3d.renderer.content.convert_mesh import convert_mesh
from povh3d.errors import Povh3dWarning
from povh3d.mesh import FORMATS
from povh3d.image.colour import linear_to_srgb, srgb_to_linear
from povh3d.mesh.load import to_pov_frame
from tests.support.mesh_oracles import parse_include, pov_single

FLIP = np.array([1.0, 1.0, -1.0])


def lumpy(seed: int = 0) -> trimesh.Trimesh:
    """An asymmetric closed mesh with awkward coordinates (not short decimals)."""
    rng = np.random.default_rng(seed)
    m = trimesh.creation.icosphere(subdivisions=2, radius=7.3)
    v = m.vertices * (1 + 0.1 * rng.random((len(m.vertices), 1))) + [1.7, -0.3, 2.9]
    return trimesh.Trimesh(v, m.faces, process=False)


def export(mesh_or_scene, folder, name: str):
    """Write with trimesh; glTF returns several files."""
    path = folder / name
    ext = path.suffix.lower()[1:]
    if name.endswith(".ascii.stl"):
        path.write_bytes(trimesh.exchange.stl.export_stl_ascii(mesh_or_scene).encode())
    elif ext == "gltf":
        for fname, data in trimesh.Scene(mesh_or_scene).export(file_type="gltf").items():
            (folder / fname).write_bytes(data)
        (folder / "model.gltf").rename(path)
    else:
        data = (trimesh.Scene(mesh_or_scene).export(file_type=ext) if ext in ("glb", "3mf")
                else mesh_or_scene.export(file_type=ext))
        path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def trimesh_corners(path, unit_mm: float) -> np.ndarray:
    """``(m, 3, 3)`` triangle corners as trimesh reads the file, in POV's frame (by hand)."""
    scene = trimesh.load(str(path), force="scene", process=False)
    tris = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        g = scene.geometry[name]
        v = trimesh.transform_points(g.vertices, transform) if not np.allclose(transform, np.eye(4)) else g.vertices
        corners = (v * FLIP * unit_mm)[g.faces]
        mirrored = np.linalg.det(np.asarray(transform)[:3, :3]) < 0  # a mirroring node turns the winding too
        tris.append(corners if mirrored else corners[:, [0, 2, 1]])
    return np.concatenate(tris)


def written_corners(parsed) -> np.ndarray:
    return np.concatenate([p["vertex_vectors"][p["faces"]] for p in parsed["parts"]])


NAMES = {".obj": "m.obj", ".stl": "m.stl", ".ply": "m.ply", ".off": "m.off", ".glb": "m.glb",
         ".gltf": "m.gltf", ".3mf": "m.3mf"}


def test_every_registered_format_has_a_round_trip_case():
    assert set(NAMES) == set(FORMATS)


@pytest.mark.parametrize("name", [*NAMES.values(), "m.ascii.stl"])
def test_round_trip_geometry_exact(tmp_path, name):
    path = export(lumpy(), tmp_path, name)
    out = tmp_path / "m.inc"
    result = convert_mesh(path, out, unit="mm", up="y")   # the loader's own frame (3MF is z up by default)
    parsed = parse_include(out.read_text())
    got = written_corners(parsed)
    expected = trimesh_corners(path, 1.0)
    assert got.shape == expected.shape
    np.testing.assert_array_equal(got, pov_single(expected) + 0.0)
    allv = np.concatenate([p["vertex_vectors"] for p in parsed["parts"]])
    np.testing.assert_array_equal(pov_single(parsed["min"]), allv.min(axis=0))
    np.testing.assert_array_equal(pov_single(parsed["max"]), allv.max(axis=0))
    assert result.triangles == len(expected) and result.warnings == []


def test_units_scale_exactly(tmp_path):
    path = export(lumpy(), tmp_path, "m.ply")
    for unit, mm in (("cm", 10.0), ("in", 25.4), ("m", 1000.0)):
        convert_mesh(path, tmp_path / "m.inc", unit=unit)
        got = written_corners(parse_include((tmp_path / "m.inc").read_text()))
        np.testing.assert_array_equal(got, pov_single(trimesh_corners(path, mm)))


def test_gltf_defaults_to_metres(tmp_path):
    path = export(lumpy(), tmp_path, "m.glb")
    convert_mesh(path, tmp_path / "m.inc")
    got = written_corners(parse_include((tmp_path / "m.inc").read_text()))
    np.testing.assert_array_equal(got, pov_single(trimesh_corners(path, 1000.0)))


def test_file_normals_and_winding(tmp_path):
    mesh = lumpy()
    obj = tmp_path / "n.obj"
    obj.write_text(trimesh.exchange.obj.export_obj(mesh, include_normals=True))
    convert_mesh(obj, tmp_path / "n.inc", shading="smooth")
    part = parse_include((tmp_path / "n.inc").read_text())["parts"][0]
    loaded = trimesh.load(str(obj), process=False)
    np.testing.assert_array_equal(part["normal_vectors"], pov_single(loaded.vertex_normals * FLIP + 0.0))
    # Outward: geometric normals of the written faces agree with the vertex normals,
    # and the closed surface encloses a positive volume (divergence theorem).
    v, f = part["vertex_vectors"], part["faces"]
    geo = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    assert (np.einsum("ij,ij->i", geo, part["normal_vectors"][f].mean(axis=1)) > 0).all()
    volume = np.einsum("ij,ij->i", v[f[:, 0]], geo).sum() / 6
    assert volume > 0
    # Negative control: without the winding swap the volume is negative.
    assert np.einsum("ij,ij->i", v[f[:, 0]], -geo).sum() < 0


def test_computed_normals_point_outward(tmp_path):
    path = export(trimesh.creation.icosphere(3, radius=5.0), tmp_path, "s.ply")
    convert_mesh(path, tmp_path / "s.inc")
    part = parse_include((tmp_path / "s.inc").read_text())["parts"][0]
    radial = part["vertex_vectors"] / np.linalg.norm(part["vertex_vectors"], axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", radial, part["normal_vectors"]).min() > 0.99
    np.testing.assert_allclose(np.linalg.norm(part["normal_vectors"], axis=1), 1.0, atol=1e-7)


def test_stl_is_flat_by_default_and_merged(tmp_path):
    path = export(trimesh.creation.box((2.0, 3.0, 4.0)), tmp_path, "b.stl")
    convert_mesh(path, tmp_path / "b.inc")
    part = parse_include((tmp_path / "b.inc").read_text())["parts"][0]
    assert "normal_vectors" not in part and len(part["vertex_vectors"]) == 8
    convert_mesh(path, tmp_path / "b.inc", shading="smooth")
    assert "normal_vectors" in parse_include((tmp_path / "b.inc").read_text())["parts"][0]


def _srgb_back(values) -> np.ndarray:
    """The 8-bit sRGB codes of linear colours (the include holds them decoded, as rgb)."""
    return np.rint(linear_to_srgb(np.asarray(values)) * 255).astype(int)


def test_vertex_colours_exact(tmp_path):
    mesh = lumpy()
    rng = np.random.default_rng(1)
    colours = rng.integers(1, 256, size=(len(mesh.vertices), 4)).astype(np.uint8)
    colours[:, 3] = 255
    mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=colours)
    path = export(mesh, tmp_path, "c.ply")
    convert_mesh(path, tmp_path / "c.inc")
    part = parse_include((tmp_path / "c.inc").read_text())["parts"][0]
    table = np.array([v for _, v in part["texture_list"]])
    assert {k for k, _ in part["texture_list"]} == {"rgb"}
    per_corner = _srgb_back(table)[part["face_textures"]]  # (m, 3, 3)
    loaded = trimesh.load(str(path), process=False)
    expected = loaded.visual.vertex_colors[loaded.faces][:, [0, 2, 1], :3]
    np.testing.assert_array_equal(per_corner, expected)
    # The text holds the decoded c / 255 exactly (repr round-trips), not a rounded decimal.
    np.testing.assert_array_equal(table, srgb_to_linear(_srgb_back(table) / 255.0))


def test_face_colours_with_alpha(tmp_path):
    mesh = lumpy()
    rng = np.random.default_rng(2)
    colours = rng.integers(1, 256, size=(len(mesh.faces), 4)).astype(np.uint8)
    mesh.visual = trimesh.visual.ColorVisuals(mesh, face_colors=colours)
    path = export(mesh, tmp_path, "f.ply")
    convert_mesh(path, tmp_path / "f.inc")
    part = parse_include((tmp_path / "f.inc").read_text())["parts"][0]
    assert {k for k, _ in part["texture_list"]} == {"rgbt"}
    table = np.array([v for _, v in part["texture_list"]])
    rgba = np.column_stack([_srgb_back(table[:, :3]), 255 - np.rint(table[:, 3] * 255).astype(int)])
    np.testing.assert_array_equal(rgba[part["face_textures"][:, 0]], colours)


def test_uv_texture_and_base_colour(tmp_path):
    mesh = lumpy()
    uv = np.random.default_rng(3).random((len(mesh.vertices), 2))
    image = Image.fromarray(np.random.default_rng(4).integers(0, 256, (8, 12, 3), dtype=np.uint8))
    material = trimesh.visual.material.SimpleMaterial(image=image, diffuse=[200, 100, 50, 255])
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    obj = tmp_path / "t.obj"
    files = {}
    text = trimesh.exchange.obj.export_obj(mesh, return_texture=True, mtl_name="t.mtl")
    text, files = text if isinstance(text, tuple) else (text, {})
    obj.write_text(text)
    for fname, data in files.items():
        (tmp_path / fname).write_bytes(data)
    result = convert_mesh(obj, tmp_path / "out.inc", name="Textured")
    parsed = parse_include((tmp_path / "out.inc").read_text())
    part = parsed["parts"][0]
    loaded = trimesh.load(str(obj), process=False)
    np.testing.assert_array_equal(part["uv_vectors"], loaded.visual.uv)
    assert part["image"] == "Textured_0.png" and result.textures == [tmp_path / "Textured_0.png"]
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "Textured_0.png")), np.asarray(image))

    # The same model with its texture file gone: a warning, the MTL's base colour.
    for fname in files:
        if fname.endswith(".png"):
            (tmp_path / fname).unlink()
    with pytest.warns(Povh3dWarning, match="missing; rendering with the base colour"):
        result = convert_mesh(obj, tmp_path / "gone.inc")
    part = parse_include((tmp_path / "gone.inc").read_text())["parts"][0]
    assert "uv_vectors" not in part and "image" not in part
    kind, value = part["base"]
    assert kind == "rgb" and _srgb_back(value).tolist() == loaded.visual.material.main_color[:3].tolist()
    assert any("missing" in w and "base colour" in w for w in result.warnings)


def test_multi_object_scene_is_a_union_with_transforms(tmp_path):
    scene = trimesh.Scene()
    T = trimesh.transformations
    scene.add_geometry(trimesh.creation.box((1.0, 2.0, 3.0)), node_name="a", geom_name="a",
                       transform=T.translation_matrix([0.5, 0, 0]) @ T.rotation_matrix(0.3, [0, 1, 0]))
    scene.add_geometry(lumpy(), node_name="b", geom_name="b", transform=T.scale_matrix(-1.0))  # a mirroring node
    path = tmp_path / "s.glb"
    path.write_bytes(scene.export(file_type="glb"))
    convert_mesh(path, tmp_path / "s.inc", unit="mm")
    text = (tmp_path / "s.inc").read_text()
    parsed = parse_include(text)
    assert "union {" in text and len(parsed["parts"]) == 2
    # Transforms applied (rotation, translation, a mirroring scale); float sums in another order: allclose.
    np.testing.assert_array_equal(written_corners(parsed), pov_single(trimesh_corners(path, 1.0)))
    lo, hi = parsed["min"], parsed["max"]
    bounds = trimesh.load(str(path), force="scene").bounds
    np.testing.assert_allclose(lo, [bounds[0][0], bounds[0][1], -bounds[1][2]], atol=1e-6)
    np.testing.assert_allclose(hi, [bounds[1][0], bounds[1][1], -bounds[0][2]], atol=1e-6)
    # The mirroring node keeps faces outward: positive volume for the lumpy part.
    for part in parsed["parts"]:
        v, f = part["vertex_vectors"], part["faces"]
        geo = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        assert np.einsum("ij,ij->i", v[f[:, 0]], geo).sum() > 0


def test_fit_depth_and_center(tmp_path):
    path = export(lumpy(), tmp_path, "m.ply")
    convert_mesh(path, tmp_path / "m.inc", fit_depth=6.0, center=True)
    parsed = parse_include((tmp_path / "m.inc").read_text())
    np.testing.assert_allclose(parsed["max"][2] - parsed["min"][2], 6.0, rtol=1e-12)
    np.testing.assert_allclose(parsed["max"] + parsed["min"], 0.0, atol=1e-12)


def test_to_pov_frame_is_a_reflection_of_z_only():
    v = np.array([[1.0, 2.0, 3.0]])
    out, f, n = to_pov_frame(v, np.array([[0, 1, 2]]), v, 2.0)
    assert out.tolist() == [[2.0, 4.0, -6.0]] and f.tolist() == [[0, 2, 1]] and n.tolist() == [[1.0, 2.0, -3.0]]
