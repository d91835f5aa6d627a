"""Model orientation: every --up is a proper rotation of the loader's frame that puts up on +y."""

from __future__ import annotations

import numpy as np
import pytest

from povh3d.errors import ConfigError
from povh3d.mesh.load import Part
from povh3d.mesh.orient import UPS, detect_up, model_to_pov, reorient, rotation


@pytest.mark.parametrize("up", UPS)
def test_up_goes_to_plus_y_and_nothing_is_mirrored(up):
    m = model_to_pov(up)
    axis = np.zeros(3)
    axis["xyz".index(up[-1])] = -1.0 if up.startswith("-") else 1.0
    np.testing.assert_allclose(axis @ m.T, [0, 1, 0])
    assert np.linalg.det(m) == pytest.approx(-1)       # right-handed model -> left-handed POV-Ray
    part = Part("p", np.eye(3), np.array([[0, 1, 2]]))
    turned = reorient([part], up)[0].vertices
    # relative to the loader's result it is a rotation: lengths and handedness kept
    r = np.linalg.lstsq(part.vertices, turned, rcond=None)[0]
    assert np.linalg.det(r) == pytest.approx(1)


def test_z_up_front_view_faces_the_viewer():
    m = model_to_pov("z")
    np.testing.assert_allclose(np.array([0, -1, 0]) @ m.T, [0, 0, -1])   # CAD front (-y) toward the viewer
    np.testing.assert_allclose(np.array([1, 0, 0]) @ m.T, [1, 0, 0])     # x stays right


def test_rotation_matches_povray_order():
    # rotate <0, 90, 0> takes +x to -z in POV-Ray's left-handed frame
    np.testing.assert_allclose(np.array([1.0, 0, 0]) @ rotation((0, 90, 0)), [0, 0, -1], atol=1e-12)


def test_detect_up():
    assert detect_up(".glb", np.zeros(3), np.ones(3))[0] == "y"
    assert detect_up(".3mf", np.zeros(3), np.ones(3))[0] == "z"
    # loader frame: file z in [0, 2] -> loader z in [-2, 0]; stands on z = 0, not on y = 0
    assert detect_up(".stl", np.array([-1, -1, -2.0]), np.array([1, 1, 0.0]))[0] == "z"
    assert detect_up(".stl", np.array([-1, 0, -2.0]), np.array([1, 1, 0.0]))[0] == "y"
    with pytest.raises(ConfigError, match="up"):
        model_to_pov("w")
