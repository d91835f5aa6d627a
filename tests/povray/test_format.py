import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from povh3d.errors import ConfigError
from povh3d.scene.format import pov_number, pov_vector, pov_vector_list


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_numbers_round_trip_exactly(x):
    assert float(pov_number(x)) == x or (x == 0 and pov_number(x) == "0")


def test_formats():
    assert pov_number(2.0) == "2"
    assert pov_number(-0.0) == "0"
    assert pov_number(1e-17) == "1e-17"
    assert pov_vector((1.5, -2, 0.1)) == "<1.5, -2, 0.1>"
    assert pov_vector_list(np.array([[0, 1, 2], [3, 4, 5]])) == "<0, 1, 2>, <3, 4, 5>"


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_is_refused(bad):
    with pytest.raises(ConfigError):
        pov_number(bad)
    with pytest.raises(ConfigError):
        pov_vector_list(np.array([[bad, 0.0]]))
