"""Benchmarks and the literature baselines they compare against."""
