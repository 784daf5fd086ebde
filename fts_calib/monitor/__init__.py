"""Monitor: the sensor's health in service and the watch of its offsets."""
