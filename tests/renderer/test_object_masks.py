"""``render --objects DIR`` end to end on the bundled sample: masks, their header, the page,
and a scene whose objects cannot be told apart as one line before any render."""

from __future__ import annotations

from pathlib import Path

from dataclasses import replace

import numpy as np
import pytest

from povh3d.renderer.outputs.objects import read_mask, read_table
from povh3d.scene.object_ids import UNRESOLVED
from tests.support.cli import run_in_process

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.povray
def test_sample_masks_annotate_and_view(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    run = run_in_process("render", ROOT / "sample_models" / "sample.pov", "--preset", "demo", "--quality", "draft",
                         "-o", tmp_path / "s.png", "--objects", tmp_path / "objs")
    assert run.code == 0, run.err
    table = read_table(tmp_path / "objs")
    assert table.names == {1: "plane_17", 2: "sphere_21", 3: "cylinder_27", 4: "torus_33", 5: "box_37"}
    from povh3d.image.io import read_sidecar

    assert read_sidecar(tmp_path / "s.png")["objects"]["names"]["4"] == "torus_33"   # and the image's hash holds
    centre = read_mask(tmp_path / "objs", table, 0, (3, 3))
    assert set(np.unique(centre)) == {1, 2, 3, 4, 5} and not (centre == UNRESOLVED).any()
    # the torus (7, 5, -3) mm sits upper right of the centre view, the box (-5, -7, -3) lower left
    rows, cols = np.nonzero(centre == 4)
    assert rows.mean() < 15 and cols.mean() > 20      # a 40x30 view: row 15, column 20 at its middle
    rows, cols = np.nonzero(centre == 5)
    assert rows.mean() > 15 and cols.mean() < 20
    (tmp_path / "links.toml").write_text('[torus_33]\nurl = "https://example.org/torus"\n')
    assert run_in_process("annotate", tmp_path / "s.png", "--objects", tmp_path / "objs", "-o", tmp_path / "s.xml",
                          "--links", tmp_path / "links.toml").code == 0
    assert b'url="https://example.org/torus"' in (tmp_path / "s.xml").read_bytes()
    assert run_in_process("viewer", tmp_path / "s.png", "--cdp", tmp_path / "s.xml", "--objects", tmp_path / "objs",
                          "-o", tmp_path / "s.html").code == 0
    # the Python API's objects= writes the same masks as the command
    import povh3d

    record = povh3d.render(ROOT / "sample_models" / "sample.pov", tmp_path / "api.png", preset="demo",
                           quality="draft", objects=tmp_path / "api_objs")
    assert record["object_masks"]["objects"] == 5 and record["object_masks"]["unresolved"] == 0
    assert replace(read_table(tmp_path / "api_objs"), render_id="") == replace(table, render_id="")  # each render its own id
    ny, nx = table.views
    for l in range(ny):
        for k in range(nx):
            api, command = (read_mask(tmp_path / name, table, 0, (l, k)) for name in ("api_objs", "objs"))
            assert (api == command).all()
    names = read_sidecar(tmp_path / "s.png")["objects"]["names"]
    assert read_sidecar(tmp_path / "api.png")["objects"]["names"] == names


def test_scene_without_separable_objects_is_one_line_before_any_render(tmp_path: Path) -> None:
    scene = tmp_path / "macro.pov"
    scene.write_text("#macro M() sphere { 0, 1 } #end\nM()\nlight_source { <0, 0, -9> rgb 1 }\n")
    run = run_in_process("render", scene, "--preset", "demo", "-o", tmp_path / "m.png", "--objects", tmp_path / "o")
    assert run.code != 0 and "no top-level object statements" in run.err and run.err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["macro.pov"]


ANIMATION = """#version 3.7;
global_settings { assumed_gamma 1.0 }
light_source { <-20, 30, -60> rgb 1 }
sphere { <-8 + 16 * clock, 3, 2>, 3 pigment { rgb <1, 0, 0> } }
box { <-3, -9, -2>, <3, -5, 2> pigment { rgb <0, 0, 1> }
  #if (clock > 0.3 & clock < 0.7) translate 200 * x #end }
"""


@pytest.mark.povray
def test_animation_masks_give_a_new_annotation_when_an_object_comes_back(tmp_path: Path, monkeypatch) -> None:
    from povh3d.commands.annotate import build_header

    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    (tmp_path / "a.pov").write_text(ANIMATION)
    run = run_in_process("render", tmp_path / "a.pov", "--preset", "demo", "--quality", "draft", "-o",
                         tmp_path / "a.png", "--frames", "0:4", "--objects", tmp_path / "objs")
    assert run.code == 0, run.err
    from povh3d.image.io import read_sidecar

    assert read_sidecar(tmp_path / "a_0002.png")["objects"]["names"] == {"1": "sphere_4", "2": "box_5"}
    header = build_header(tmp_path / "a.png", tmp_path / "objs")
    spans = [(a.object_name, a.start, a.end) for a in header.scenes[0].annotations]
    assert spans == [("box_5", 0, 1), ("sphere_4", 0, 4), ("box_5", 3, 4)]   # the box is away at clock 0.5
    sphere = header.scenes[0].annotations[1]
    lefts = [b.box[0] for b in sphere.boxes if b.space == "view"]
    assert lefts == sorted(lefts) and lefts[-1] - lefts[0] >= 15     # 16 mm right over 40 lenses of 0.8 mm
    assert {b.space for b in sphere.boxes} == {"view", "h3d"}


@pytest.mark.povray
def test_hex_masks_hold_every_panel_pixel_and_views_never_blended(tmp_path: Path, monkeypatch) -> None:
    # the panel mask: each pixel's own ray (the lens mesh's, as in the colour pass); the views: each
    # view pixel the id of the lens pixel nearest the view's point, scored against the view's own ray
    from povh3d.display.display import Display
    from povh3d.image.io import read_sidecar
    from tests.support.id_oracle import SCENE, SHAPES, expected_ids, expected_view_ids

    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    (tmp_path / "s.pov").write_text(SCENE)
    run = run_in_process("render", tmp_path / "s.pov", "--grid", "hex", "--lenses", "30x20", "--ppl", "6",
                         "--pixel-pitch", "0.1", "--focal", "1.5", "--quality", "draft", "-o", tmp_path / "h.png",
                         "--objects", tmp_path / "o")
    assert run.code == 0, run.err
    lens_array = Display.from_record(read_sidecar(tmp_path / "h.png")).lens_array
    table = read_table(tmp_path / "o")
    assert table.panel == (lens_array.panel.height, lens_array.panel.width) and len(table.names) == 3
    panel = read_mask(tmp_path / "o", table, 0, None)
    want, clear = expected_ids(lens_array, SHAPES)
    assert clear.mean() > 0.5 and set(np.unique(want[clear])) == {0, 1, 2, 3}
    share = (panel[clear] == want[clear]).mean()
    assert share >= 0.995, f"{100 * share:.2f} % of the panel's clear pixels right"
    ny, nx = table.views
    views = np.stack([[read_mask(tmp_path / "o", table, 0, (l, k)) for k in range(nx)] for l in range(ny)])
    want, clear = expected_view_ids(lens_array, table.views, SHAPES)
    # a view whose point lies outside the hex cell (its corners) has no ray of the lens: it reads the
    # nearest pixel, as the colour views do, and is not scored
    px, py = lens_array.pitch_x, lens_array.pitch_y
    u = (np.arange(nx) + 0.5 - nx / 2) * lens_array.panel.pitch_x
    v = (ny / 2 - np.arange(ny) - 0.5) * lens_array.panel.pitch_y
    offsets = np.stack(np.broadcast_arrays(u[None, :], v[:, None]), axis=-1)
    neighbours = np.array([[px, 0], [-px, 0], [px / 2, py], [-px / 2, py], [px / 2, -py], [-px / 2, -py]])
    in_cell = (np.linalg.norm(offsets, axis=-1)[..., None]
               < np.linalg.norm(offsets[..., None, :] - neighbours, axis=-1)).all(axis=-1)
    assert in_cell.sum() == ny * nx - 4
    clear &= in_cell[:, :, None, None]
    view_share = (views[clear] == want[clear]).mean()
    assert view_share >= 0.995, f"{100 * view_share:.2f} % of the views' clear pixels right"
    swapped = np.choose(want, [0, 2, 1, 3])    # negative control: the two spheres' ids swapped
    assert (swapped[clear & (want > 0)] == views[clear & (want > 0)]).mean() < 0.8
    print(f"hex: panel {100 * share:.3f} %, views {100 * view_share:.3f} % of clear pixels right")
    (tmp_path / "links.toml").write_text('[Ball]\nurl = "https://example.org/ball"\n')
    assert run_in_process("annotate", tmp_path / "h.png", "--objects", tmp_path / "o", "-o", tmp_path / "h.xml",
                          "--links", tmp_path / "links.toml").code == 0
    assert b'space="h3d"' in (tmp_path / "h.xml").read_bytes()    # the panel mask's boxes


def test_subpixel_masks_are_refused_before_any_render(tmp_path: Path) -> None:
    run = run_in_process("render", ROOT / "sample_models" / "sample.pov", "--preset", "demo", "--method", "subpixel",
                         "-o", tmp_path / "h.png", "--objects", tmp_path / "o")
    assert run.code != 0 and "own ray" in run.err and run.err.count("\n") == 1, run.err
    assert list(tmp_path.iterdir()) == []
    import povh3d

    with pytest.raises(povh3d.ConfigError, match="own ray"):     # the API refuses it the same way
        povh3d.render(ROOT / "sample_models" / "sample.pov", tmp_path / "h.png", method="subpixel",
                      objects=tmp_path / "o")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("grid", ["square", "lenticular"])
def test_view_masks_are_the_views_extract_cuts(grid: str) -> None:
    # mask_views copies extract's layout without its compiled gather: the same views, pixel for pixel
    from povh3d.renderer.passes.object_masks import mask_views
    from povh3d.geometry.lens_array import LensArray, Panel
    from povh3d.image.interleave import extract

    lens_array = {"square": LensArray("square", 40, 30, 0.8, 0.8, 1.5, Panel(324, 242, 0.1, 0.1)),
                  "lenticular": LensArray("lenticular", 40, 240, 0.8, 0.1, 1.5, Panel(320, 240, 0.1, 0.1))}[grid]
    ids = np.random.default_rng(3).integers(0, 1000, (242 if grid == "square" else 240, lens_array.panel.width),
                                            dtype=np.uint16)
    got = mask_views(ids, lens_array)
    want = extract(ids[lens_array.bank_region][..., None], lens_array.views)[..., 0]
    assert got.shape == want.shape == (*lens_array.views, lens_array.lenses_y, lens_array.lenses_x)
    assert (got == want).all()
    assert (got[0, 0] != got[0, 1]).mean() > 0.9    # the views differ: the comparison can fail


# An isosurface (a sphere's distance function, gradient 1) and a one-component blob (density
# s (1 - (d/r)^2)^2 = threshold t: a sphere of radius r sqrt(1 - sqrt(t/s))) beside a box, display mm
ISO = ((-6.0, 3.0, 4.0), 4.0)
BLOB = ((5.0, -3.0, -2.0), 3.0)
ISO_BOX = ((0.0, 2.0, -1.0), (9.0, 8.0, 3.0))
ISO_SCENE = f"""#version 3.7;
global_settings {{ assumed_gamma 1.0 }}
light_source {{ <-20, 30, -60> rgb 1 }}
isosurface {{ function {{ sqrt(x * x + y * y + z * z) - {ISO[1]} }} contained_by {{ box {{ -4.5, 4.5 }} }}
  max_gradient 1.1 translate <{ISO[0][0]}, {ISO[0][1]}, {ISO[0][2]}> pigment {{ rgb <0.2, 0.8, 0.3> }} }}
blob {{ threshold 0.25 sphere {{ <{BLOB[0][0]}, {BLOB[0][1]}, {BLOB[0][2]}>, {BLOB[1] / 0.5 ** 0.5!r}, 1 }}
  pigment {{ rgb <0.9, 0.6, 0.1> }} finish {{ phong 1 }} }}
box {{ <{ISO_BOX[0][0]}, {ISO_BOX[0][1]}, {ISO_BOX[0][2]}>, <{ISO_BOX[1][0]}, {ISO_BOX[1][1]}, {ISO_BOX[1][2]}>
  pigment {{ rgb <0.3, 0.3, 1> }} }}
"""


@pytest.mark.povray
@pytest.mark.parametrize("grid, lenses", [("square", ["--lenses", "40x30", "--ppl", "8"]),
                                          ("lenticular", ["--lenses", "40", "--rows", "240", "--ppl", "8"])])
def test_isosurface_and_blob_masks_match_their_analytic_projection_in_every_view(tmp_path: Path, monkeypatch,
                                                                                grid: str, lenses: list[str]) -> None:
    from povh3d.display.display import Display
    from povh3d.renderer.passes.object_masks import mask_views
    from povh3d.image.io import read_sidecar
    from tests.support.id_oracle import expected_ids

    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    (tmp_path / "iso.pov").write_text(ISO_SCENE)
    run = run_in_process("render", tmp_path / "iso.pov", "--grid", grid, *lenses, "--pixel-pitch", "0.1",
                         "--focal", "1.5", "--quality", "draft", "-o", tmp_path / "i.png", "--objects", tmp_path / "o")
    assert run.code == 0, run.err
    table = read_table(tmp_path / "o")
    assert table.names == {1: "isosurface_4", 2: "blob_6", 3: "box_8"}
    lens_array = Display.from_record(read_sidecar(tmp_path / "i.png")).lens_array
    ny, nx = table.views
    got = np.stack([[read_mask(tmp_path / "o", table, 0, (l, k)) for k in range(nx)] for l in range(ny)])
    shapes = [("sphere", *ISO), ("sphere", *BLOB), ("box", *ISO_BOX)]
    want, clear = (mask_views(a, lens_array) for a in expected_ids(lens_array, shapes))
    assert clear.mean() > 0.6 and set(np.unique(want[clear])) == {0, 1, 2, 3}
    worst = worst_view(got, want, clear)
    assert worst >= 0.995, f"a view with {100 * worst:.2f} % of its clear pixels right"
    # negative controls: the oracle fails masks whose isosurface, or blob, is 2 mm (2.5 lens pitches) off
    for moved_shapes in ([("sphere", (ISO[0][0] + 2.0, *ISO[0][1:]), ISO[1]), *shapes[1:]],
                         [shapes[0], ("sphere", (BLOB[0][0], BLOB[0][1] - 2.0, BLOB[0][2]), BLOB[1]), shapes[2]]):
        moved, moved_clear = (mask_views(a, lens_array) for a in expected_ids(lens_array, moved_shapes))
        assert worst_view(got, moved, clear & moved_clear) < 0.995
    print(f"{grid}: the worst view {100 * worst:.3f} % of its clear pixels right")


def worst_view(got: np.ndarray, want: np.ndarray, clear: np.ndarray) -> float:
    """The smallest share of a view's clear pixels whose id is right, over all the views."""
    return min((got[l, k][clear[l, k]] == want[l, k][clear[l, k]]).mean()
               for l in range(got.shape[0]) for k in range(got.shape[1]))


@pytest.mark.povray
def test_a_camera_scenes_masks_take_the_colour_pass_placement(tmp_path: Path, monkeypatch) -> None:
    """A scene with its own camera: the masks reuse the colour pass's frame and clearance (no camera or
    depth run again), and equal the masks placed again from the scene (the same rays)."""
    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    import povh3d
    from povh3d.renderer.passes import object_masks
    from povh3d.renderer.placement import place as placement

    scene = tmp_path / "cam.pov"
    scene.write_text("camera { location <3, 2, -40> look_at <0, 0, 0> }\n"
                     "light_source { <0, 20, -30> rgb 1 }\n"
                     "sphere { <-2, 1, 0>, 2.5 pigment { rgb 1 } }\n"
                     "box { <1, -3, -1>, <4, 0, 2> pigment { rgb <1, 0, 0> } }\n"
                     "plane { z, 6 pigment { rgb 0.5 } }\n")
    record = povh3d.render(scene, tmp_path / "c.png", preset="demo", quality="draft", use_cache=False)
    assert record["placement"]["source"] == "camera"
    from povh3d.display.display import build_display
    from povh3d.renderer.request import RenderRequest
    from povh3d.renderer.methods.quality import RenderSettings

    request = RenderRequest(source=scene, display=build_display("demo"), output=tmp_path / "c.png",
                            settings=RenderSettings(quality="draft", use_cache=False))
    placed = []
    real = placement.place_display
    monkeypatch.setattr(placement, "place_display", lambda r, s: placed.append(r.settings.pose) or real(r, s))
    reused = object_masks.render_objects(request, tmp_path / "reused", record)
    again = object_masks.render_objects(request, tmp_path / "again")
    assert placed[0] is not None and placed[1] is None   # the first took the recorded frame as its matrix
    table = read_table(tmp_path / "reused")
    assert replace(read_table(tmp_path / "again"), render_id="") == replace(table, render_id="") and reused["objects"] == again["objects"] == 3
    ny, nx = table.views
    for l in range(ny):
        for k in range(nx):
            a, b = (read_mask(tmp_path / name, table, 0, (l, k)) for name in ("reused", "again"))
            assert (a == b).all()
    # control: a frame moved by 1 mm gives other masks, so the equality above can fail
    shifted = dict(record, placement={**record["placement"],
                                          "centre": [c + 1.0 for c in record["placement"]["centre"]]})
    object_masks.render_objects(request, tmp_path / "moved", shifted)
    assert any((read_mask(tmp_path / "moved", table, 0, (l, k)) != read_mask(tmp_path / "again", table, 0, (l, k))).any()
               for l in range(ny) for k in range(nx))


# A bar as wide as image_width says (tests/renderer/test_ray_origins.py): each view's own run (16 pixels wide)
# builds it a quarter as wide as a run of the 64-pixel panel, so the default falls back to one run a view.
# Flat emission colours: the colour image's silhouettes are its channels (red the bar, green the sphere).
SIZED = """#version 3.7;
global_settings { assumed_gamma 1 }
background { rgb 0 }
box { <-8, -2, 0>, <-8 + image_width / 10, 2, 1> pigment { rgb <1, 0, 0> } finish { emission 1 diffuse 0 } }
sphere { <5, 3, 0>, 2.5 pigment { rgb <0, 1, 0> } finish { emission 1 diffuse 0 } }
"""


@pytest.mark.povray
def test_the_masks_of_a_render_that_fell_back_trace_its_method(tmp_path: Path, monkeypatch) -> None:
    """The colour pass's default fell back to multi-ortho-views (the scene reads image_width): its masks
    are traced the same way and match the colour views' silhouettes.  Control: traced with the mesh
    camera the request named, the bar is another width and the masks miss the silhouettes."""
    import povh3d
    from povh3d.renderer.passes import object_masks
    from povh3d.display.display import build_display
    from povh3d.renderer.request import RenderRequest
    from povh3d.renderer.methods.quality import RenderSettings
    from povh3d.geometry.lens_array import LensArray, Panel
    from povh3d.image.io import read_png

    monkeypatch.setenv("POVH3D_CACHE", str(tmp_path / "cache"))
    scene = tmp_path / "sized.pov"
    scene.write_text(SIZED)
    array = LensArray("square", 16, 12, 1.0, 1.0, 2.0, Panel(64, 48, 0.25, 0.25))
    record = povh3d.render(scene, tmp_path / "s.png", lens_array=array, quality="draft",
                           views_dir=tmp_path / "views", objects=tmp_path / "objs")
    assert record["method"] == "multi-ortho-views" and "image_width" in record["method_note"]
    table = read_table(tmp_path / "objs")
    ids = {name: i for i, name in table.names.items()}
    bar, ball = ids["box_4"], ids["sphere_5"]

    def misses(folder: Path) -> int:
        """Pixels, over every view, where the mask's id is not the colour view's object."""
        wrong = 0
        for l in range(table.views[0]):
            for k in range(table.views[1]):
                view = read_png(tmp_path / "views" / f"v_{l:03d}_{k:03d}.png")[..., :3]
                half = np.iinfo(view.dtype).max // 2
                seen = np.where(view[..., 0] > half, bar, np.where(view[..., 1] > half, ball, 0))
                wrong += int((read_mask(folder, table, 0, (l, k)) != seen).sum())
        return wrong

    assert misses(tmp_path / "objs") == 0
    request = RenderRequest(source=scene, display=build_display(None, lens_array=array), output=tmp_path / "s.png",
                            settings=RenderSettings(quality="draft"), method_chosen=False)
    object_masks.render_objects(request, tmp_path / "mesh", {**record, "method": "multi-ortho"})
    assert misses(tmp_path / "mesh") > 100        # the bar 4.8 mm wider: some 20 view pixels in each of 16 views
