"""The scene's cameras, every statement rewritten for POV-Ray; POV-Ray 3.7's rules on the last one run."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.scene.camera import CameraError, camera_from_log
from povh3d.scene.camera_script import camera_script


def _script(text: str, files: dict[str, str] | None = None) -> str | None:
    found = camera_script(text, (files or {}).get)
    return None if found is None else found.script


def test_every_camera_statement_is_rewritten_with_directives_in_place():
    text = ('#declare E = <1, 2, -3>;\ncamera { location 0 }\n#declare C = camera { location 5 }\n'
            'camera { location E /* here */ look_at 0\n#if (1) angle 40 #else angle 50 #end\n'
            '#debug "x"\n rotate 10*y }\nsphere { 0, 1 }\n')
    script = _script(text)
    assert script.count("povh3d-camera begin") == 2 and script.count("povh3d-camera end") == 2
    assert "sphere { 0, 1 }" in script and "camera {" not in script.replace("#declare C = camera {", "")
    assert "#if (1)" in script and "#else" in script and '#debug "x"' in script
    assert "transform Povh3d_Cam_T rotate 10*y" in script
    assert _script("sphere { 0, 1 }") is None


def test_an_old_version_scene_is_refused():
    with pytest.raises(CameraError, match="#version 3.1"):
        _script("#version 3.1;\ncamera { location -5*z look_at 0 }\n")
    assert _script("#version 3.7;\ncamera { location -5*z look_at 0 }\n") is not None


def test_a_camera_in_a_macro_and_in_an_include_is_rewritten_where_it_is():
    files = {"cam.inc": "#macro Cam() camera { location -5*z } #end\n", "plain.inc": "#declare A = 1;\n"}
    script = _script('#include "plain.inc"\n#include "cam.inc"\nCam()\n', files)
    assert '#include "plain.inc"' in script and '#include "cam.inc"' not in script   # only cameras inlined
    assert "#macro Cam()" in script and "povh3d-camera begin" in script
    assert _script('#include "plain.inc"\n', files) is None


def _log(**values):
    lines = []
    for key, value in values.items():
        for v in np.ravel(value):
            lines.append(f"povh3d-camera {key} {float(v)!r}")
    return "\n".join(lines + ["povh3d-camera end"])


def test_the_last_block_of_the_first_parse_counts():
    first = _log(location=[0, 0, -10], look_at=[0, 0, 0])
    last = _log(location=[0, 0, -20], look_at=[0, 0, 0])
    log = "\n".join(["povh3d-camera parse", "povh3d-camera begin", first, "povh3d-camera begin", last,
                     "povh3d-camera parse", "povh3d-camera begin", first])
    cam = camera_from_log(log)
    assert cam.location == (0.0, 0.0, -20.0) and cam.cameras == 2
    with pytest.raises(CameraError, match="reaches none"):
        camera_from_log("povh3d-camera parse\n")


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


def test_a_camera_from_an_identifier_replays_its_declaration():
    text = ("#declare Camera_0 = camera { location <1, 2, -9> look_at <0, 1, 0> }\n"
            "camera { Camera_0 rotate 30*y }\nsphere { 0, 1 }\n")
    script = _script(text)
    assert "<1, 2, -9>" in script and "rotate 30*y" in script and "#switch (Povh3d_W0)" in script
    with pytest.raises(CameraError, match="cannot find"):
        _script("camera { Elsewhere }\n")


def test_sky_along_the_view_keeps_the_supplied_right_as_povray_does():
    cam = camera_from_log(_log(location=[0, 10, 0], look_at=[0, 0, 0], right=[1.5, 0, 0]))
    np.testing.assert_allclose(cam.direction, [0, -1, 0])
    np.testing.assert_allclose(cam.right, [1.5, 0, 0])
    np.testing.assert_allclose(cam.up, [0, 0, 1])   # direction x right


def test_a_camera_type_no_pose_can_come_from_is_told_from_the_text():
    """Only a perspective camera defines a pose; a mesh_camera's or fisheye's refusal needs no parse."""
    from povh3d.scene.camera_script import written_camera_type

    mesh = "camera { mesh_camera { 1 3 mesh { M } } }\n"
    includes = {"cam.inc": mesh, "persp.inc": "camera { location -5*z look_at 0 }\n"}
    read = includes.get
    assert written_camera_type(mesh, read) == "mesh_camera"
    assert written_camera_type('#include "cam.inc"\nsphere { 0, 1 }\n', read) == "mesh_camera"
    assert written_camera_type("camera { fisheye angle 180 location -z }\n#declare C = camera { fisheye }\n",
                               read) == "fisheye"
    # Controls: anything that may be or become a perspective camera goes to POV-Ray's parse
    assert written_camera_type(mesh + '#include "persp.inc"\n', read) is None   # which one runs: the parse says
    assert written_camera_type("camera { location -5*z look_at 0 }\n", read) is None
    assert written_camera_type("camera { orthographic location -5*z }\n", read) is None   # refused with its place
    assert written_camera_type("#declare C = camera { mesh_camera { 1 3 mesh { M } } }\ncamera { C }\n",
                               read) is None
    assert written_camera_type("sphere { 0, 1 }\n", read) is None


def test_the_camera_scan_reads_files_as_the_tokens_do():
    """``holds_camera``'s one-regex scan against the tokens (``scene.camera.tokens``): the word
    ``camera`` outside comments and strings, and the literal ``#include`` names, on POV-Ray's own
    include files and example scenes and on the corner cases."""
    import glob

    from povh3d.scene.camera import tokens
    from povh3d.scene.camera_script import _camera_word_and_includes, _literal_includes

    texts = ['// camera\n#include "a.inc" /* camera\n */ "camera" #include "b.inc"',
             '#  include "x y.inc"\ncamera {}', "#declare my_camera = 1; #declare camera_x = 1;",
             '"a \\" camera" #include "q.inc"', '#include "one.inc" #include "two.inc" sphere { 0, 1 }']
    files = sorted(glob.glob("/usr/share/povray-3.7/include/*.inc")) + \
        sorted(glob.glob("/usr/share/doc/povray/examples/**/*.pov", recursive=True))[:200]
    texts += [open(f, encoding="latin-1").read() for f in files]
    for text in texts:
        toks = tokens(text)
        word, includes = _camera_word_and_includes(text)
        assert word == any(t.text == "camera" for t in toks), text[:60]
        if not word:   # the scan stops at the first camera; up to there it has every include
            assert includes == _literal_includes(toks), text[:60]
    assert _camera_word_and_includes(texts[0]) == (False, ["a.inc", "b.inc"])
    assert _camera_word_and_includes(texts[1]) == (True, ["x y.inc"])
    # control: a scan that ignored comments and strings finds the commented camera, which the tokens do not
    import re
    assert re.search(r"\bcamera\b", texts[0]) and not any(t.text == "camera" for t in tokens(texts[0]))
