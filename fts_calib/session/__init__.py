"""Session: a calibration session and its runs over a source.

Samples in, a calibration out: its fit check, diagnosis, held-out units and checkpoint.
"""
