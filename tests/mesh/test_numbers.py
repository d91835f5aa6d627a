"""The vectorised number writer: the same text as scene.format, and exact round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from povh3d.errors import ConfigError
from povh3d.mesh.numbers import format_rows, format_vectors
from povh3d.scene.format import pov_vector_list

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(0, 30), st.integers(1, 4)), elements=finite),
       st.integers(1, 6))
def test_same_text_as_scene_format_and_round_trips(array, per_line):
    text = format_vectors(array, per_line)
    if len(array):
        assert text == pov_vector_list(array, per_line)
        back = np.array([float(x) for x in text.replace("<", " ").replace(">", " ").replace(",", " ").split()])
        np.testing.assert_array_equal(back.reshape(array.shape), array)  # bit-exact (also -0.0 == 0.0)
    else:
        assert text == ""


def test_integers_and_templates():
    faces = np.array([[0, 1, 2], [3, 4, 5]], dtype=np.int32)
    assert format_vectors(faces) == pov_vector_list(faces)
    rows = np.array([[0, 1, 2, 7], [3, 4, 5, 8]])
    assert format_rows(rows, "<%d, %d, %d>, %d", 1) == "<0, 1, 2>, 7,\n    <3, 4, 5>, 8"


def test_non_finite_refused():
    with pytest.raises(ConfigError):
        format_vectors(np.array([[0.0, np.nan, 1.0]]))
