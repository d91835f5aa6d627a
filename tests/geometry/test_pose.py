"""DisplayPose: the map display mm -> scene units and its inverse; the camera's frame."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError, param
from povh3d.geometry.pose import DisplayPose, camera_pose, explicit_pose

finite = st.floats(-1e3, 1e3, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.tuples(finite, finite, finite), st.tuples(finite, finite, finite).filter(
    lambda n: np.linalg.norm(n) > 1e-3 and np.linalg.norm(np.cross(n, (0, 1, 0))) > 1e-3 * np.linalg.norm(n)),
    st.floats(1e-3, 1e4), st.tuples(finite, finite, finite))
def test_to_display_inverts_to_scene(centre, normal, width, point):
    frame = explicit_pose(centre, normal, width, 100.0, up=(0, 1, 0))
    back = frame.to_display(frame.to_scene(np.array(point)))
    np.testing.assert_allclose(back, point, atol=1e-6 * (1 + np.abs(point).max()))
    np.testing.assert_allclose(frame.to_scene([0, 0, 0]), centre)
    assert not frame.mirrored


def test_camera_frame_of_the_default_camera():
    # POV-Ray's default camera looking at the origin from -z: the native frame scaled by the field.
    frame = camera_pose((0, 0, -10), (0, 0, 1), (1.33, 0, 0), (0, 1, 0), (0, 0, 0), 100.0)
    np.testing.assert_allclose(frame.centre, 0, atol=0)
    np.testing.assert_allclose([frame.axis_x, frame.axis_y, frame.axis_z], np.eye(3))
    assert frame.units_per_mm == pytest.approx(10 * 1.33 / 100)
    mirrored = camera_pose((0, 0, -10), (0, 0, 1), (-1.33, 0, 0), (0, 1, 0), (0, 0, 0), 100.0)
    assert mirrored.mirrored and mirrored.axis_x == (-1.0, 0.0, 0.0)


def test_degenerate_frames_are_refused():
    with pytest.raises(ConfigError, match="looks away"):
        camera_pose((0, 0, -10), (0, 0, -1), (1, 0, 0), (0, 1, 0), (0, 0, 0), 100.0)
    with pytest.raises(ConfigError, match="orthonormal"):
        DisplayPose(axis_x=(1, 0, 0), axis_y=(1, 0, 0))


# -- the default up: one rule for every normal (issue 22, item 5) ------------------------

def _old_default_up(z):
    """The rule before: ``z`` within 0.999 of the y axis, ``y`` elsewhere (the negative control)."""
    return (0.0, 0.0, 1.0) if abs(z[1]) > 0.999 else (0.0, 1.0, 0.0)


def _largest_turn(normals, up_rule=None):
    """The largest angle (degrees) between the display x axes of neighbouring normals."""
    xs = []
    for n in normals:
        n = np.asarray(n, float) / np.linalg.norm(n)
        up = None if up_rule is None else up_rule(n)
        xs.append(explicit_pose((0, 0, 0), n, 1.0, 1.0, up=up).axis_x)
    dots = np.clip(np.sum(np.array(xs[1:]) * np.array(xs[:-1]), axis=-1), -1, 1)
    return float(np.degrees(np.arccos(dots)).max())


@pytest.mark.parametrize("path", [
    lambda t: (0.0, 1.0, t),       # the path: (0, 1, 0.05) to (0, 1, 0.01) turned the image 180 deg
    lambda t: (0.0, -1.0, t),
    lambda t: (t, 1.0, 1.0),
    lambda t: (1.0, t, 0.0),       # near the x axis
    lambda t: (0.3, t, 1.0),       # near the z axis
])
def test_the_default_up_turns_continuously_with_the_normal(path):
    normals = [path(t) for t in np.geomspace(0.2, 1e-3, 400)]
    assert _largest_turn(normals) < 1.0
    ends = [explicit_pose((0, 0, 0), normals[i], 1.0, 1.0).axis_x for i in (0, -1)]
    assert np.dot(*ends) > 0.5  # no half turn along the way


def test_the_old_threshold_fails_the_continuity_check():
    normals = [(0.0, 1.0, t) for t in np.geomspace(0.2, 1e-3, 400)]
    assert _largest_turn(normals, _old_default_up) > 170


@settings(max_examples=80, deadline=None)
@given(st.tuples(finite, finite, finite).filter(lambda n: np.linalg.norm(n) > 1e-3))
def test_the_default_up_is_the_scene_y_projected_on_the_display(normal):
    n = np.asarray(normal) / np.linalg.norm(normal)
    frame = explicit_pose((0, 0, 0), normal, 1.0, 1.0)
    projected = np.array([0.0, 1.0, 0.0]) - n[1] * n
    if np.linalg.norm(projected) > 1e-6:
        np.testing.assert_allclose(frame.axis_y, projected / np.linalg.norm(projected), atol=1e-9)
        assert abs(frame.axis_x[1]) < 1e-9  # x horizontal
    assert frame.axis_y[1] >= -1e-6  # never upside down (rounding near the pole)


def test_a_normal_along_y_keeps_x_of_a_display_tilted_from_facing_z():
    for sign in (1, -1):
        for deg in (0, 30, 60, 89.9, 89.9999, 90):
            t = np.radians(deg)
            frame = explicit_pose((0, 0, 0), (0, sign * np.sin(t), np.cos(t)), 1.0, 1.0)
            np.testing.assert_allclose(frame.axis_x, (1, 0, 0), atol=1e-9)


def test_a_chosen_up_near_the_y_axis_is_warned_about():
    from povh3d.geometry.pose import up_warning

    assert param("placement.up") in up_warning((0, 1, 0.05))
    assert param("placement.up") in up_warning((0, -1, 0))
    assert up_warning((0, 1, 0.05), up=(0, 0, 1)) is None   # the user's own up
    assert up_warning((0, 0, 1)) is None
    assert up_warning((1, 0.1, 1)) is None
