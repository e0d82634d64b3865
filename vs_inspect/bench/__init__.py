"""Benchmarks that print tables (speed and accuracy are measured here, not in timed tests)."""
