"""Service: the calibration in use: wrench reader, gravity compensation, tare, payload identification, validation, exports."""
