"""Report: the one-page HTML report of a calibration, its pictures, the comparison of two, and plots."""
