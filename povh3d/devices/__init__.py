"""Commercial light-field displays: their calibration files and device tables."""
