"""``povh3d layout``: the set-up picture drawn headless (off-screen PyVista), for a scene with its
own camera, a mesh model and a volume; the content placed as a render places it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from povh3d.commands.layout import layout, scene_content, volume_content, write_layout
from povh3d.commands.layout_picture import SCREEN
from povh3d.display.presets import lens_array
from povh3d.image.io import read_png
from povh3d.volume.grid import Volume
from tests.support.cli import one_error_line

pv = pytest.importorskip("pyvista")
ANT = Path(pv.__file__).parent / "examples" / "ant.ply"
SIZE = (480, 360)
CAMERA_SCENE = """#version 3.7;
global_settings { assumed_gamma 1.0 }
camera { location <0, 3, -12> look_at <0, 0, 0> angle 40 }
background { rgb 0.1 }
light_source { <-10, 20, -30> rgb 1 }
sphere { <0, 0, 0>, 1.5 pigment { rgb <0.9, 0.3, 0.1> } }
box { <1.5, -1, -3>, <3, 1, -1.5> pigment { rgb <0.3, 0.8, 0.3> } }
"""


def screen_pixels(image: np.ndarray, tolerance: int = 40) -> int:
    """Pixels of the screen outline's colour (the translucent slab may tint it a little)."""
    return int(np.sum(np.all(np.abs(image.astype(int) - SCREEN) <= tolerance, axis=-1)))


def not_blank(image: np.ndarray) -> bool:
    """More than a background: many pixels away from the picture's most common colour."""
    flat = image.reshape(-1, 3)
    values, counts = np.unique(flat, axis=0, return_counts=True)
    background = values[np.argmax(counts)]
    return float(np.mean(np.any(flat != background, axis=1))) > 0.05


def test_the_pixel_checks_fail_on_a_blank_picture():
    blank = np.full((SIZE[1], SIZE[0], 3), 255, np.uint8)
    assert not not_blank(blank) and screen_pixels(blank) == 0


def check_picture(path: Path) -> dict:
    image = read_png(path)
    assert image.shape[:2] == (SIZE[1], SIZE[0])
    assert not_blank(image)
    assert screen_pixels(image) > 200
    return json.loads(path.with_suffix(".json").read_text())


def test_a_model_is_placed_as_the_stage_places_it(tmp_path):
    from povh3d.renderer.content.model import prepare_stage

    a = lens_array("demo")
    record = check_picture_of(layout(ANT, tmp_path / "ant.png", a, size=SIZE), tmp_path / "ant.png")
    # the render's own stage (converted to POV-Ray, placed from the include's bounds) agrees
    _, stage = prepare_stage(ANT, a, cache_dir=tmp_path / "cache")
    assert np.allclose(record["content"]["fit"]["size_mm"], stage["fit"]["size_mm"], rtol=1e-9)
    assert record["content"]["up"] == stage["up"]
    depth = record["content_depth"]
    assert depth["depth_mm"] == pytest.approx(stage["fit"]["size_mm"][2], rel=1e-9)
    assert depth["near_mm"] == pytest.approx(-depth["far_mm"])   # centred on the screen


def check_picture_of(record: dict, path: Path) -> dict:
    written = check_picture(path)
    assert written["content_depth"] == record["content_depth"]
    return written


@pytest.mark.povray
def test_a_scene_with_a_camera_is_measured_in_the_cameras_frame(tmp_path):
    from povh3d.renderer.placement.place import scene_report
    from povh3d.geometry.pose import DisplayPose

    scene = tmp_path / "cam.pov"
    scene.write_text(CAMERA_SCENE)
    a = lens_array("demo")
    content = scene_content(scene, a)
    write_layout(content, a, tmp_path / "cam.png", size=SIZE)
    record = check_picture(tmp_path / "cam.png")
    info = scene_report(scene, a)["placement"]   # what 'povh3d info SCENE' reports
    assert record["content"]["source"] == "camera"
    assert record["units_per_mm"] == pytest.approx(info["units_per_mm"])
    frame = DisplayPose(info["centre"], info["axis_x"], info["axis_y"], info["normal"], info["units_per_mm"])
    # every hit, taken back into the scene, lies on the sphere or on the box (to the pass's resolution)
    p = frame.to_scene(content.vertices)
    assert len(p) > 500
    on_sphere = np.abs(np.linalg.norm(p, axis=1) - 1.5) < 0.05
    lo, hi = np.array([1.5, -1, -3]), np.array([3, 1, -1.5])
    outside = np.max(np.maximum(lo - p, p - hi), axis=1)   # > 0 outside the box, 0 on its faces
    on_box = np.abs(outside) < 0.05
    assert np.mean(on_sphere | on_box) > 0.98 and on_sphere.any() and on_box.any()
    # the nearest hit is the box's nearest corner along the display normal
    corners = np.array([[x, y, z] for x in (1.5, 3) for y in (-1, 1) for z in (-3, -1.5)])
    assert record["content_depth"]["near_mm"] == pytest.approx(frame.to_display(corners)[:, 2].min(), abs=0.3)


def test_a_volume_box_is_fitted_and_turned(tmp_path):
    a = lens_array("demo")
    volume = Volume(np.zeros((10, 20, 30), np.int16), (1.0, 1.0, 2.0), name="phantom")
    content = volume_content(volume, a, orientation="coronal")
    record = write_layout(content, a, tmp_path / "vol.png", size=SIZE)
    check_picture(tmp_path / "vol.png")
    box = content.box
    size = box.max(axis=0) - box.min(axis=0)
    # coronal: patient x (10 mm) across, z (60 mm) up, y (20 mm) in depth; 0.9 of the panel's height
    assert size[1] == pytest.approx(0.9 * 24.0) and size[0] == pytest.approx(10 / 60 * 0.9 * 24.0)
    assert size[2] == pytest.approx(20 / 60 * 0.9 * 24.0)
    marks = dict(content.marks)
    centre = box.mean(axis=0)
    assert marks["L"][0] > centre[0] and marks["S"][1] > centre[1] and marks["A"][2] < centre[2]
    assert record["content_depth"]["outside"] == 0.0


def test_a_deep_model_shows_its_share_outside_the_budget(tmp_path):
    # a thin rod along z, 4x the panel's height deep at its fitted scale: most of it outside
    (tmp_path / "rod.obj").write_text("v -1 -1 0\nv 1 -1 0\nv 0 1 0\nv 0 0 -40\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 3 1 4\n")
    record = layout(tmp_path / "rod.obj", tmp_path / "rod.png", lens_array("demo"), size=SIZE,
                    model={"up": "y"})
    depth = record["content_depth"]
    assert depth["far_mm"] - depth["near_mm"] > 24.0 and depth["outside"] > 0


def test_bad_input_is_one_line_and_leaves_the_output(tmp_path, cli):
    out = tmp_path / "out.png"
    out.write_bytes(b"previous")
    for args in (["missing.pov"], [str(tmp_path / "x.xyz")], [str(ANT), "--size", "10x10"],
                 [str(ANT), "--rotate", "1,2"], [str(tmp_path / "none.nii")]):
        assert one_error_line(cli("layout", *args, "-o", out, cwd=tmp_path))
    assert out.read_bytes() == b"previous" and not out.with_suffix(".json").exists()
    assert "must be a .png" in one_error_line(cli("layout", str(ANT), "-o", tmp_path / "o.jpg"))


@pytest.mark.povray
def test_the_command_is_quiet_headless(tmp_path):
    # a separate process with no display: VTK's X-server complaint must not reach the user
    out = tmp_path / "ant.png"
    done = subprocess.run([sys.executable, "-m", "povh3d.cli", "layout", str(ANT), "-o", str(out),
                           "--size", "400x300"], capture_output=True, text=True, timeout=120, check=False,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(Path(__file__).resolve().parents[2]),
                               "HOME": str(tmp_path)})
    assert done.returncode == 0, done.stderr
    assert done.stderr.strip() == "", done.stderr
    assert out.is_file() and done.stdout.startswith(str(out))


def frog() -> Volume:
    """PyVista's segmented frog (500 x 470 x 136 voxels, 30 labels), read here with PyVista itself."""
    grid = pv.read(Path(pv.__file__).parent / "examples" / "frog_tissues.vti")
    values = np.asarray(grid.point_data[grid.array_names[0]]).reshape(grid.dimensions, order="F")
    return Volume(values, tuple(grid.spacing), tuple(grid.origin), name="frog_tissues.vti")


def test_frog_tissues_layout_shows_its_labels_inside_its_box(tmp_path):
    a = lens_array("demo")
    content = volume_content(frog(), a, orientation="axial")
    write_layout(content, a, tmp_path / "frog.png", size=SIZE)
    check_picture(tmp_path / "frog.png")
    assert len(content.faces) > 1000 and content.record["shape"] == "labels"
    lo, hi = content.box.min(axis=0), content.box.max(axis=0)
    assert np.all(content.vertices >= lo - 1e-9) and np.all(content.vertices <= hi + 1e-9)
    # the labels fill most of the box's width (the frog is not a speck in a corner)
    assert np.ptp(content.vertices[:, 0]) > 0.6 * (hi[0] - lo[0])


def test_an_iso_value_outside_the_data_names_the_range():
    from povh3d.errors import ConfigError

    volume = Volume(np.linspace(-5, 5, 6 * 7 * 8).reshape(6, 7, 8), (1.0, 1.0, 1.0))
    with pytest.raises(ConfigError, match=r"-5 \.\. 5"):
        volume_content(volume, lens_array("demo"), iso=(9.0,))
    # scalar values rising through the box: the iso-surface at 0 crosses it
    content = volume_content(volume, lens_array("demo"), iso=(0.0,))
    assert len(content.faces) > 0 and content.record["shape"] == "iso"


@pytest.mark.parametrize("preset, overrides", [("alioscopy-42", {}), ("hex-5.6", {}),
                                               ("demo", {"lens_rotation": 10.0})])
def test_lenticular_hex_and_rotated_arrays_are_drawn(tmp_path, preset, overrides):
    (tmp_path / "tet.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    a = lens_array(preset, **overrides)
    record = check_picture_of(layout(tmp_path / "tet.obj", tmp_path / "tet.png", a, size=SIZE),
                              tmp_path / "tet.png")
    assert record["kind"] == "layout"
    assert record["setup"]["cone_half_angles_deg"][0] == pytest.approx(a.viewing_angle_deg / 2)
    assert (record["setup"]["cone_half_angles_deg"][1] is None) == (a.grid == "lenticular")


def test_the_share_outside_is_a_share_of_the_surface(tmp_path):
    # a flat square (two triangles) in the plane x = 0, 1 wide in y and 4 deep in z, centred:
    # scaled to fill 0.9 of the panel's height (21.6 mm) it is 86.4 mm deep, and the budget
    # (24 mm) holds 24 / 86.4 of it: the rest lies outside, half in front and half behind
    (tmp_path / "sq.obj").write_text("v 0 -0.5 -2\nv 0 0.5 -2\nv 0 0.5 2\nv 0 -0.5 2\nf 1 2 3\nf 1 3 4\n")
    record = layout(tmp_path / "sq.obj", tmp_path / "sq.png", lens_array("demo"), size=SIZE, model={"up": "y"})
    depth = record["content_depth"]
    assert depth["depth_mm"] == pytest.approx(86.4)
    assert depth["outside"] == pytest.approx(1 - 24 / 86.4, abs=0.01)
    assert depth["front_outside"] == pytest.approx(depth["behind_outside"], abs=0.015)


@pytest.mark.povray
def test_no_opengl_is_one_line_not_a_crash(tmp_path):
    # glvnd finds no EGL driver: VTK falls back to OSMesa, which segfaults the process when it is
    # missing too; povh3d must refuse with one line instead (or draw, where OSMesa is installed)
    out = tmp_path / "ant.png"
    done = subprocess.run([sys.executable, "-m", "povh3d.cli", "layout", str(ANT), "-o", str(out),
                           "--size", "300x200"], capture_output=True, text=True, timeout=120, check=False,
                          env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(Path(__file__).resolve().parents[2]),
                               "HOME": str(tmp_path), "__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json"})
    assert done.returncode in (0, 1), (done.returncode, done.stderr)
    if done.returncode == 1:
        assert done.stderr.strip().splitlines() == [done.stderr.strip()] and "cannot draw" in done.stderr
        assert not out.exists()
    else:
        assert out.is_file()
