"""The depth pass's median over colour channels (passes/depth.py) against np.nanmedian, bit for bit:
it replaces NumPy's small-axis path, which imports numpy.ma at render start-up (issue 37)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from povh3d.renderer.passes.depth import nan_median_last


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
def test_same_numbers_as_nanmedian(channels):
    rng = np.random.default_rng(channels)
    values = rng.standard_normal((4000, channels)) * 10 ** rng.uniform(-6, 6, (4000, channels))
    values[rng.random(values.shape) < 0.4] = np.nan
    values[:3] = np.nan   # rows with no number at all
    values[3:6] = 0.25    # ties
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # nanmedian warns on all-NaN rows
        expected = np.nanmedian(values, axis=-1)
    got = nan_median_last(values)
    assert np.array_equal(got, expected, equal_nan=True)
    assert np.isnan(got[:3]).all()
    if channels > 1:  # negative control: the plain median lets one NaN poison the row
        assert not np.array_equal(np.median(values, axis=-1), expected, equal_nan=True)


@pytest.mark.povray   # a process of its own (the --fast guard refuses any)
def test_three_channels_of_an_image_and_no_masked_arrays():
    import subprocess
    import sys

    code = ("import sys, numpy as np; from povh3d.renderer.passes.depth import nan_median_last; "
            "print(nan_median_last(np.array([[[0.2, np.nan, 0.4], [0.1, 0.3, 0.2]]])).tolist(), "
            "'numpy.ma' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["[[0.30000000000000004,", "0.2]]", "False"]
