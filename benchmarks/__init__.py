"""Benchmarks: scripts that print a table and write JSON (``python -m benchmarks.NAME``).

Speed claims in the docs come from these, never from timed unit tests. Each benchmark
measures its baseline in the same run and reports ratios, since machines are noisy.
"""
