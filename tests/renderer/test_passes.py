"""Only the POV-Ray passes something reads (``renderer.placement.place.depth_wanted``), each one in the
sidecar's ``passes`` with its cost; the scene camera alone at its smallest exact size; the depth maps'
fog pairs in one mesh camera with the values of a pair per view, and every pass's progress said."""

from __future__ import annotations

import json

import numpy as np
import pytest

from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.scene.scene import load_scene

ARRAY = ("--grid", "square", "--lenses", "16x12", "--ppl", "4x4", "--pixel-pitch", "0.25", "--focal", "2",
         "--quality", "draft", "-q")
#: A camera on the axis: the frame's centre is its look_at (0, 2, 0) and its normal +z (docs/geometry.md).
CAMERA = """#version 3.7;
global_settings { assumed_gamma 1 }
camera { location <0, 2, -10> angle 40 right x * image_width / image_height look_at <0, 2, 0> }
light_source { <5, 10, -20> rgb 1 }
plane { y, 0 pigment { checker rgb 1 rgb 0.2 } hollow }
sphere { <0, 2, 0>, 1.5 pigment { rgb <1, 0.2, 0.1> } }
"""


def _fresh(tmp_path) -> dict[str, str]:
    """A cache of the test's own: what ran is not what an earlier test left."""
    return {"POVH3D_CACHE": str(tmp_path / "cache")}


def _passes(path) -> tuple[list[dict], dict]:
    record = json.loads(path.with_suffix(".json").read_text())
    return record["passes"], record["placement"]


@pytest.mark.povray
def test_a_plain_render_runs_no_depth_pass_and_fit_depth_does(cli, tmp_path):
    scene = tmp_path / "cam.pov"
    scene.write_text(CAMERA)
    plain, fitted = tmp_path / "p.png", tmp_path / "f.png"
    assert cli("render", str(scene), "-o", str(plain), *ARRAY, env=_fresh(tmp_path)).code == 0
    passes, frame = _passes(plain)
    assert [p["name"] for p in passes] == ["scene-camera-text"], passes   # literal values: no POV-Ray run
    assert passes[0]["shots"] == 0 and passes[0]["runs"] == 0
    assert "depth" not in frame
    assert frame["centre"] == pytest.approx([0, 2, 0], abs=1e-9) and frame["normal"] == pytest.approx([0, 0, 1])
    # --fit-depth reads the depth: the camera's run measures it (two fog frames), the same frame found
    result = cli("render", str(scene), "-o", str(fitted), "--fit-depth", "auto", *ARRAY, env=_fresh(tmp_path))
    assert result.code == 0, result.err
    passes, frame = _passes(fitted)
    assert [p["name"] for p in passes] == ["scene-camera-depth"], passes
    assert passes[0]["shots"] == 2 and passes[0]["runs"] == 2   # the two fog frames side by side
    assert frame["depth"]["pass"] == "in the camera's evaluation run" and "fit" in frame["depth"]
    assert frame["centre"] == pytest.approx([0, 2, 0], abs=1e-9) and frame["normal"] == pytest.approx([0, 0, 1])
    # The sphere's front (1.5 units before the centre) in mm: the measured subject reaches it.
    before = frame["depth"]["before_fit"]
    units = json.loads(plain.with_suffix(".json").read_text())["placement"]["units_per_mm"]
    assert before["near_mm"] == pytest.approx(-1.5 / units, rel=0.05)
    # A camera of declared values is evaluated by POV-Ray, alone: one run of one row; again from the cache.
    declared = tmp_path / "declared.pov"
    declared.write_text(CAMERA.replace("camera { location <0, 2, -10>", "#declare L = <0, 2, -10>;\ncamera { location L"))
    for name, cached in (("d1.png", False), ("d2.png", True)):
        assert cli("render", str(declared), "-o", str(tmp_path / name), *ARRAY, env=_fresh(tmp_path)).code == 0
        passes, frame = _passes(tmp_path / name)
        assert [p["name"] for p in passes] == ["scene-camera"], passes
        assert (passes[0]["shots"], passes[0]["runs"], passes[0]["from_cache"]) == ((0, 0, True) if cached else (1, 1, False))
        assert frame["centre"] == pytest.approx([0, 2, 0], abs=1e-9) and "depth" not in frame


@pytest.mark.povray
def test_depth_report_measures_without_fitting(cli, tmp_path):
    scene = tmp_path / "cam.pov"
    scene.write_text(CAMERA)
    out = tmp_path / "r.png"
    result = cli("render", str(scene), "-o", str(out), "--depth-report", *ARRAY, env=_fresh(tmp_path))
    assert result.code == 0, result.err
    passes, frame = _passes(out)
    assert [p["name"] for p in passes] == ["scene-camera-depth"]
    assert "fit" not in frame["depth"] and frame["depth"]["near_mm"] < 0


@pytest.mark.parametrize("camera, expected", [
    ("camera { location -5*z look_at 0 }", (16, 9)),   # names no size (an include it reads may: screen.inc)
    ("camera { location -5*z right x*image_width/image_height look_at 0 }", (16, 9)),   # the aspect, exactly
    ("#declare IW = image_width;\ncamera { location -5*z right x*IW/100 look_at 0 }", "physical"),
])
def test_the_camera_alone_is_evaluated_at_its_smallest_exact_size(tmp_path, camera, expected):
    from povh3d.display.display import build_display
    from povh3d.renderer.passes.scene_camera import camera_size, physical_size

    path = tmp_path / "c.pov"
    path.write_text(camera + "\nsphere { 0, 1 pigment { rgb 1 } }\n")
    array = build_display("alioscopy-42").render_array    # 16:9 in mm, 5760 x 1080 subpixels
    size = camera_size(load_scene(path), array)
    assert size == (physical_size(array) if expected == "physical" else expected)


@pytest.mark.povray
def test_the_smallest_size_gives_the_panels_camera(tmp_path):
    """The ratio camera at camera_size equals its evaluation at physical_size (the panel's rows);
    negative control: at a square 1x1 run its right vector is another."""
    from povh3d.display.display import build_display
    from povh3d.renderer.passes.scene_camera import camera_size, evaluate_camera, physical_size
    from povh3d.scene.camera_script import camera_script

    path = tmp_path / "c.pov"
    path.write_text("camera { location -5*z right x*image_width/image_height look_at 0 }\n"
                    "sphere { 0, 1 pigment { rgb 1 } }\n")
    scene, array = load_scene(path), build_display("alioscopy-42").render_array
    script = camera_script(path.read_text(), scene.include_text)

    def camera(size):
        return evaluate_camera(scene, script.script, array, script.cameras, tmp_path, False, script.lines,
                               size=size)[0]

    small, panel, square = camera(camera_size(scene, array)), camera(physical_size(array)), camera((1, 1))
    assert small["right"] == pytest.approx(panel["right"], rel=1e-12)
    assert small["right"][0] == pytest.approx(16 / 9, rel=1e-12)
    assert square["right"][0] != pytest.approx(panel["right"][0], rel=1e-3)


def _plane_array() -> LensArray:
    return LensArray(grid="square", lenses_x=16, lenses_y=12, pitch_x=0.6, pitch_y=0.6, focal=2.0,
                     panel=Panel(48, 36, 0.2, 0.2))   # 3x3 views


def _plane_and_sphere(array: LensArray) -> tuple[np.ndarray, np.ndarray]:
    """``(Ny, Nx, Ly, Lx)`` mm along each view's rays from the screen to the sphere of radius 2 at (1, 0.5, 0)
    or else the plane z = 5 (docs/geometry.md: view (l, k) has slopes (u_k, v_l) / f, pixel (i, j) is the
    ray through lens (j, i)), and where a ray is clear of the sphere's silhouette (0.05 mm)."""
    ny, nx = array.require_views()
    s, f = array.panel.pitch_x, array.focal
    a = ((np.arange(nx) + 0.5 - nx / 2) * s / f)[None, :, None, None]
    b = ((ny / 2 - np.arange(ny) - 0.5) * s / f)[:, None, None, None]
    x = ((np.arange(array.lenses_x) + 0.5 - array.lenses_x / 2) * array.pitch_x)[None, None, None, :]
    y = ((array.lenses_y / 2 - np.arange(array.lenses_y) - 0.5) * array.pitch_y)[None, None, :, None]
    # (x - 1 + t a)^2 + (y - 0.5 + t b)^2 + t^2 = 4, t along z
    qa, qb, qc = a * a + b * b + 1, 2 * ((x - 1) * a + (y - 0.5) * b), (x - 1) ** 2 + (y - 0.5) ** 2 - 4
    disc = qb * qb - 4 * qa * qc
    t = np.where(disc > 0, (-qb - np.sqrt(np.maximum(disc, 0))) / (2 * qa), 5.0)
    miss = np.sqrt(np.maximum(disc, 0)) / (2 * qa)   # half the chord, in t: small near the silhouette
    return np.minimum(t, 5.0) * np.sqrt(qa), (disc <= 0) & (qc > 0.3) | (miss > 0.05)


@pytest.mark.povray
def test_depth_maps_in_one_mesh_camera_equal_the_per_view_passes_and_say_their_progress(tmp_path, monkeypatch):
    """Every view's fog pair in one mesh camera (two frames, a run each) gives the values of a fog pair per
    view (the code before, ``_fog_batch``) within the pass's 16-bit resolution (here 7e-4 mm; measured
    equal to the bit), and those are the scene's: the plane at z = 5 mm, which a view's ray of slopes
    (a, b) meets 5 |(a, b, 1)| mm from the screen, and the sphere before it."""
    import povh3d.renderer.passes.depth as depth
    from povh3d.renderer.passes.record import recording

    path = tmp_path / "plane.pov"
    path.write_text("light_source { <0, 0, -100> rgb 1 }\nplane { -z, -5 pigment { rgb 0.5 } }\n"
                    "sphere { <1, 0.5, 0>, 2 pigment { rgb <1, 0.2, 0.2> } }\n")
    scene, array = load_scene(path), _plane_array()
    settings = RenderSettings(quality="draft", use_cache=False)
    calls: list[tuple[float, float]] = []

    def per_view(slopes, views, cells, pitch, lens_array, front_clearance, fog):
        directions = [(a, b, 1.0) for a, b in slopes.tolist()]
        field = (cells[0] * pitch[0], cells[1] * pitch[1])
        return depth._fog_batch(directions, lens_array, front_clearance, fog, *cells, field), None

    with recording() as notes:
        tiled = depth.view_depth_maps(scene, array, settings, 10.0, 1.0, progress=lambda d, t: calls.append((d, t)))
        monkeypatch.setattr(depth, "_views_pass", per_view)
        each = depth.view_depth_maps(scene, array, settings, 10.0, 1.0)
    assert [(n.name, n.shots, n.runs) for n in notes] == [("depth-maps", 2, 2), ("depth-maps", 18, 3)]
    assert np.array_equal(np.isnan(tiled), np.isnan(each))
    assert np.nanmax(np.abs(tiled - each)) < 0.002
    assert calls[-1] == (2, 2) and calls[0][0] == 0
    expected, clear = _plane_and_sphere(array)
    assert clear.mean() > 0.9 and np.abs(tiled - expected)[clear].max() < 0.01
    assert (expected[clear] < 0).mean() > 0.05     # the sphere seen before the screen too
    # negative controls: views swapped left to right (another view's rays: the sphere's parallax), lens
    # columns swapped (the sphere, off the axis, seen on the other side)
    assert np.nanmax(np.abs(tiled[:, ::-1] - each)) > 0.1
    assert np.abs(tiled[..., ::-1] - expected)[clear].max() > 1


@pytest.mark.povray
def test_depth_maps_are_a_pass_of_the_sidecar(cli, tmp_path):
    path = tmp_path / "plane.pov"
    path.write_text("light_source { <0, 0, -100> rgb 1 }\nplane { -z, -5 pigment { rgb 0.5 } }\n")
    out = tmp_path / "d.png"
    result = cli("render", str(path), "-o", str(out), "--depth-maps", str(tmp_path / "maps"), *ARRAY,
                 env=_fresh(tmp_path))
    assert result.code == 0, result.err
    passes, _ = _passes(out)
    assert [p["name"] for p in passes] == ["depth-maps"]      # native frame: no camera, no summary pass
    assert passes[0]["shots"] == 2 and passes[0]["runs"] == 2   # 16 views' fog pairs in one mesh camera


#: Cameras the text alone decides, with POV-Ray's own evaluation as the oracle.
LITERAL = [
    "camera { location <-8.0, 4.0, -14.0> angle 40 up <0.0, 1.0, 0.0> right x*image_width/image_height "
    "look_at <-2.0, 0.0, -4.0> }",                                                      # advanced/pawns.pov
    "camera { location <7, 20, 20> direction y sky z up z right x*image_width/image_height look_at <0.0, 0, 1.2> }",
    "camera { perspective location -(2 + 3) * z + <1, .5e1, 0> / 2 right -1.5*x direction 2*z }",   # right-handed
    "camera { location <0, 0, -5> /* a comment */ angle 65 // another\n look_at 0 }",   # a float promoted
    # templates/Basic_Scenes: declared cameras, one used by name
    "#declare Camera_0 = camera {/*ultra_wide_angle*/ angle 75 location <0.0, 1.0, -3.0>\n"
    "  right x*image_width/image_height look_at <0.0, 1.0, 0.0>}\n"
    "#declare Camera_1 = camera { angle 90 location <2.0, 2.5, -3.0> look_at <0.0, 1.0, 0.0>}\n"
    "camera{Camera_0}",
    "#declare C = camera { location <0, 0, -5> }\ncamera { C }",
    # a scene that builds from the image size itself (language/image_size.pov), its camera too
    "camera { location <0, 1, -image_width/64> right x*image_width/image_height look_at 0 }\n"
    "#declare TotalPixels = image_width * image_height;",
]
#: Cameras it does not decide (POV-Ray does): identifiers, transforms, two cameras, a directive around it.
NOT_LITERAL = [
    "#declare L = <0, 0, -5>;\ncamera { location L look_at 0 }",
    "camera { location <0, 0, -5> look_at 0 rotate 30*y }",
    "camera { location <0, 0, -5> look_at 0 }\ncamera { location <0, 0, -6> look_at 0 }",
    "#if (1)\ncamera { location <0, 0, -5> look_at 0 }\n#end",
    "#declare C = camera { location <0, 0, -5> }\n#declare C = camera { location <0, 0, -6> }\ncamera { C }",
    "#if (1) #declare C = camera { location <0, 0, -5> } #end\ncamera { C }",
    "#declare C = camera { location <0, 0, -5> }\ncamera { C rotate 30*y }",
    "#declare C = camera { location <0, 0, -5> }\ncamera { location <0, 0, -6> }",
    "#declare L = <0, 0, -5>;\n#declare C = camera { location L }\ncamera { C }",
    "camera { orthographic location <0, 0, -5> look_at 0 }",
    "camera { location <0, 0, -5> look_at 0 aperture 0.1 focal_point 0 }",
    "camera { location <0, 0, -5, 1> look_at 0 }",
    "#version 3.1;\ncamera { location <0, 0, -5> look_at 0 }",
    '#include concat("a", ".inc")\ncamera { location <0, 0, -5> look_at 0 }',
]


@pytest.mark.povray
@pytest.mark.parametrize("camera", LITERAL)
def test_a_literal_camera_from_the_text_equals_povrays(tmp_path, camera):
    from povh3d.display.display import build_display
    from povh3d.renderer.passes.scene_camera import evaluate_camera, physical_size
    from povh3d.scene.camera import camera_from_items
    from povh3d.scene.camera_script import camera_script
    from povh3d.scene.camera_text import literal_camera

    path = tmp_path / "c.pov"
    path.write_text("#version 3.7;\n" + camera + "\nsphere { 0, 1 pigment { rgb 1 } }\n")
    scene, array = load_scene(path), build_display("alioscopy-42").render_array
    items = literal_camera(path.read_text(), scene.include_text, physical_size(array))
    assert items is not None
    mine = camera_from_items(items).as_record()
    script = camera_script(path.read_text(), scene.include_text)
    theirs = evaluate_camera(scene, script.script, array, script.cameras, tmp_path, False, script.lines)[0]
    for key in ("location", "direction", "right", "up"):
        assert mine[key] == pytest.approx(theirs[key], rel=1e-12, abs=1e-12), key
    assert (mine["look_at"] is None) == (theirs["look_at"] is None) and mine["type"] == theirs["type"]


@pytest.mark.parametrize("camera", NOT_LITERAL)
def test_a_camera_the_text_does_not_decide_is_left_to_povray(tmp_path, camera):
    from povh3d.scene.camera_text import literal_camera

    path = tmp_path / "c.pov"
    path.write_text(camera + "\nsphere { 0, 1 pigment { rgb 1 } }\n")
    assert literal_camera(path.read_text(), load_scene(path).include_text, (16, 9)) is None


def test_a_camera_in_an_include_is_left_to_povray(tmp_path):
    """Negative control of the include check: the same literal camera in the main file is read."""
    from povh3d.scene.camera_text import literal_camera

    (tmp_path / "cam.inc").write_text("camera { location <0, 0, -5> look_at 0 }\n")
    main = tmp_path / "c.pov"
    main.write_text('#include "cam.inc"\ncamera { location <0, 0, -6> look_at 0 }\n')
    assert literal_camera(main.read_text(), load_scene(main).include_text, (4, 3)) is None
    (tmp_path / "cam.inc").write_text("#declare R = 1;\n")
    assert literal_camera(main.read_text(), load_scene(main).include_text, (4, 3)) is not None


@pytest.mark.povray
def test_the_inside_solid_check_says_its_progress_and_its_cost(tmp_path):
    """A fogged scene: the inside-solid pass (two frames) shows in the sidecar, run beside the fallback's views
    (``render._settled_beside``), or, where the fallback may not be taken (the method chosen), on the render's
    progress before the render; the same scene without fog runs no such pass (the negative control)."""
    from povh3d.display.display import Display
    from povh3d.renderer.render import render
    from povh3d.renderer.request import RenderRequest

    fogged = CAMERA + "fog { rgb 0.8 distance 40 }\n"
    names = {}
    for name, text, chosen in (("fog", fogged, False), ("chosen", fogged, True), ("clear", CAMERA, False)):
        scene = tmp_path / f"{name}.pov"
        scene.write_text(text)
        calls: list[tuple[float, float]] = []
        request = RenderRequest(source=scene, display=Display(_plane_array()), output=tmp_path / f"{name}.png",
                                settings=RenderSettings(quality="draft", cache_dir=tmp_path / "cache"),
                                method_chosen=chosen)
        record = render(request, lambda d, t: calls.append((d, t)))
        names[name] = [(p["name"], p.get("beside")) for p in record["passes"]]
        if name == "chosen":
            assert (2, 2) in calls and calls.index((2, 2)) < len(calls) - 1, calls
        assert record["method"] == "multi-ortho"   # the plane is hollow: the mesh camera is right
    assert names == {"fog": [("scene-camera-text", None), ("origins-inside", True)],
                     "chosen": [("scene-camera-text", None), ("origins-inside", None)],
                     "clear": [("scene-camera-text", None)]}


@pytest.mark.povray
def test_every_pass_says_its_progress(tmp_path):
    """The issue: a status line at '1/1 frames' and then seconds of silence.  A camera scene with depth maps
    has three phases, each counted to its end: the camera's run (its two fog frames), the render,
    the depth maps' two frames; a scene without a camera has no camera phase (negative control)."""
    import povh3d

    def phases(text: str) -> list[list[tuple[float, float]]]:
        scene = tmp_path / "s.pov"
        scene.write_text(text)
        calls: list[tuple[float, float]] = []
        povh3d.render(scene, tmp_path / "o.png", lens_array=_plane_array(), quality="draft", use_cache=False,
                      depth_maps=tmp_path / "maps", progress=lambda d, t: calls.append((d, t)))
        found: list[list[tuple[float, float]]] = []
        for done, total in calls:
            if not found or total != found[-1][-1][1] or done < found[-1][-1][0]:
                found.append([])
            found[-1].append((done, total))
        return found

    # The depth maps' pass runs beside the render (``passes.beside``): its phase follows the render's, from
    # where it has got to by then, to its end.
    camera = phases(CAMERA)
    assert [(p[0][0], p[-1]) for p in camera][:2] == [(0, (2, 2)), (0, (1, 1))], camera
    assert len(camera) == 3 and camera[2][-1] == (2, 2), camera
    plain = phases("\n".join(line for line in CAMERA.splitlines() if not line.startswith("camera")))
    assert [(p[0][0], p[-1]) for p in plain][:1] == [(0, (1, 1))] and len(plain) == 2 and plain[1][-1] == (2, 2), plain


def test_a_tiled_image_one_pixel_wide_takes_a_fog_pair_per_view():
    """POV-Ray's mesh camera crashes on an image one pixel wide (``mesh_camera_batch``): one view of one
    lens column takes the per-view pass; two such views, tiled two pixels wide, the mesh camera."""
    import povh3d.renderer.passes.depth as depth

    batch, tiles = depth._views_pass(np.zeros((1, 2)), (1, 1), (1, 5), (0.6, 0.6), _plane_array(), 10.0, 10.0)
    assert tiles is None and batch.template == "depth.pov.j2" and [s["fog"] for s in batch.shots] == [0, 1]
    batch, tiles = depth._views_pass(np.zeros((2, 2)), (1, 2), (1, 5), (0.6, 0.6), _plane_array(), 10.0, 10.0)
    assert tiles == ((1, 2), (1, 5)) and batch.template == "depth_mesh.pov.j2" and (batch.width, batch.height) == (3, 6)
