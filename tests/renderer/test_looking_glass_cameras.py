"""A Looking Glass preset renders the vendor's camera model: view ``i`` of ``N`` from the scene camera
moved along its right vector by ``D tan((i / (N - 1) - 0.5) cone)``, the frustum sheared so the plane
through ``look_at`` keeps its frame (HoloPlay Core's ``setupVirtualCameraForView``, docs/displays.md).

Oracles: a plain POV-Ray render of the scene through that camera, written here in the scene's own
coordinates from its camera statement (no povh3d code), for tiles 0, 23 and 47; and a floor that
stays a floor: no tile row shows the sky where the scene's own render shows the floor.  Negative
control of both: the oblique orthographic model (``camera_model="orthographic"``).
"""

from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

from povh3d.display.looking_glass import DEVICES
from povh3d.display.quilt import default_viewing_distance, vendor_cameras, view_offsets
from povh3d.image.io import read_png, read_sidecar
from povh3d.image.metrics import psnr
from povh3d.image.quilt import quilt_to_views

PORTRAIT = DEVICES["looking-glass-portrait"]
LOCATION, LOOK_AT, ANGLE = np.array([0.0, 2.2, -7.0]), np.array([0.0, 0.6, 0.0]), 36.0
SKY = (255, 0, 0)   # the background: no lit surface of the scene renders pure red

# A camera above a checkered floor, objects in front of and behind the look_at plane.
BODY = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <1, 0, 0> }
light_source { <-8, 12, -10> rgb 1 }
plane { y, 0 pigment { checker rgb <0.9, 0.9, 0.9> rgb <0.1, 0.2, 0.6> scale 0.8 } finish { ambient 0.3 } }
sphere { <-0.9, 0.6, -1.2>, 0.6 pigment { rgb <0.9, 0.7, 0.2> } finish { ambient 0.3 } }
box { <0.4, 0, 0.8>, <1.4, 1.6, 1.8> pigment { rgb <0.2, 0.8, 0.3> } finish { ambient 0.3 } }
cylinder { <1.8, 0, -2.0>, <1.8, 1.2, -2.0>, 0.25 pigment { rgb <0.8, 0.3, 0.8> } finish { ambient 0.3 } }
"""
SCENE_CAMERA = (f"camera {{ perspective location <{LOCATION[0]}, {LOCATION[1]}, {LOCATION[2]}> "
                f"right x * 4/3 angle {ANGLE} look_at <{LOOK_AT[0]}, {LOOK_AT[1]}, {LOOK_AT[2]}> }}\n")


def vendor_camera(i: int, views: int = 48, cone: float = 40.0) -> str:
    """View ``i``'s camera in scene coordinates, from the camera statement above alone."""
    d = LOOK_AT - LOCATION
    distance = float(np.linalg.norm(d))
    r = np.cross([0.0, 1.0, 0.0], d)      # POV-Ray's look_at: right = sky x direction (left-handed)
    r /= np.linalg.norm(r)
    u = np.cross(d / distance, r)
    s = distance * math.tan((i / (views - 1) - 0.5) * math.radians(cone))
    width = 2 * distance * math.tan(math.radians(ANGLE) / 2)    # the horizontal field at look_at
    height = width / PORTRAIT.aspect                              # the vertical from the device's aspect

    def v(a):
        return "<" + ", ".join(f"{float(x):.12g}" for x in a) + ">"

    return (f"camera {{ perspective location {v(LOCATION + s * r)} direction {v(d - s * r)} "
            f"right {v(width * r)} up {v(height * u)} }}\n")


def plain_render(tmp_path, camera: str, name: str) -> np.ndarray:
    """POV-Ray alone, point-sampled, at the tile size."""
    tw, th = PORTRAIT.tile_size
    script = tmp_path / f"{name}.pov"
    script.write_text(BODY + camera)
    out = tmp_path / f"{name}.png"
    subprocess.run(["povray", f"+I{script}", f"+O{out}", f"+W{tw}", f"+H{th}", "-A", "-D", "+FN8",
                    "File_Gamma=sRGB"], check=True, capture_output=True)
    return read_png(out)[..., :3]


@pytest.fixture(scope="module")
def quilts(tmp_path_factory):
    """The Portrait quilt of the scene under each camera model, point-sampled, and the first sidecar."""
    import povh3d

    folder = tmp_path_factory.mktemp("lkg")
    scene = folder / "floor.pov"
    scene.write_text(BODY + SCENE_CAMERA)
    out = {}
    for model in ("perspective", "orthographic"):
        png = folder / f"{model}.png"
        record = povh3d.render(scene, png, preset="looking-glass-portrait", quality="draft", camera_model=model,
                               use_cache=False)
        quilt = read_png(folder / f"{model}_qs8x6a0.75.png")[..., :3]
        out[model] = (quilt_to_views(quilt, *PORTRAIT.grid), record)
    return out, folder


def test_vendor_offsets_and_the_default_viewer():
    offsets = view_offsets(48, 40.0, 500.0)
    assert offsets[0] == pytest.approx(-500 * math.tan(math.radians(20))) and offsets[-1] == -offsets[0]
    assert offsets[23] == pytest.approx(500 * math.tan(math.radians(-20 / 47)))
    assert np.all(np.diff(offsets) > 0)                                     # view 0 the leftmost
    # HoloPlay Core's 14 deg vertical field: the Portrait's 160.6 mm screen seen from 654 mm
    assert default_viewing_distance(160.6) == pytest.approx(80.3 / math.tan(math.radians(7)))
    # every view's pixel crosses the screen at the same point: the shear keeps the screen's frame
    for cam in vendor_cameras(5, 40.0, 400.0, (120.0, 160.0)):
        loc, dirn = np.array(cam["location"]), np.array(cam["direction"])
        for x, y in ((-0.5, -0.5), (0.3, 0.1)):
            ray = dirn + x * np.array(cam["right"]) + y * np.array(cam["up"])
            hit = loc + ray * (-loc[2] / ray[2])
            assert hit == pytest.approx([120 * x, 160 * y, 0.0], abs=1e-9)


@pytest.mark.povray
@pytest.mark.parametrize("tile", [0, 23, 47])
def test_tiles_equal_a_plain_render_through_the_vendor_camera(quilts, tmp_path, tile):
    (rendered, folder) = quilts
    reference = plain_render(tmp_path, vendor_camera(tile), f"view{tile}")
    views, record = rendered["perspective"]
    assert psnr(views[tile], reference) >= 35.0
    # control: the oblique orthographic model is another picture
    assert psnr(rendered["orthographic"][0][tile], reference) < 35.0
    # control: the neighbouring view is not this one (the test tells views apart)
    assert psnr(views[tile], plain_render(tmp_path, vendor_camera(47 - tile if tile != 23 else 0), "other")) < 35.0
    cm = record["camera_model"]
    assert cm["camera_model"] == "perspective" and cm["viewer_distance_mm"] > 0
    assert record["display"]["quilt"]["camera_model"] == "perspective"
    assert rendered["orthographic"][1]["display"]["quilt"]["camera_model"] == "orthographic"


@pytest.mark.povray
def test_a_floor_stays_a_floor_in_every_tile(quilts, tmp_path):
    rendered, _ = quilts
    own = plain_render(tmp_path, vendor_camera(0, views=2, cone=0.0), "own")   # the scene's own view, the device's aspect
    floor_rows = ~np.any(np.all(own == SKY, axis=-1), axis=1)         # rows the 2D render fills with floor
    assert floor_rows.sum() > 100

    def sky_in_floor_rows(views):
        return int(np.any(np.all(views == SKY, axis=-1), axis=2)[:, floor_rows].sum())

    assert sky_in_floor_rows(rendered["perspective"][0]) == 0
    assert sky_in_floor_rows(rendered["orthographic"][0]) > 0      # control: rays parallel to the normal


ORBIT = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.1, 0.1, 0.2> }
light_source { <-8, 12, -10> rgb 1 }
camera { location <0, 1, -7> look_at <0, 0.6, 0> angle 36 }
sphere { <1.5 * cos(2 * pi * clock), 0.6, 1.5 * sin(2 * pi * clock)>, 0.6 pigment { rgb <0.9, 0.7, 0.2> } }
"""


@pytest.mark.povray
def test_frames_write_a_quilt_and_a_native_image_per_frame_and_a_quilt_video(tmp_path, cli):
    from povh3d.display.looking_glass import visual_json
    from povh3d.image.interleave import extract

    scene, cal = tmp_path / "orbit.pov", tmp_path / "visual.json"
    scene.write_text(ORBIT)
    cal.write_text(visual_json(PORTRAIT.calibration))
    result = cli("render", scene, "--preset", "looking-glass-portrait", "--quality", "draft", "--frames", "0:2",
                 "--clock", "0:0.5", "--calibration", cal, "--video", tmp_path / "orbit.mp4", "-o", tmp_path / "orbit.png")
    assert result.code == 0, result.err
    quilts = []
    for n in range(3):
        quilt = read_png(tmp_path / f"orbit_{n:04d}_qs8x6a0.75.png")
        tiles = quilt_to_views(quilt, *PORTRAIT.grid)
        assert np.array_equal(tiles, extract(read_png(tmp_path / f"orbit_{n:04d}.png"), (1, 48))[0][::-1])
        assert read_png(tmp_path / f"orbit_{n:04d}_native.png").shape == (2048, 1536, 3)
        record = read_sidecar(tmp_path / f"orbit_{n:04d}.png")
        assert record["quilt"]["file"] == f"orbit_{n:04d}_qs8x6a0.75.png" and record["animation"]["frame"] == n
        quilts.append(quilt)
    assert not np.array_equal(quilts[0], quilts[1])          # the clock moved the sphere
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(tmp_path / "orbit.mp4"))
    meta = next(reader)
    assert tuple(meta["size"]) == (3360, 3360)
    decoded = [np.frombuffer(f, np.uint8).reshape(3360, 3360, 3) for f in reader]
    assert len(decoded) == 3 and all(np.array_equal(a, b) for a, b in zip(decoded, quilts))  # lossless
    assert not list(tmp_path.glob(".orbit*"))                 # no staging left


def test_camera_model_is_refused_where_it_chooses_nothing(tmp_path, cli):
    from povh3d.display.display import build_display
    from povh3d.errors import ConfigError
    from tests.conftest import SAMPLE
    from tests.support.cli import one_error_line

    line = one_error_line(cli("render", SAMPLE, "--preset", "demo", "--camera-model", "perspective",
                              "-o", tmp_path / "x.png"))
    assert "--camera-model" in line and not list(tmp_path.glob("*.png"))
    with pytest.raises(ConfigError, match="unknown camera model 'fisheye'"):
        build_display("looking-glass-portrait", camera_model="fisheye")
    assert build_display("looking-glass-portrait").quilt["camera_model"] == "perspective"    # the default
    assert build_display("looking-glass-portrait", camera_model="orthographic").quilt["camera_model"] == "orthographic"


def test_what_traces_the_lens_array_is_refused_with_the_vendor_cameras(tmp_path, cli):
    from tests.conftest import SAMPLE
    from tests.support.cli import one_error_line

    base = ("render", SAMPLE, "--preset", "looking-glass-portrait", "-o", tmp_path / "x.png")
    for extra, words in ((("--depth-maps", tmp_path / "d"), "--depth-maps"), (("--objects", tmp_path / "m"), "masks"),
                         (("--fit-depth", "auto"), "--fit-depth"),
                         (("--quality", "auto", "--max-error", "30"), "--quality auto")):
        line = one_error_line(cli(*base, *extra))
        assert words in line and "--camera-model orthographic" in line, line
    assert not list(tmp_path.rglob("*.png"))


NO_CAMERA = """#version 3.7;
global_settings { assumed_gamma 1.0 }
background { rgb <0.2, 0.3, 0.4> }
light_source { <-300, 400, -600> rgb 1 }
plane { z, 40 pigment { checker rgb 0.9 rgb <0.1, 0.2, 0.6> scale 12 } }
sphere { <-20, 10, -15>, 18 pigment { rgb <0.9, 0.7, 0.2> } }
box { <10, -50, -5>, <40, -10, 25> pigment { rgb <0.2, 0.8, 0.3> } }
"""


@pytest.mark.povray
def test_a_scene_without_a_camera_is_seen_from_the_vendors_default_viewer(tmp_path):
    """In display mm (screen z = 0, viewer on -z): the eye at (D tan t_i, 0, -D), D = (H / 2) / tan(7 deg)."""
    import povh3d

    scene = tmp_path / "nocam.pov"
    scene.write_text(NO_CAMERA)
    record = povh3d.render(scene, tmp_path / "n.png", preset="looking-glass-portrait", quality="draft", use_cache=False)
    views = quilt_to_views(read_png(tmp_path / "n_qs8x6a0.75.png")[..., :3], *PORTRAIT.grid)
    w, h = PORTRAIT.calibration.size_mm
    d = 0.5 * h / math.tan(math.radians(7))
    assert record["camera_model"]["viewer_distance_mm"] == pytest.approx(d, abs=1e-3)

    def camera(i):
        s = d * math.tan((i / 47 - 0.5) * math.radians(40))
        return (f"camera {{ perspective location <{s!r}, 0, {-d!r}> direction <{-s!r}, 0, {d!r}> "
                f"right <{w!r}, 0, 0> up <0, {h!r}, 0> }}\n")

    for tile in (0, 47):
        script = tmp_path / f"plain{tile}.pov"
        script.write_text(NO_CAMERA + camera(tile))
        out = tmp_path / f"plain{tile}.png"
        subprocess.run(["povray", f"+I{script}", f"+O{out}", "+W420", "+H560", "-A", "-D", "+FN8", "File_Gamma=sRGB"],
                       check=True, capture_output=True)
        reference = read_png(out)[..., :3]
        assert psnr(views[tile], reference) >= 35.0
        assert psnr(views[47 - tile], reference) < 35.0          # control: the mirrored view order fails


@pytest.mark.povray
def test_a_second_render_writes_the_quilt_again(tmp_path):
    """The whole-output cache holds the image alone: a Looking Glass render takes the normal path (its
    frames from the image cache), so a deleted quilt is written again."""
    import povh3d

    scene = tmp_path / "nocam.pov"
    scene.write_text(NO_CAMERA)
    kw = dict(preset="looking-glass-portrait", quality="draft", cache_dir=tmp_path / "cache")
    povh3d.render(scene, tmp_path / "n.png", **kw)
    quilt = tmp_path / "n_qs8x6a0.75.png"
    first = read_png(quilt)
    quilt.unlink()
    record = povh3d.render(scene, tmp_path / "n.png", **kw)
    assert np.array_equal(read_png(quilt), first)
    assert record["timings"]["shots_from_cache"] == 48 and "output_from_cache" not in record["timings"]
