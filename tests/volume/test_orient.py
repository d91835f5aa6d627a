"""Orientation presets: radiological views, never a mirror (oracles from the LPS definition)."""

import numpy as np
import pytest

from povh3d.errors import ConfigError
from povh3d.volume.grid import Volume
from povh3d.volume.orient import ORIENTATIONS, display_box, lps_to_display, volume_to_display, world_to_display

LEFT, POSTERIOR, SUPERIOR = np.eye(3)


@pytest.mark.parametrize("orientation", ORIENTATIONS)
def test_presets_turn_the_patient_without_mirroring(orientation):
    # POV-Ray's axes are left-handed and LPS right-handed: an unmirrored map has determinant -1.
    m = lps_to_display(orientation)
    assert np.allclose(m @ m.T, np.eye(3))
    assert np.linalg.det(m) == pytest.approx(-1.0)


def test_radiological_conventions():
    # Coronal and axial: the patient's left on the screen's right; coronal and sagittal: head up.
    assert lps_to_display("coronal") @ LEFT == pytest.approx([1, 0, 0])
    assert lps_to_display("axial") @ LEFT == pytest.approx([1, 0, 0])
    assert lps_to_display("coronal") @ SUPERIOR == pytest.approx([0, 1, 0])
    assert lps_to_display("sagittal") @ SUPERIOR == pytest.approx([0, 1, 0])
    # Viewer at -z: coronal sees the face (anterior nearest), axial the feet, sagittal the left side.
    assert lps_to_display("coronal") @ -POSTERIOR == pytest.approx([0, 0, -1])
    assert lps_to_display("axial") @ -SUPERIOR == pytest.approx([0, 0, -1])
    assert lps_to_display("sagittal") @ LEFT == pytest.approx([0, 0, -1])
    # Sagittal from the left: anterior on the screen's left.
    assert lps_to_display("sagittal") @ -POSTERIOR == pytest.approx([-1, 0, 0])


def test_rotate_follows_povray():
    # rotate <0, 0, 90> takes +x to +y in POV-Ray.
    m = volume_to_display("coronal", (0, 0, 90))
    assert m @ LEFT == pytest.approx([0, 1, 0], abs=1e-12)


def test_unknown_orientation_is_one_line():
    with pytest.raises(ConfigError, match="axial, coronal|coronal, axial"):
        lps_to_display("frontal")


def test_box_and_placement():
    v = Volume(np.zeros((10, 20, 5)), (1.0, 0.5, 2.0), origin=(5.0, 0.0, -3.0))
    corners = v.corners()
    assert corners.min(axis=0) == pytest.approx([4.5, -0.25, -4.0])
    assert corners.max(axis=0) == pytest.approx([14.5, 9.75, 6.0])
    lo, hi = display_box(corners, lps_to_display("coronal"))
    assert hi - lo == pytest.approx([10.0, 10.0, 10.0])   # x: i (10 mm), y: k (10 mm), z: j (10 mm)
    w = world_to_display(lps_to_display("coronal"), -(lo + hi) / 2, 2.0)
    centre = (w @ np.r_[corners.mean(axis=0), 1.0])[:3]
    assert centre == pytest.approx([0, 0, 0], abs=1e-12)


def test_bad_spacing_is_a_config_error():
    with pytest.raises(ConfigError, match="spacing"):
        Volume(np.zeros((2, 2, 2)), (1.0, 0.0, 1.0))
