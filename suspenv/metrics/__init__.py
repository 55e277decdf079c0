"""Metrics: pure functions from rig results to numbers."""
