"""Simulation: the simulated sensor and simulated recordings, for the demo and the tests."""
