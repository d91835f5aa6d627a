"""DisplayFrame: the map display mm -> scene units and its inverse; the camera's frame."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.geometry.frame import DisplayFrame, camera_frame, explicit_frame

finite = st.floats(-1e3, 1e3, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(st.tuples(finite, finite, finite), st.tuples(finite, finite, finite).filter(
    lambda n: np.linalg.norm(n) > 1e-3 and np.linalg.norm(np.cross(n, (0, 1, 0))) > 1e-3 * np.linalg.norm(n)),
    st.floats(1e-3, 1e4), st.tuples(finite, finite, finite))
def test_to_display_inverts_to_scene(centre, normal, width, point):
    frame = explicit_frame(centre, normal, width, 100.0, up=(0, 1, 0))
    back = frame.to_display(frame.to_scene(np.array(point)))
    np.testing.assert_allclose(back, point, atol=1e-6 * (1 + np.abs(point).max()))
    np.testing.assert_allclose(frame.to_scene([0, 0, 0]), centre)
    assert not frame.mirrored


def test_camera_frame_of_the_default_camera():
    # POV-Ray's default camera looking at the origin from -z: the native frame scaled by the field.
    frame = camera_frame((0, 0, -10), (0, 0, 1), (1.33, 0, 0), (0, 1, 0), (0, 0, 0), 100.0)
    np.testing.assert_allclose(frame.centre, 0, atol=0)
    np.testing.assert_allclose([frame.axis_x, frame.axis_y, frame.axis_z], np.eye(3))
    assert frame.units_per_mm == pytest.approx(10 * 1.33 / 100)
    mirrored = camera_frame((0, 0, -10), (0, 0, 1), (-1.33, 0, 0), (0, 1, 0), (0, 0, 0), 100.0)
    assert mirrored.mirrored and mirrored.axis_x == (-1.0, 0.0, 0.0)


def test_degenerate_frames_are_refused():
    with pytest.raises(ConfigError, match="looks away"):
        camera_frame((0, 0, -10), (0, 0, -1), (1, 0, 0), (0, 1, 0), (0, 0, 0), 100.0)
    with pytest.raises(ConfigError, match="orthonormal"):
        DisplayFrame(axis_x=(1, 0, 0), axis_y=(1, 0, 0))
