"""Pipeline: settings, sample checks, the quasi-static filter, the calibration session and its runs on recordings and live feeds.

Knows nothing of the command line or plots.
"""
