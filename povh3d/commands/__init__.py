"""The commands on files (map, refocus, quilt, resample, calibrate, viewer, annotate, bench, layout)."""
