"""``render --objects`` of a converted model and of a label volume: every part (an OBJ group, a
glTF node, a 3MF object) and every label its own id, named after it, against the parts' own
geometry along each pixel's conventions ray.

The oracle places the parts itself: a model is turned into POV-Ray's frame (``z`` negated), its
box centred on the origin and scaled by the largest factor that keeps it within 90 % of the
panel's width and height (the default stage); a label block of voxels ``a..b`` is bounded by the
voxel faces ``a - 1/2 .. b + 1/2`` (SurfaceNets without smoothing), carried by the volume's
placement onto the display."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from povh3d.display.display import Display
from povh3d.renderer.passes.object_masks import render_objects
from povh3d.renderer.outputs.objects import read_mask, read_table
from povh3d.renderer.request import ModelOptions, RenderRequest, VolumeOptions
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.interleave import interleave
from tests.support.id_oracle import expected_ids

ARRAY = LensArray("square", 24, 18, 0.4, 0.4, 1.5, Panel(96, 72, 0.1, 0.1))
SETTINGS = RenderSettings(quality="draft", use_cache=False)
# model units, right-handed, +y up, the viewer on +z: a wall behind, a box in front of it, one beside
BOXES = {"wall": ((-5.0, -3.0, -3.0), (3.0, 3.0, -1.0)),
         "front": ((-1.0, -1.0, 1.0), (4.0, 2.0, 3.0)),
         "side": ((3.5, -4.0, -1.0), (5.0, 0.0, 1.0))}


def parts_model(folder: Path, kind: str) -> Path:
    """The three boxes as separate parts of one file: OBJ groups (``g``), glTF nodes, 3MF objects."""
    import trimesh

    scene = trimesh.Scene()
    for name, bounds in BOXES.items():
        box = trimesh.creation.box(bounds=bounds)
        # colours (kept by the glb: a texture list per face colour, a translucent rgbt) must not hide the ids
        if name == "wall":
            box.visual.face_colors = np.tile([[255, 0, 0, 255], [0, 255, 0, 255]], (6, 1))
        elif name == "front":
            box.visual.vertex_colors = np.tile([[0, 0, 255, 100]], (8, 1))
        scene.add_geometry(box, node_name=name, geom_name=name)
    path = folder / f"parts.{kind}"
    scene.export(path)
    if kind == "obj":   # trimesh writes objects (o); the groups of most exporters are g
        text = path.read_text()
        assert text.count("\no ") == 3
        path.write_text(text.replace("\no ", "\ng "))
    return path


def model_shapes(names: dict[int, str]) -> list:
    """The boxes on the display, in id order: POV-Ray's frame, centred, scaled to 90 % of the panel."""
    pov = {n: (np.array([lo[0], lo[1], -hi[2]]), np.array([hi[0], hi[1], -lo[2]])) for n, (lo, hi) in BOXES.items()}
    lo = np.min([a for a, _ in pov.values()], axis=0)
    hi = np.max([b for _, b in pov.values()], axis=0)
    width, height = ARRAY.panel.size_mm
    scale = min(0.9 * width / (hi - lo)[0], 0.9 * height / (hi - lo)[1])
    centre = (lo + hi) / 2
    return [("box", (pov[names[i]][0] - centre) * scale, (pov[names[i]][1] - centre) * scale)
            for i in sorted(names)]


def h3d_ids(folder: Path) -> tuple[dict[int, str], np.ndarray]:
    """The table's names and the masks of the still's views interleaved into the panel's pixels."""
    table = read_table(folder)
    ny, nx = table.views
    stack = np.stack([[read_mask(folder, table, 0, (l, k)) for k in range(nx)] for l in range(ny)])
    return table.names, interleave(stack[..., None])[..., 0]


def score(got: np.ndarray, shapes: list) -> float:
    want, clear = expected_ids(ARRAY, shapes)
    assert clear.mean() > 0.5 and set(np.unique(want[clear])) == set(range(len(shapes) + 1))
    return float((got[clear] == want[clear]).mean())


@pytest.mark.povray
@pytest.mark.parametrize("kind", ["obj", "glb", "3mf"])
def test_model_parts_are_their_own_ids(tmp_path: Path, monkeypatch, kind: str) -> None:
    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    model = parts_model(tmp_path, kind)
    request = RenderRequest(model, Display(ARRAY), tmp_path / "m.png", settings=SETTINGS, model=ModelOptions(up="y"))
    report = render_objects(request, tmp_path / "objs")
    names, got = h3d_ids(tmp_path / "objs")
    assert sorted(names.values()) == sorted(BOXES) and report["unresolved"] == 0
    share = score(got, model_shapes(names))
    assert share >= 0.995, f"{kind}: {100 * share:.2f} % of clear pixels right"
    # negative control: the oracle tells the names of the wall and the front box swapped
    swapped = {i: {"wall": "front", "front": "wall"}.get(n, n) for i, n in names.items()}
    assert score(got, model_shapes(swapped)) < 0.8
    print(f"{kind}: {100 * share:.3f} % of clear pixels right")


def label_volume(folder: Path) -> Path:
    """Two labelled blocks, the nearer one partly in front of the other, with a Slicer label table."""
    import nrrd

    values = np.zeros((40, 30, 24), np.uint8)
    values[6:30, 4:26, 12:20] = 3
    values[18:36, 10:20, 4:10] = 5
    path = folder / "blocks.nrrd"
    header = {"space": "left-posterior-superior", "space directions": np.diag([1.0, 1.0, 1.0]),
              "space origin": np.zeros(3), "Segment0_LabelValue": "3", "Segment0_Name": "liver",
              "Segment1_LabelValue": "5", "Segment1_Name": "kidney"}
    nrrd.write(str(path), values, header)
    return path


@pytest.mark.povray
def test_volume_labels_are_their_own_ids_named_from_the_label_table(tmp_path: Path, monkeypatch) -> None:
    from povh3d.renderer.content.volume import place_volume
    from povh3d.volume.read import read_volume

    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    path = label_volume(tmp_path)
    request = RenderRequest(path, Display(ARRAY), tmp_path / "v.png", settings=SETTINGS,
                            volume=VolumeOptions(labels="all", smoothing=0))
    report = render_objects(request, tmp_path / "objs")
    names, got = h3d_ids(tmp_path / "objs")
    assert names == {1: "liver", 2: "kidney"} and report["unresolved"] == 0
    volume = read_volume(path)
    to_display = place_volume(volume, ARRAY, "coronal")[2] @ volume.index_to_world()
    blocks = {"liver": ((6, 4, 12), (29, 25, 19)), "kidney": ((18, 10, 4), (35, 19, 9))}

    def shapes(table: dict[int, str]) -> list:
        out = []
        for i in sorted(table):
            a, b = np.array(blocks[table[i]][0]) - 0.5, np.array(blocks[table[i]][1]) + 0.5
            corners = np.array([[x, y, z, 1.0] for x in (a[0], b[0]) for y in (a[1], b[1]) for z in (a[2], b[2])])
            placed = corners @ to_display.T
            out.append(("box", placed[:, :3].min(axis=0), placed[:, :3].max(axis=0)))
        return out

    share = score(got, shapes(names))
    assert share >= 0.995, f"{100 * share:.2f} % of clear pixels right"
    assert score(got, shapes({1: "kidney", 2: "liver"})) < 0.8     # negative control: names swapped
    print(f"labels: {100 * share:.3f} % of clear pixels right")


def test_a_volume_drawn_as_a_medium_is_refused_in_one_line(tmp_path: Path) -> None:
    from tests.support.cli import run_in_process

    path = label_volume(tmp_path)
    run = run_in_process("render", path, "--volume", "--lenses", "24x18", "--ppl", "4", "--pixel-pitch", "0.1",
                         "--focal", "1.5", "-o", tmp_path / "v.png", "--objects", tmp_path / "o")
    assert run.code != 0 and "medium (--volume)" in run.err and run.err.count("\n") == 1, run.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocks.nrrd"]
