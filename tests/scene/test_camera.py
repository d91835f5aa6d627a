"""The scene's camera: the last top-level statement, rewritten for POV-Ray; POV-Ray 3.7's rules."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.scene.camera import CameraError, camera_from_log, evaluation_script


def test_the_last_top_level_camera_is_rewritten_with_directives_in_place():
    text = ('#declare E = <1, 2, -3>;\ncamera { location 0 }\n#declare C = camera { location 5 }\n'
            'camera { location E /* here */ look_at 0\n#if (1) angle 40 #else angle 50 #end\n'
            '#debug "x"\n rotate 10*y }\nsphere { 0, 1 }\n')
    found = evaluation_script(text)
    assert found.cameras == 2
    assert "sphere" not in found.script and found.script.startswith("#declare E")
    assert "#if (1)" in found.script and "#else" in found.script and '#debug "x"' in found.script
    assert "transform Povh3d_Cam_T rotate 10*y" in found.script
    assert evaluation_script("sphere { 0, 1 }") is None


def test_an_old_version_scene_is_refused():
    with pytest.raises(CameraError, match="#version 3.1"):
        evaluation_script("#version 3.1;\ncamera { location -5*z look_at 0 }\n")
    assert evaluation_script("#version 3.7;\ncamera { location -5*z look_at 0 }\n") is not None


def test_a_camera_inside_a_macro_cannot_be_isolated():
    with pytest.raises(CameraError, match="--display-center"):
        evaluation_script("#macro Cam() camera { location -5*z } #end\nCam()\n")


def _log(**values):
    lines = []
    for key, value in values.items():
        for v in np.ravel(value):
            lines.append(f"povh3d-camera {key} {float(v)!r}")
    return "\n".join(lines + ["povh3d-camera end"])


def test_look_at_angle_and_sky_follow_povray_rules():
    cam = camera_from_log(_log(location=[0, 0, -10], right=[4 / 3, 0, 0], angle=[90], look_at=[0, 0, 0]))
    # angle 90: |direction| = |right| / 2 / tan(45 deg)
    np.testing.assert_allclose(cam.direction, [0, 0, 2 / 3])
    np.testing.assert_allclose(cam.right, [4 / 3, 0, 0])
    rolled = camera_from_log(_log(location=[0, 0, -10], sky=[1, 1, 0], look_at=[0, 0, 0]))
    np.testing.assert_allclose(rolled.up, np.array([1, 1, 0]) / np.sqrt(2), atol=1e-12)  # up follows the sky
    flipped = camera_from_log(_log(location=[0, 0, -10], right=[-1.33, 0, 0], look_at=[0, 0, 0]))
    assert flipped.right[0] < 0   # a right-handed scene keeps its mirror
    with pytest.raises(CameraError, match="look_at"):
        camera_from_log(_log(location=[1, 1, 1], look_at=[1, 1, 1]))


def test_a_camera_from_an_identifier_uses_its_declaration():
    text = ("#declare Camera_0 = camera { location <1, 2, -9> look_at <0, 1, 0> }\n"
            "camera { Camera_0 rotate 30*y }\nsphere { 0, 1 }\n")
    script = evaluation_script(text).script
    assert "<1, 2, -9>" in script and "rotate 30*y" in script
    with pytest.raises(CameraError, match="cannot find"):
        evaluation_script("camera { Elsewhere }\n")


def test_sky_along_the_view_keeps_the_supplied_right_as_povray_does():
    cam = camera_from_log(_log(location=[0, 10, 0], look_at=[0, 0, 0], right=[1.5, 0, 0]))
    np.testing.assert_allclose(cam.direction, [0, -1, 0])
    np.testing.assert_allclose(cam.right, [1.5, 0, 0])
    np.testing.assert_allclose(cam.up, [0, 0, 1])   # direction x right
