"""The mask copy of a converted include (``scene.part_ids``): each ``mesh2`` painted its own id
wherever it names a texture, the rest of the text kept byte for byte."""

from __future__ import annotations

import re

import numpy as np
import pytest

from povh3d.mesh.load import Part
from povh3d.mesh.write import include_text, mesh2_text
from povh3d.scene.object_ids import ObjectsError, id_colour
from povh3d.scene.part_ids import id_texture, part_ids_include, part_table

TETRA = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def include(parts: list[Part]) -> str:
    blocks = [mesh2_text(p, smooth=False, normals=None, texture_file=f"M_{i}.png" if p.uv is not None else None,
                         ident="M") for i, p in enumerate(parts)]
    return include_text(blocks, "M", (TETRA.min(0), TETRA.max(0)), source="m.obj", summary="test")


def test_every_texture_of_a_part_becomes_its_id() -> None:
    colours = np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [255, 0, 0, 255]], np.uint8)
    parts = [Part("plain {x}", TETRA, FACES), Part("faces", TETRA + 2, FACES, face_colors=colours),
             Part("verts", TETRA - 2, FACES, vertex_colors=colours),
             Part("image", TETRA * 2, FACES, uv=TETRA[:, :2], texture=np.zeros((2, 2, 3), np.uint8))]
    text = include(parts)
    assert "image_map" in text
    masked = part_ids_include(text, 4)
    assert "image_map" not in masked and "uv_vectors" in masked     # the UVs stay, unused
    blocks = masked.split("mesh2 {")[1:]
    assert len(blocks) == 4
    for ident, block in enumerate(blocks, start=1):
        textures = re.findall(r"texture \{[^\n]*", block)
        assert textures and all(t.startswith(id_texture(ident)) for t in textures), block
    assert masked.count(id_texture(2)) == 3          # the texture_list of three colours, each one the id
    assert "Povh3d_Mesh_Finish }" not in masked.split("#declare M =")[1]
    # everything but the textures is kept: vertices, faces with their texture indices
    strip = lambda s: re.sub(r"(?m)^.*\btexture \{.*$", "T", s)  # noqa: E731  (the writer: one a line)
    assert strip(masked) == strip(text)
    assert id_colour(3) in blocks[2]


def test_a_part_without_texture_gets_its_id() -> None:
    text = "#declare M = union {\nmesh2 { vertex_vectors { 3, <0,0,0>, <1,0,0>, <0,1,0> }\n" \
           "face_indices { 1, <0, 1, 2> } }\n}\n"
    masked = part_ids_include(text, 1)
    assert id_texture(1) in masked and masked.count("texture") == 1


def test_an_include_of_other_parts_is_refused() -> None:
    text = include([Part("a", TETRA, FACES)])
    with pytest.raises(ObjectsError, match="1 mesh2 parts, not the 2"):
        part_ids_include(text, 2)


def test_part_names_are_unique_and_never_empty() -> None:
    assert part_table(["box", "box", "", "a\nb", "box"]) == {1: "box", 2: "box (2)", 3: "part 3", 4: "a b",
                                                             5: "box (3)"}
