"""Simulation: the simulated sensor, recordings, robot logs and services, for the demo and the tests."""
