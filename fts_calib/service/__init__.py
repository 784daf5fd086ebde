"""Service: the calibration in use: wrench reader, gravity compensation, re-tare, validation, exports."""
