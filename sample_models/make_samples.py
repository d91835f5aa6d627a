"""Make the bundled sample models, without downloading anything.

    .venv/bin/python sample_models/make_samples.py [--out sample_models]

Writes, in millimetres, in the usual right-handed, y-up model frame:

- ``letter_l.stl``   binary STL, an extruded capital L (asymmetric: a mirrored
                     render is obvious), no colour
- ``letter_f.obj``   OBJ with ``letter_f.mtl`` and the texture ``letter_f.png``:
                     an extruded F, its front face UV-mapped to the image
- ``blob.ply``       PLY with per-vertex colours: a lumpy sphere
- ``still_life.glb`` binary glTF with three objects (box, sphere, cylinder),
                     each with its own node transform and base colour

The files are committed; re-running this script reproduces them byte for byte.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image

HERE = Path(__file__).resolve().parent


def extrude_rectilinear(outline: list[tuple[float, float]], rects: list[tuple[float, float, float, float]],
                        depth: float) -> tuple[np.ndarray, np.ndarray]:
    """A closed prism from a counter-clockwise outline and a cover of its area by rectangles.

    Returns vertices ``(n, 3)`` and faces ``(m, 3)``, front cap at ``z = +depth/2``
    (toward the model's viewer), outward winding.
    """
    verts: list[tuple[float, float, float]] = []
    faces: list[tuple[int, int, int]] = []
    h = depth / 2

    def quad(a, b, c, d):  # counter-clockwise seen from outside
        i = len(verts)
        verts.extend([a, b, c, d])
        faces.extend([(i, i + 1, i + 2), (i, i + 2, i + 3)])

    for x0, y0, x1, y1 in rects:
        quad((x0, y0, h), (x1, y0, h), (x1, y1, h), (x0, y1, h))      # front, faces +z
        quad((x0, y0, -h), (x0, y1, -h), (x1, y1, -h), (x1, y0, -h))  # back, faces -z
    for (xa, ya), (xb, yb) in zip(outline, outline[1:] + outline[:1]):
        quad((xa, ya, -h), (xb, yb, -h), (xb, yb, h), (xa, ya, h))    # side, outward for a CCW outline
    return np.array(verts, dtype=np.float64), np.array(faces, dtype=np.int64)


def letter_l() -> trimesh.Trimesh:
    outline = [(0, 0), (14, 0), (14, 4), (4, 4), (4, 20), (0, 20)]
    rects = [(0, 0, 14, 4), (0, 4, 4, 20)]
    v, f = extrude_rectilinear(outline, rects, 4.0)
    return trimesh.Trimesh(v - [7, 10, 0], f, process=False)


def letter_f() -> tuple[np.ndarray, np.ndarray]:
    outline = [(0, 0), (4, 0), (4, 8), (11, 8), (11, 12), (4, 12), (4, 16), (14, 16), (14, 20), (0, 20)]
    rects = [(0, 0, 4, 20), (4, 8, 11, 12), (4, 16, 14, 20)]
    v, f = extrude_rectilinear(outline, rects, 4.0)
    return v - [7, 10, 0], f


def texture_image(size: int = 64) -> np.ndarray:
    """An orange-blue checker with a white bar across the top: up and down are easy to tell."""
    j, i = np.meshgrid(np.arange(size), np.arange(size))
    checker = ((i // 8 + j // 8) % 2).astype(bool)
    img = np.where(checker[..., None], [230, 120, 30], [40, 80, 200]).astype(np.uint8)
    img[: size // 8] = 255
    return img


def write_obj(out: Path) -> None:
    v, f = letter_f()
    uv = (v[:, :2] - v[:, :2].min(axis=0)) / np.ptp(v[:, :2], axis=0)  # planar map of x, y
    lines = ["# letter F, mm, y up; made by sample_models/make_samples.py", "mtllib letter_f.mtl", "o letter_f"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()]
    lines += [f"vt {s!r} {t!r}" for s, t in uv.tolist()]
    lines.append("usemtl checker")
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in f.tolist()]
    (out / "letter_f.obj").write_text("\n".join(lines) + "\n")
    (out / "letter_f.mtl").write_text("newmtl checker\nKa 0 0 0\nKd 0.8 0.8 0.8\nKs 0 0 0\nmap_Kd letter_f.png\n")
    Image.fromarray(texture_image()).save(out / "letter_f.png", optimize=True)


def blob() -> trimesh.Trimesh:
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=10.0)
    v = sphere.vertices
    bump = 1 + 0.12 * np.sin(3 * v[:, 0] / 10 * np.pi) * np.cos(2 * v[:, 1] / 10 * np.pi)
    v = v * bump[:, None]
    colours = np.column_stack([(v - v.min(0)) / np.ptp(v, axis=0) * 255, np.full(len(v), 255)])
    return trimesh.Trimesh(v, sphere.faces, vertex_colors=colours.round().astype(np.uint8), process=False)


def still_life() -> trimesh.Scene:
    def coloured(mesh: trimesh.Trimesh, rgba) -> trimesh.Trimesh:
        mesh.visual = trimesh.visual.TextureVisuals(
            material=trimesh.visual.material.PBRMaterial(baseColorFactor=rgba))
        return mesh

    scene = trimesh.Scene()
    T = trimesh.transformations
    # glTF is in metres: a 16 mm box is 0.016.
    scene.add_geometry(coloured(trimesh.creation.box((0.016, 0.016, 0.016)), [200, 60, 40, 255]),
                       node_name="box", geom_name="box",
                       transform=T.translation_matrix([-0.012, -0.004, 0]) @ T.rotation_matrix(0.5, [0, 1, 0]))
    scene.add_geometry(coloured(trimesh.creation.icosphere(3, radius=0.008), [60, 160, 80, 255]),
                       node_name="sphere", geom_name="sphere", transform=T.translation_matrix([0.012, 0.006, 0.004]))
    scene.add_geometry(coloured(trimesh.creation.cylinder(0.004, 0.02, sections=24), [60, 90, 200, 255]),
                       node_name="cylinder", geom_name="cylinder",
                       transform=T.translation_matrix([0.004, -0.008, -0.006]) @ T.rotation_matrix(np.pi / 2, [0, 0, 1]))
    return scene


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE)
    out = parser.parse_args(argv).out
    out.mkdir(parents=True, exist_ok=True)
    letter_l().export(out / "letter_l.stl", file_type="stl")
    write_obj(out)
    blob().export(out / "blob.ply", file_type="ply", encoding="ascii")
    still_life().export(out / "still_life.glb", file_type="glb")
    for name in ("letter_l.stl", "letter_f.obj", "letter_f.mtl", "letter_f.png", "blob.ply", "still_life.glb"):
        print(out / name, (out / name).stat().st_size, "bytes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
