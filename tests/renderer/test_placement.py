"""The placement on scenes with their own camera (issue 13).

Oracles: the frame against the scene's declared identifiers (analytic); every
view extracted from the H3D image against a plain POV-Ray render through an
oblique orthographic camera placed by the frame in NumPy (PSNR >= 40 dB,
point-sampled); the camera's vectors against POV-Ray's own render through
the scene's camera; a scene moved by a transform and the display moved by
the same frame give the same pixels.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from povh3d.display.display import Display
from povh3d.renderer.placement.pose import PlacementOptions, resolve_pose
from povh3d.renderer.methods.quality import RenderSettings
from povh3d.errors import ConfigError
from povh3d.geometry.pose import DisplayPose, explicit_pose
from povh3d.geometry.lens_array import LensArray, Panel
from povh3d.image.interleave import extract
from povh3d.image.io import read_image, read_png
from povh3d.image.metrics import psnr
from povh3d.scene.format import pov_vector
from povh3d.povray.process import PovrayJob, run_jobs
from povh3d.scene.camera import CameraError
from povh3d.scene.scene import load_scene
from tests.support.render import render

GALLERY = Path(__file__).resolve().parents[1] / "support" / "gallery"


def small_array() -> LensArray:
    return LensArray(grid="square", lenses_x=24, lenses_y=18, pitch_x=1.2, pitch_y=1.2, focal=2.0,
                     panel=Panel(144, 108, 0.2, 0.2))


def _povray(script: str, width: int, height: int, include: Path) -> np.ndarray:
    images: list[np.ndarray] = []
    job = PovrayJob(name="oracle", script=script, width=width, height=height, include_dirs=(str(include),),
                    options=("-A",))
    run_jobs([job], processes=1, on_result=lambda r: images.append(read_image(r.images[0])))
    return images[0]


def _frame(record: dict) -> DisplayPose:
    return DisplayPose(tuple(record["centre"]), tuple(record["axis_x"]), tuple(record["axis_y"]),
                        tuple(record["normal"]), record["units_per_mm"], record["source"])


@pytest.mark.povray
def test_frame_follows_the_declared_camera():
    """Centre at look_at, normal along look_at - location, y along the rolled sky, width = field."""
    array = small_array()
    frame, record = resolve_pose(PlacementOptions(), load_scene(GALLERY / "tilted.pov"), array)
    target = np.array([0.35, 0.42, -0.10])
    el, az = np.radians(28), np.radians(-37)
    # vrotate(<0,0,-d>, <el, az, 0>) in POV-Ray's left-handed frame: about x, then y.
    p = np.array([0, 3.2 * np.sin(el), -3.2 * np.cos(el)])
    location = target + np.array([p[0] * np.cos(az) + p[2] * np.sin(az), p[1],
                                  -p[0] * np.sin(az) + p[2] * np.cos(az)])
    assert record["source"] == "camera"
    np.testing.assert_allclose(frame.centre, target, atol=1e-12)
    normal = (target - location) / np.linalg.norm(target - location)
    np.testing.assert_allclose(frame.axis_z, normal, atol=1e-9)
    # The roll: the display's up is the world's up rolled 12 degrees about the view axis.
    flat_up = np.array([0.0, 1, 0]) - normal[1] * normal
    flat_up /= np.linalg.norm(flat_up)
    assert np.degrees(np.arccos(np.clip(np.dot(frame.axis_y, flat_up), -1, 1))) == pytest.approx(12, abs=1e-6)
    width_units = 2 * 3.2 * np.tan(np.radians(16))   # angle 32 at the look_at distance
    assert frame.units_per_mm * array.panel.size_mm[0] == pytest.approx(width_units, rel=1e-12)
    # Negative control: a frame that ignored the roll would fail the angle check above.
    assert np.dot(frame.axis_y, flat_up) < np.cos(np.radians(11))


@pytest.mark.povray
def test_camera_vectors_reproduce_povray_render(tmp_path):
    """POV-Ray through the scene's own camera == through a camera written from povh3d's vectors."""
    scene = GALLERY / "tilted.pov"
    _, record = resolve_pose(PlacementOptions(), load_scene(scene), small_array())
    cam = record["camera"]
    own = _povray(f'#include "{scene.name}"\n', 144, 108, GALLERY)
    ours = _povray(f'#include "{scene.name}"\ncamera {{ location {pov_vector(cam["location"])} '
                   f'direction {pov_vector(cam["direction"])} right {pov_vector(cam["right"])} '
                   f'up {pov_vector(cam["up"])} }}\n', 144, 108, GALLERY)
    assert psnr(ours, own) > 40   # a few checker-edge pixels differ in the last bits of the vectors
    assert (np.abs(ours.astype(int) - own).max(-1) > 8).mean() < 0.002
    wrong = _povray(f'#include "{scene.name}"\ncamera {{ location {pov_vector(cam["location"])} '
                    f'direction {pov_vector(cam["direction"])} right {pov_vector(cam["right"])} '
                    f'up {pov_vector(np.negative(cam["up"]))} }}\n', 144, 108, GALLERY)
    assert psnr(wrong, own) < 25  # negative control


@pytest.mark.povray
@pytest.mark.parametrize("name", ["tilted.pov", "inches.pov"])
def test_views_equal_oblique_orthographic_renders(tmp_path, name):
    """Every view (a sample of them) equals POV-Ray's oblique orthographic render placed by the frame."""
    array = small_array()
    record = render(GALLERY / name, array, tmp_path / "h3d.png", settings=RenderSettings(quality="draft"))
    frame = _frame(record["placement"])
    assert record["placement"]["source"] == "camera"
    front_clearance = record["quality"]["front_clearance_mm"]
    views = extract(read_png(tmp_path / "h3d.png"), array.require_views())
    ny, nx = array.require_views()
    s, f = array.panel.pitch_x, array.focal
    worst, flipped = np.inf, 0
    for l, k in [(0, 0), (ny // 2, nx // 2), (ny - 1, nx - 1), (1, nx - 2)]:
        u, v = (k + 0.5 - nx / 2) * s, (ny / 2 - l - 0.5) * s
        d = np.array([u / f, v / f, 1.0])
        # The ray of docs/geometry.md in display mm, carried into scene units by the frame in NumPy.
        location = frame.to_scene(-front_clearance * d)
        direction = frame.directions_to_scene(d)
        right = frame.directions_to_scene([array.lenses_x * array.pitch_x, 0, 0])
        up = frame.directions_to_scene([0, array.lenses_y * array.pitch_y, 0])
        script = (f'#include "{name}"\ncamera {{ orthographic location {pov_vector(location)} '
                  f'direction {pov_vector(direction)} right {pov_vector(right)} up {pov_vector(up)} }}\n')
        oracle = _povray(script, array.lenses_x, array.lenses_y, GALLERY)
        worst = min(worst, psnr(views[l, k], oracle))
        flipped = max(flipped, int((np.abs(views[l, k].astype(int) - oracle).max(-1) > 8).sum()))
        if (l, k) == (0, 0):  # negative control: the mirror view differs
            assert psnr(views[ny - 1, nx - 1], oracle) < 35
    assert worst >= 40
    assert flipped == 0


@pytest.mark.povray
def test_moved_scene_and_frame_give_the_same_pixels(tmp_path):
    """A scene moved by T, rendered through the frame T, equals the scene in place (every method)."""
    base = tmp_path / "base.pov"
    base.write_text('#version 3.7;\nglobal_settings { assumed_gamma 1.0 }\n#ifndef (T) #declare T = '
                    'transform { scale 1 } #end\nbackground { rgb 0.1 }\n'
                    'light_source { <-40, 60, -80> rgb 1 transform T }\n'
                    'sphere { <1, 0.5, -1>, 2.5 pigment { checker rgb <0.9,0.4,0.1> rgb 0.2 scale 0.7 } transform T }\n'
                    'plane { z, 3 pigment { checker rgb 0.9 rgb 0.3 scale 1.1 } transform T }\n')
    moved = tmp_path / "moved.pov"
    moved.write_text('#declare T = transform { rotate <20, -35, 10> scale 2.5 translate <100, -40, 300> }\n'
                     '#include "base.pov"\n')
    ax, ay, az = np.radians([20, -35, 10])
    rx = np.array([[1, 0, 0], [0, np.cos(ax), np.sin(ax)], [0, -np.sin(ax), np.cos(ax)]])
    ry = np.array([[np.cos(ay), 0, -np.sin(ay)], [0, 1, 0], [np.sin(ay), 0, np.cos(ay)]])
    rz = np.array([[np.cos(az), np.sin(az), 0], [-np.sin(az), np.cos(az), 0], [0, 0, 1]])
    r = rx @ ry @ rz   # POV-Ray's rotate <a,b,c> on row vectors
    frame = DisplayPose((100, -40, 300), r[0], r[1], r[2], 2.5, "explicit")
    # pinhole renders one camera a lens: a ninth of small_array()'s lenses for it.
    arrays = {"multi-ortho": small_array(),
              "pinhole": LensArray("square", 8, 6, 1.2, 1.2, 2.0, Panel(48, 36, 0.2, 0.2))}
    for method, array in arrays.items():
        a = render(base, array, tmp_path / f"a-{method}.png", method=method,
                   settings=RenderSettings(quality="draft"))
        b = render(moved, array, tmp_path / f"b-{method}.png", method=method,
                   settings=RenderSettings(quality="draft", pose=tuple(frame.matrix().ravel())))
        assert psnr(read_png(tmp_path / f"a-{method}.png"), read_png(tmp_path / f"b-{method}.png")) > 60
        assert a["placement"]["source"] == "native" and b["placement"]["source"] == "matrix"
    c = render(moved, arrays["multi-ortho"], tmp_path / "c.png", settings=RenderSettings(quality="draft"))
    assert psnr(read_png(tmp_path / "a-multi-ortho.png"), read_png(tmp_path / "c.png")) < 20  # control
    assert c["placement"]["source"] == "native"


def _scene(tmp_path: Path, camera: str) -> Path:
    path = tmp_path / "s.pov"
    path.write_text(f"#version 3.7;\n#declare Use_A = 1;\n{camera}\nsphere {{ 0, 1 pigment {{ rgb 1 }} }}\n")
    return path


@pytest.mark.parametrize("camera, words", [
    pytest.param("#if (!Use_A) camera { location <0,0,-5> look_at 0 } #end", "reaches none of its camera statements",
                 marks=pytest.mark.povray),
    pytest.param("camera { location <0,0,-5> look_at <0,0,-5> }", "location equals its look_at", marks=pytest.mark.povray),
    pytest.param("camera { orthographic location <0,0,-5> look_at 0 }", "orthographic", marks=pytest.mark.povray),
    ("camera { Elsewhere rotate 10*y }", "identifier 'Elsewhere'"),
])
def test_camera_that_cannot_be_used_is_one_line_naming_the_options(tmp_path, camera, words):
    with pytest.raises(CameraError) as info:
        resolve_pose(PlacementOptions(), load_scene(_scene(tmp_path, camera)), small_array())
    message = str(info.value)
    assert words in message and "placement.center" in message and "\n" not in message


def test_explicit_and_native_frames(tmp_path):
    scene = load_scene(_scene(tmp_path, "camera { location <0,0,-5> look_at 0 }"))
    array = small_array()
    frame, _ = resolve_pose(PlacementOptions("native"), scene, array)
    assert frame.is_native
    frame, record = resolve_pose(PlacementOptions(center=(1, 2, 3), normal=(0, 0, 2), width=28.8), scene, array)
    assert record["source"] == "explicit" and frame.units_per_mm == pytest.approx(1.0)
    np.testing.assert_allclose(frame.to_scene([0, 0, 0]), [1, 2, 3])
    with pytest.raises(ConfigError, match="parallel"):
        explicit_pose((0, 0, 0), (0, 1, 0), 10, 28.8, up=(0, 2, 0))
    with pytest.raises(ConfigError, match="positive"):
        explicit_pose((0, 0, 0), (0, 0, 1), 0, 28.8)
    with pytest.raises(ConfigError, match="needs all"):
        PlacementOptions(center=(0, 0, 0))


@pytest.mark.povray
def test_camera_evaluation_is_cached_by_scene_digest():
    scene, array = load_scene(GALLERY / "inches.pov"), small_array()
    _, first = resolve_pose(PlacementOptions(), scene, array)
    _, again = resolve_pose(PlacementOptions(), scene, array)
    assert not first["evaluation_from_cache"] and again["evaluation_from_cache"]
    assert again["evaluation_seconds"] < 0.05
    assert any("ran 2 camera statements" in w for w in first["warnings"])
    assert first["centre"] == [0.0, 1.0, 0.0]   # the last camera counts


def test_a_non_uniform_frame_matrix_is_refused(tmp_path):
    """The mesh camera turns normals as normals: a depth-only scale would bend multi-ortho's rays."""
    matrix = np.eye(4, 3)
    matrix[2] *= 2.5
    with pytest.raises(ConfigError, match="uniform scale"):
        render(GALLERY / "inches.pov", small_array(), tmp_path / "x.png",
               settings=RenderSettings(quality="draft", pose=tuple(matrix.ravel())))
    assert not (tmp_path / "x.png").exists()


@pytest.mark.povray
def test_camera_frame_and_its_depth_in_one_povray_run(tmp_path, monkeypatch):
    """The depth pass made in the camera's run equals a depth pass of its own in the same frame."""
    import povh3d.renderer.placement.place as placement
    from povh3d.renderer.placement.pose import resolve_pose_and_depth
    from povh3d.renderer.request import RenderRequest
    from povh3d.renderer.passes.depth import depth_pass

    scene, array = load_scene(GALLERY / "tilted.pov"), small_array()
    settings = RenderSettings(quality="draft", cache_dir=tmp_path)
    # --depth-report: a plain render measures no depth (test_passes.py)
    request = RenderRequest(source=scene.path, display=Display(array), output=tmp_path / "o.png", settings=settings,
                            placement=PlacementOptions(depth_report=True))
    monkeypatch.setattr(placement, "depth_pass", None)   # a separate pass would fail: none is run
    _, record = placement.place_display(request, scene)
    again = placement.place_display(request, scene)[1]
    monkeypatch.undo()
    assert record["depth"]["pass"] == "in the camera's evaluation run" and not record["evaluation_from_cache"]
    assert again["evaluation_from_cache"] and again["evaluation_seconds"] < 0.05
    frame = _frame(record)
    own = depth_pass(scene, array, RenderSettings(pose=tuple(frame.matrix().ravel())), 4 * 28.8,
                     frame.units_per_mm).summary(record["depth_budget_mm"])
    for key in ("near_mm", "far_mm", "field_near_mm", "field_far_mm"):
        assert record["depth"][key] == pytest.approx(own[key], abs=0.02), key
    # The pass belongs to its frame and clearance: another one is measured again.
    placed, _, seen = resolve_pose_and_depth(PlacementOptions(), scene, array, cache_dir=tmp_path,
                                              front_clearance=4 * 28.8)
    assert np.allclose(placed.matrix(), frame.matrix())
    clearance = placement._front_clearance(placed, 4 * 28.8)   # within 0.9 of the camera's distance
    assert clearance < 4 * 28.8
    assert seen.depth(frame, clearance, array) is not None
    assert seen.depth(frame.scaled(1.001), clearance, array) is None
    assert seen.depth(frame, clearance * 1.001, array) is None


@pytest.mark.parametrize("camera, size, odd", [
    ("camera { location -5*z look_at 0 }", (80, 60), (80, 62)),                                   # any size
    ("camera { location -5*z right x*image_width/image_height look_at 0 }", (80, 60), (64, 50)),  # exact aspect
    ("#declare IW = image_width;\ncamera { location -5*z right x*IW/100 look_at 0 }", None, None),  # own run
])
def test_the_camera_is_evaluated_at_a_size_it_cannot_tell_apart(tmp_path, camera, size, odd):
    from povh3d.renderer.passes.scene_camera import measured_size

    scene = load_scene(_scene(tmp_path, camera))
    assert measured_size(scene, 320, 240, 80) == size
    assert measured_size(scene, 320, 250, 80) == odd


@pytest.mark.parametrize("camera, uses", [
    ("camera { location -5*z look_at 0 }", False),
    ("camera { location -5*z right x*image_width/image_height look_at 0 }", False),   # the ratio: the panel's
    ("#declare N = image_width * image_height;\ncamera { location -5*z look_at 0 }", True),   # language/image_size
])
def test_a_scene_that_builds_from_the_image_size_is_told(tmp_path, camera, uses):
    from povh3d.renderer.passes.scene_camera import uses_image_size

    assert uses_image_size(load_scene(_scene(tmp_path, camera))) == uses


@pytest.mark.povray
def test_the_render_warns_a_scene_built_from_the_image_size(cli, tmp_path):
    """language/image_size.pov prints the image's pixel count: each POV-Ray run (a bank of views) has its
    own, not the panel's.  The default method falls back to one run a view (said in the sidecar and the
    summary); a chosen multi-ortho-views warns that each view sees its own size.  Negative control: the
    ratio alone, neither."""
    from povh3d.image.io import read_sidecar

    display = ("--grid", "square", "--lenses", "8x6", "--ppl", "2x2", "--quality", "draft")
    for camera, told in [("#declare N = image_width;\ncamera { location -5*z look_at 0 }", True),
                         ("camera { location -5*z right x*image_width/image_height look_at 0 }", False)]:
        folder = tmp_path / str(told)
        folder.mkdir()
        scene = _scene(folder, camera)
        result = cli("render", str(scene), "-o", str(folder / "o.png"), *display)
        assert result.code == 0, result.err
        side = read_sidecar(folder / "o.png")
        assert (side["method"] == "multi-ortho-views") == told, side["method"]
        assert ("not the default multi-ortho" in result.out) == told, result.out
        chosen = cli("render", str(scene), "-o", str(folder / "v.png"), *display, "-q", "--method", "multi-ortho-views")
        assert chosen.code == 0, chosen.err
        assert ("image_width or image_height other than as their ratio" in chosen.err) == told, chosen.err


@pytest.mark.povray
@pytest.mark.parametrize(("camera", "refused_before_parse"), [
    ("camera { mesh_camera { 1 3 mesh { M } } }", True),
    ("camera { location <0, 0, -5> look_at 0 }", False),   # the control: the parse runs and stops
])
def test_a_mesh_camera_scene_is_refused_before_its_parse(cli, tmp_path, camera, refused_before_parse):
    """The mesh-camera demos build their mesh from image_width: at a large panel's size their parse
    takes minutes, only for a refusal that needs none of the camera's values."""
    scene = tmp_path / "s.pov"
    scene.write_text(f'#version 3.7;\n{camera}\n#error "the scene was parsed"\n')
    result = cli("render", str(scene), "--preset", "demo", "--quality", "draft", "-o", str(tmp_path / "h.png"))
    lines = [line for line in result.err.splitlines() if line.strip()]
    assert result.code != 0 and len(lines) == 1, result.err
    assert ("mesh_camera camera" in lines[0]) is refused_before_parse
    assert ("the scene was parsed" in lines[0]) is not refused_before_parse


@pytest.mark.povray
def test_the_renders_timeout_governs_the_camera_run(tmp_path):
    """The run that evaluates the scene's camera (and measures depth through it) is limited by the
    render's own ``timeout``, not a fixed one: a scene whose parse takes minutes renders when the user
    allows it, and a short limit stops the camera run itself."""
    import time

    from povh3d.renderer.placement.pose import resolve_pose_and_depth
    from povh3d.errors import PovrayTimeout

    # about 4 s of parse before the camera (the two fog frames' runs parse side by side; stopping a
    # run takes up to 1.3 s: SIGTERM, then SIGKILL after a grace)
    path = tmp_path / "slow.pov"
    path.write_text("#version 3.7;\n#declare T = 0; #while (T < 6000000) #declare T = T + 1; #end\n"
                    "camera { location <0, 0, -5> look_at 0 }\nsphere { 0, 1 pigment { rgb 1 } }\n")
    scene, array = load_scene(path), small_array()
    start = time.perf_counter()
    frame, record, seen = resolve_pose_and_depth(PlacementOptions(), scene, array, use_cache=False,
                                                  front_clearance=2.0, timeout=60)   # the control
    whole = time.perf_counter() - start
    assert record["source"] == "camera" and seen is not None
    start = time.perf_counter()
    with pytest.raises(PovrayTimeout):
        resolve_pose_and_depth(PlacementOptions(), scene, array, use_cache=False, front_clearance=2.0,
                                timeout=0.3)
    # stopped at the limit, not after the parse: a share of the whole run, which a loaded machine slows alike
    assert time.perf_counter() - start < 0.6 * whole


@pytest.mark.povray
def test_a_mesh_camera_built_from_image_width_is_told_at_a_few_rows(tmp_path):
    """A scene whose mesh camera (a triangle a pixel, from image_width) sits beside a perspective camera in
    an ``#if`` parses for minutes at a 2048 x 1536 panel only to be refused: which camera the parse ends
    with is told at a few rows first.  The control, the same scene with its perspective camera on, is
    framed by it."""
    import time

    from povh3d.display.presets import lens_array

    def scene(use_mesh: int) -> Path:
        path = tmp_path / f"meshcam{use_mesh}.pov"
        path.write_text(
            f"#version 3.7;\n#declare use_mesh = {use_mesh};\n#declare N = image_width * image_height;\n"
            "#if (use_mesh)\n  #declare M = mesh { #local i = 0; #while (i < N)\n"
            "    triangle { <i, 0, 0>, <i + 1, 0, 0>, <i, 1, 0> } #local i = i + 1; #end }\n"
            "  camera { mesh_camera { 1 0 mesh { M } } location <0, 0, -1> }\n"
            "#else\n  camera { location <0, 0, -5> look_at 0 }\n#end\nsphere { 0, 1 pigment { rgb 1 } }\n")
        return path

    array = lens_array("ipad-retina")   # 3.1 million triangles at the panel's size: minutes of parse
    start = time.perf_counter()
    with pytest.raises(CameraError, match=r"mesh_camera camera .* told by a parse at \d+x\d+ pixels"):
        resolve_pose(PlacementOptions(), load_scene(scene(1)), array, use_cache=False)
    assert time.perf_counter() - start < 10
    frame, record = resolve_pose(PlacementOptions(), load_scene(scene(0)), array, use_cache=False)
    assert record["source"] == "camera"
