"""Calibration: measure the machine on the wall: `pattern` (the marks to draw and measure) and
`fit` (machine values from the measured distances)."""
