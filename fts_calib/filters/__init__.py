"""Filters: the pipeline's settings and the chain every sample goes through before the estimator.

Checks, then quasi-static, dynamic or none; joint rates and the stream latency.
"""
