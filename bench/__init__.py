"""Benchmarks: each prints one JSON object (`sidewalk bench …`)."""
