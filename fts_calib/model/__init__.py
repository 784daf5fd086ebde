"""Model: the sensor, its model families, the estimator and its choice of model, the calibration and its file.

The sensor: channel layout (P), its file, channel limits. Knows nothing of robots, other files or sources.
"""
