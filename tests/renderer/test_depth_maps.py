"""The depth maps' 16-bit PNG codes (``image/depth_codes.py``)."""

from __future__ import annotations

import numpy as np


def test_depth_map_codes_round_trip():
    """quantise/dequantise: NaN <-> 0, every finite value back within half a step (hypothesis-style sweep)."""
    from povh3d.image.depth_codes import dequantise, quantise

    rng = np.random.default_rng(7)
    for spread in (1e-3, 1.0, 500.0):
        values = rng.normal(-3.0, spread, (40, 30))
        values[rng.random(values.shape) < 0.2] = np.nan
        codes, scale, offset = quantise(values)
        back = dequantise(codes, scale, offset)
        assert ((codes == 0) == np.isnan(values)).all() and codes.max() == 65535 and codes[codes > 0].min() == 1
        assert np.nanmax(np.abs(back - values)) <= scale / 2 * (1 + 1e-9)
    codes, scale, offset = quantise(np.full((2, 2), np.nan))
    assert (codes == 0).all()
