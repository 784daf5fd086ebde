"""Feeds: where samples come from: recordings, the UDP protocol, the synchronizer and replay.

Knows nothing of kinematics or the estimator.
"""
