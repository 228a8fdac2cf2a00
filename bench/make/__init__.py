"""Generators of test drawings for the benchmarks (deterministic): samples.py, varied.py."""
