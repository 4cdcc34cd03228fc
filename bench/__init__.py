"""Benchmarks: they print figures; tests keep only generous sanity bounds."""
