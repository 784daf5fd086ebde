"""Model: the sensor channel layout (P, paper eqs 1-7), the estimators (eqs 9, 12-16) and the calibration result and its file.

Knows nothing of robots, feeds or files other than its own.
"""
