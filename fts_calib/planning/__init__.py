"""Planning: home pose, ruckig sweeps, excitation prediction and trajectory files.

Knows nothing of feeds.
"""
