"""Evaluation: scoring maps, TABLE II-style benchmarks, CSW trade-off sweeps, min-cost
histograms, and their plots."""
