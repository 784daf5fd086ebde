"""Payload: an unknown payload identified from still or moving samples.

Mass, centre of mass, inertia and offsets, with their standard errors.
"""
