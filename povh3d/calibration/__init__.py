"""Capture processing (calibrate, undistort, borders, equalise, viewpoints, stitch): SciPy's
optimisers and filters, an optional group (``pip install 'povh3d[calibration]'``)."""

from ..extras import require

require("scipy", "calibration", "capture processing (calibrate, undistort, borders, ...)")
